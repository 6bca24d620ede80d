/*
 * volux/image.h — a linear RGB float image (plain value type).
 *
 * Pixels are row-major from the top-left, 3 floats each. Owned by whoever
 * created it; free with volux_image_free(). Readers/writers are in io.h.
 */
#ifndef VOLUX_IMAGE_H
#define VOLUX_IMAGE_H

#include "base.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VOLUX_MAX_IMAGE_DIM 32768

typedef struct volux_image {
    int width, height;
    float *rgb; /* width·height·3 floats */
} volux_image;

/* Allocates a zeroed image through ctx (validates sizes first). */
VOLUX_API volux_status volux_image_create(volux_context *ctx, int width, int height, volux_image *out);
/* Frees pixels allocated by volux_image_create or an io reader; resets *img. */
VOLUX_API void volux_image_free(volux_context *ctx, volux_image *img);
/* Deep copy. */
VOLUX_API volux_status volux_image_copy(volux_context *ctx, const volux_image *src, volux_image *out);

/* Error metrics between two images of the same size, over all channels:
 * rmse, rel_mse = mean((a−b)²/(b²+eps)) with b the reference (eps = 1e-2
 * as in Rousselle et al.'s relMSE), psnr = 20·log10(peak/rmse) with peak =
 * max of the reference (1 if it is ≤ 0), max_abs. VOLUX_ERR_INVALID when
 * the sizes differ or either image holds a NaN or an infinity. */
typedef struct volux_image_error {
    double rmse, rel_mse, psnr, max_abs;
} volux_image_error;

VOLUX_API volux_status volux_image_compare(volux_context *ctx, const volux_image *a,
                                           const volux_image *reference, volux_image_error *out);

#ifdef __cplusplus
}
#endif
#endif
