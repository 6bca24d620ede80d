/*
 * examples/beer_lambert.c — volux from C, end to end, with an answer we know.
 *
 * Builds a homogeneous box in the program's own memory (no file), lends it to
 * volux without a copy, renders it with the emission–absorption technique
 * `ea` against a white background, and checks the centre pixel against
 * Beer–Lambert: a black medium of extinction σt over a path of length d lets
 * through exactly T = exp(−σt·d) of the background.
 *
 * Build against an installed volux:
 *     cc -std=c11 beer_lambert.c $(pkg-config --cflags --libs volux) -o beer_lambert
 * or with CMake: find_package(volux) and link volux::volux (examples/CMakeLists.txt).
 * Run: ./beer_lambert [out.png]   (exit status 0 when the check holds)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <volux/volux.h>

enum { N = 32 };               /* nodes per axis                         */
static const double SPACING = 0.5; /* world units between nodes           */
static const float SIGMA_T = 0.1f; /* extinction, 1 / world unit          */

static int fail(volux_context *ctx, const char *what) {
    fprintf(stderr, "beer_lambert: %s: %s\n", what, volux_context_error(ctx));
    return 1;
}

int main(int argc, char **argv) {
    printf("volux %s (compiled against %s)\n", volux_version(), VOLUX_VERSION);
    volux_context *ctx;
    if (volux_context_create(NULL, &ctx) != VOLUX_OK) return 1;

    /* The caller's field: all ones, x fastest. volux borrows it; it must
     * outlive the volume (released below, before the free). */
    float *field = malloc(sizeof(float) * N * N * N);
    if (!field) return 1;
    for (int i = 0; i < N * N * N; i++) field[i] = 1.0f;
    volux_volume_memory_desc md = {.dims = {N, N, N}, .type = VOLUX_FLOAT32, .data = field,
                                   .spacing = {SPACING, SPACING, SPACING}, .mode = VOLUX_MEMORY_BORROW};
    volux_volume *vol = NULL;
    volux_scene *scene = NULL;
    volux_technique *tech = NULL;
    volux_framebuffer *fb = NULL;
    volux_image img = {0};
    int status = 1;
    if (volux_volume_from_memory(ctx, &md, &vol) != VOLUX_OK) {
        status = fail(ctx, "volume");
        goto done;
    }

    /* A black medium of constant extinction: only absorption is seen. */
    volux_tf_color_point black[] = {{0.0f, 0, 0, 0}, {1.0f, 0, 0, 0}};
    volux_tf_scalar_point sigma[] = {{0.0f, SIGMA_T}, {1.0f, SIGMA_T}};
    volux_transfer_desc tf;
    volux_transfer_desc_defaults(&tf);
    tf.color = black, tf.n_color = 2;
    tf.opacity = sigma, tf.n_opacity = 2, tf.extinction = 1;

    /* An orthographic camera looking down −Z through the box's centre. */
    volux_camera_desc cam;
    volux_camera_desc_defaults(&cam);
    cam.projection = VOLUX_ORTHOGRAPHIC, cam.use_orbit = 0;
    cam.eye = (volux_vec3){0, 0, 50}, cam.look_at = (volux_vec3){0, 0, 0}, cam.up = (volux_vec3){0, 1, 0};
    cam.height = 40.0f;

    volux_render_settings rs;
    volux_render_settings_defaults(&rs);
    rs.width = rs.height = 33; /* odd: pixel 16 is centred on the axis */
    rs.spp = 1;

    if (volux_scene_create(ctx, &scene) || volux_scene_set_volume(scene, vol) ||
        volux_scene_set_transfer(scene, &tf) || volux_scene_set_camera(scene, &cam) ||
        volux_scene_set_render(scene, &rs)) {
        status = fail(ctx, "scene");
        goto done;
    }
    volux_scene_set_background(scene, (volux_vec3){1, 1, 1});
    if (volux_technique_create(ctx, "ea", scene, &tech) || volux_framebuffer_create(ctx, rs.width, rs.height, &fb) ||
        volux_render(tech, scene, fb, NULL, NULL) || volux_framebuffer_resolve(fb, &img)) {
        status = fail(ctx, "render");
        goto done;
    }

    /* Node-centred: the box spans (N − 1)·spacing along z. */
    double depth = (N - 1) * SPACING, expected = exp(-SIGMA_T * depth);
    const float *c = img.rgb + 3 * ((rs.height / 2) * rs.width + rs.width / 2);
    printf("centre pixel %.6f %.6f %.6f, Beer-Lambert exp(-%.2f x %.2f) = %.6f\n", c[0], c[1], c[2], SIGMA_T,
           depth, expected);
    status = 0;
    for (int ch = 0; ch < 3; ch++)
        if (fabs(c[ch] - expected) > 1e-4 * expected) status = 1;
    /* A corner pixel misses the box and sees the background. */
    if (fabsf(img.rgb[0] - 1.0f) > 1e-6f) status = 1;
    if (argc > 1 && volux_image_save(ctx, argv[1], &img, 0.0f) != VOLUX_OK) status = fail(ctx, argv[1]);
    printf("%s\n", status == 0 ? "ok" : "MISMATCH");

done:
    volux_image_free(ctx, &img);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(tech);
    volux_scene_destroy(scene);
    volux_volume_release(vol); /* the last reference: volux stops reading `field` */
    free(field);
    volux_context_destroy(ctx);
    return status;
}
