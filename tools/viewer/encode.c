/*
 * tools/viewer/encode.c — JPEG frames for the event stream (libjpeg-turbo's
 * libjpeg API). The pixels are tone-mapped exactly as PNG output is
 * (volux_image_to_srgb8), so a JPEG preview differs from the PNG of the
 * same image only by the JPEG's own compression error.
 */
#include <stdio.h>
#include <stdlib.h>

#include <jpeglib.h>
#include <setjmp.h>

#include "viewer.h"

typedef struct jpeg_failure {
    struct jpeg_error_mgr mgr;
    jmp_buf jump;
} jpeg_failure;

static void on_jpeg_error(j_common_ptr c) {
    jpeg_failure *f = (jpeg_failure *)c->err;
    longjmp(f->jump, 1);
}

static void on_jpeg_message(j_common_ptr c) { (void)c; } /* no printing */

int viewer_encode_jpeg(const volux_image *img, float exposure, int quality, unsigned char **out, size_t *size) {
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    unsigned char *rgb = malloc(n);
    if (!rgb) return 0;
    volux_image_to_srgb8(img, exposure, rgb);
    struct jpeg_compress_struct c;
    jpeg_failure fail;
    c.err = jpeg_std_error(&fail.mgr);
    fail.mgr.error_exit = on_jpeg_error;
    fail.mgr.output_message = on_jpeg_message;
    /* volatile: they change between setjmp and a possible longjmp */
    unsigned char *volatile buf = NULL;
    unsigned long volatile len = 0;
    if (setjmp(fail.jump)) {
        jpeg_destroy_compress(&c);
        free(buf);
        free(rgb);
        return 0;
    }
    jpeg_create_compress(&c);
    jpeg_mem_dest(&c, (unsigned char **)&buf, (unsigned long *)&len);
    c.image_width = (JDIMENSION)img->width;
    c.image_height = (JDIMENSION)img->height;
    c.input_components = 3;
    c.in_color_space = JCS_RGB;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, quality, TRUE);
    /* 4:4:4: thin coloured structures (TF bands) stay sharp */
    for (int i = 0; i < c.num_components; i++) c.comp_info[i].h_samp_factor = c.comp_info[i].v_samp_factor = 1;
    c.dct_method = JDCT_ISLOW;
    jpeg_start_compress(&c, TRUE);
    while (c.next_scanline < c.image_height) {
        JSAMPROW row = rgb + (size_t)c.next_scanline * (size_t)img->width * 3;
        jpeg_write_scanlines(&c, &row, 1);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    free(rgb);
    *out = buf;
    *size = len;
    return 1;
}
