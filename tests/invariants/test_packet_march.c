/* The shared packet march of the illuminated ray casters
 * (render/packet_impl.h with each technique's lane hook: lightvol's and
 * ao's as gathers, single's scalar shading per lane) against their scalar
 * marches (volux_ea_march for lightvol, scatter_march for single and ao),
 * forced with `march_kernel: "scalar"` against the dispatched SIMD one:
 * the same image within a stated float tolerance on every storage type,
 * perspective and orthographic, with and without skipping and early
 * termination (and pre-integration for lightvol); the 16- and 8-lane
 * widths bit-identical; thread-count independence; skipping exact; the
 * parameter validated.
 *
 * Tolerances, relative to the largest pixel value of the scalar image (the
 * scenes' radiance reaches ~0.4–3 under two directional lights and an
 * environment):
 *   - lightvol with pre-integration: the float integral tables of the dvr
 *     kernels (their bound, docs in dvr_simd_impl.h): max 1e-4, mean 1e-6;
 *   - without pre-integration the samples are bit-identical; differences
 *     are the vector exp (≤ 2 ulp; scatter_march's volux_exp_nonpos_t6 is
 *     within 4.1e-6 relative), T −= T·α against T·(1 − α), and the hook's
 *     product order (albedo·c·L_s): max 4e-6, mean 1e-7.
 * Measured (AMD EPYC with AVX-512): plain max 8.6e-7 / mean 1.5e-8 (ao), pre-
 * integrated max 1.3e-5 / mean 8.1e-8 (lightvol); the test prints them. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/packet.h"
#include "test_util.h"

enum { NX = 40, NY = 36, NZ = 44, W = 37, H = 29 };

typedef struct storage_case {
    const char *type;
    double lo, hi;
    int bytes;
} storage_case;

static const storage_case storages[] = {
    {"uint8", 0, 255, 1},
    {"uint16", 0, 65535, 2},
    {"int16", -1000, 3000, 2},
    {"float32", -2.5, 7.5, 4},
};

/* shells, a blob and empty corners (as test_ea_fastpath.c) */
static double field(int i, int j, int k) {
    double x = (i + 0.5) / NX - 0.5, y = (j + 0.5) / NY - 0.5, z = (k + 0.5) / NZ - 0.5;
    double r = sqrt(x * x + y * y + z * z);
    double shells = 0.5 + 0.5 * cos(18.0 * r) * exp(-4.0 * r);
    double blob = exp(-60.0 * ((x - 0.15) * (x - 0.15) + (y + 0.1) * (y + 0.1) + z * z));
    double v = r > 0.45 ? 0.0 : 0.75 * shells + 0.25 * blob;
    return v < 0.0 ? 0.0 : v > 1.0 ? 1.0 : v;
}

static const char *write_volume(const storage_case *sc) {
    size_t n = (size_t)NX * NY * NZ;
    unsigned char *buf = malloc(n * (size_t)sc->bytes);
    assert_non_null(buf);
    size_t p = 0;
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++, p++) {
                double v = sc->lo + (sc->hi - sc->lo) * field(i, j, k);
                if (!strcmp(sc->type, "uint8")) {
                    buf[p] = (unsigned char)lround(v);
                } else if (!strcmp(sc->type, "uint16")) {
                    uint16_t u = (uint16_t)lround(v);
                    memcpy(buf + 2 * p, &u, 2);
                } else if (!strcmp(sc->type, "int16")) {
                    int16_t u = (int16_t)lround(v);
                    memcpy(buf + 2 * p, &u, 2);
                } else {
                    float f = (float)v;
                    memcpy(buf + 4 * p, &f, 4);
                }
            }
    char name[64];
    snprintf(name, sizeof name, "packet_%s.raw", sc->type);
    const char *path = tu_write_file(name, buf, n * (size_t)sc->bytes);
    free(buf);
    return strrchr(path, '/') + 1;
}

/* The techniques under test and the settings they take. */
typedef struct tech_case {
    const char *name;
    int has_preint; /* the `preintegrate` parameter */
    const char *extra; /* further technique parameters (JSON members) */
} tech_case;

static const tech_case techs[] = {
    {"lightvol", 1, "\"scale\": 0.5, \"env_directions\": 4"},
    {"single", 0, "\"env_directions\": 4, \"emission\": 0.3"},
    {"ao", 0, "\"radius\": 4, \"directional\": false, \"emission\": 0.3"}, /* the packet march shades the isotropic model */
    {"ambient", 0, "\"offset\": 0, \"radius\": 4, \"emission\": 0.3"}, /* lag 0 only */
};
enum { N_TECHS = sizeof techs / sizeof techs[0] };

static int g_point_light = 0; /* add a point light (ao: the per-lane scalar hook) */
static double g_aniso = 0.3;  /* HG g of the TF (lightvol: g = 0 reads only the RGB channels) */

static volux_scene *make_scene(volux_context *ctx, const tech_case *tc, const storage_case *sc, const char *file,
                               int ortho, int preint, int skip, double early) {
#define S_(f) (sc->lo + (sc->hi - sc->lo) * (f))
    char json[4096], params[512];
    snprintf(params, sizeof params, "\"skip_empty\": %s, \"early_termination\": %g, %s%s", skip ? "true" : "false",
             early, tc->extra, tc->has_preint ? (preint ? ", \"preintegrate\": true" : ", \"preintegrate\": false") : "");
    snprintf(json, sizeof json,
             "{\"volume\": {\"file\": \"%s\", \"dims\": [%d, %d, %d], \"type\": \"%s\", \"endian\": \"little\"},"
             " \"transfer_function\": {"
             "   \"opacity\": [[%g, 0], [%g, 0], [%g, 0.5], [%g, 0.02], [%g, 0.02], [%g, 0.9], [%g, 0.95]],"
             "   \"color\": [[%g, 0.2, 0.4, 1], [%g, 1, 0.9, 0.6], [%g, 1, 0.4, 0.1], [%g, 1, 1, 1]],"
             "   \"albedo\": 0.8, \"anisotropy\": %g},"
             " \"camera\": {%s\"orbit\": {\"azimuth\": %s, \"elevation\": %s}},"
             " \"background\": [0.1, 0.2, 0.3],"
             " \"lights\": [{\"type\": \"directional\", \"direction\": [-1, -0.5, -0.8], \"irradiance\": 15},"
             "              {\"type\": \"directional\", \"direction\": [0.6, -1, 0.2], \"irradiance\": 7,"
             "               \"color\": [1, 0.7, 0.4]},"
             "              {\"type\": \"environment\", \"radiance\": 0.2, \"color\": [0.6, 0.75, 1.0]}%s],"
             " \"render\": {\"width\": %d, \"height\": %d, \"spp\": 2, \"step\": 0.45},"
             " \"techniques\": {\"%s\": {%s}}}",
             file, NX, NY, NZ, sc->type, S_(0), S_(0.3), S_(0.36), S_(0.42), S_(0.6), S_(0.8), S_(1.0), S_(0),
             S_(0.36), S_(0.7), S_(1.0), g_aniso, ortho ? "\"type\": \"orthographic\", " : "", ortho ? "-60" : "35",
             ortho ? "10" : "25",
             g_point_light ? ", {\"type\": \"point\", \"position\": [0.9, 0.8, -0.7], \"intensity\": 0.8}" : "", W, H,
             tc->name, params);
#undef S_
    return tu_scene(ctx, json);
}

static volux_image render_with(volux_context *ctx, volux_scene *s, const char *tech, const char *kernel) {
    assert_int_equal(volux_scene_set_param(s, tech, "march_kernel", 0, kernel), VOLUX_OK);
    return tu_render(ctx, s, tech);
}

static double image_max(const volux_image *a) {
    double m = 0.0;
    for (int i = 0; i < a->width * a->height * 3; i++) m = fmax(m, fabs((double)a->rgb[i]));
    return m;
}

static double mean_abs_diff(const volux_image *a, const volux_image *b) {
    double sum = 0.0;
    size_t n = (size_t)a->width * (size_t)a->height * 3;
    for (size_t i = 0; i < n; i++) sum += fabs((double)a->rgb[i] - (double)b->rgb[i]);
    return sum / (double)n;
}

static int simd_or_skip(void) {
    if (volux_packet_avx2_available()) return 1;
    fprintf(stderr, "(no AVX2+FMA on this CPU: the packet march is not available, nothing to compare)\n");
    return 0;
}

static void simd_matches_scalar(const tech_case *tc) {
    volux_context *ctx = tu_context(2);
    double worst[2] = {0, 0}, worst_mean[2] = {0, 0};
    int compared = 0;
    for (size_t t = 0; t < sizeof storages / sizeof storages[0]; t++) {
        const char *file = write_volume(&storages[t]);
        for (int ortho = 0; ortho < 2; ortho++)
            for (int preint = 0; preint < (tc->has_preint ? 2 : 1); preint++)
                for (int skip_empty = 0; skip_empty < 2; skip_empty++) {
                    double early = skip_empty ? 0.002 : 0.0;
                    volux_scene *s = make_scene(ctx, tc, &storages[t], file, ortho, preint, skip_empty, early);
                    volux_image a = render_with(ctx, s, tc->name, "scalar"), b = render_with(ctx, s, tc->name, "simd");
                    double scale = image_max(&a);
                    /* the test is not vacuous: the lit volume is brighter than the sky (≤ 0.2) */
                    if (!(scale > 0.3)) fail_msg("%s %s: the image is dark (max %g)", tc->name, storages[t].type, scale);
                    double d = tu_max_abs_diff(&a, &b) / scale, m = mean_abs_diff(&a, &b) / scale;
                    double tol = preint ? 1e-4 : 4e-6, tol_mean = preint ? 1e-6 : 1e-7;
                    if (d > worst[preint]) worst[preint] = d;
                    if (m > worst_mean[preint]) worst_mean[preint] = m;
                    if (!(d <= tol) || !(m <= tol_mean))
                        fail_msg("%s %s %s preint=%d skip=%d point=%d: SIMD vs scalar max %g (tol %g), mean %g "
                                 "(tol %g), relative to %g",
                                 tc->name, storages[t].type, ortho ? "ortho" : "persp", preint, skip_empty,
                                 g_point_light, d, tol, m, tol_mean, scale);
                    compared++;
                    volux_image_free(ctx, &a);
                    volux_image_free(ctx, &b);
                    volux_scene_destroy(s);
                }
    }
    fprintf(stderr, "%s%s (g %g): worst relative SIMD-scalar difference: plain max %.3g mean %.3g", tc->name,
            g_point_light ? " (point light)" : "", g_aniso, worst[0], worst_mean[0]);
    if (tc->has_preint) fprintf(stderr, ", pre-integrated max %.3g mean %.3g", worst[1], worst_mean[1]);
    fprintf(stderr, "\n");
    assert_int_equal(compared, 4 * 2 * (tc->has_preint ? 2 : 1) * 2);
    /* the packet march ran: its rounding differs from the scalar march's
     * somewhere (identical images everywhere would mean "simd" fell back) */
    if (!(worst[0] > 0.0)) fail_msg("%s: SIMD and scalar images are identical: was the packet march used?", tc->name);
    volux_context_destroy(ctx);
}

static void test_lightvol_simd_matches_scalar(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    simd_matches_scalar(&techs[0]); /* g ≠ 0: all 6 channels (RGB + mean light direction) */
    g_aniso = 0.0;                  /* g = 0: the RGB channels only */
    simd_matches_scalar(&techs[0]);
    g_aniso = 0.3;
}

static void test_single_simd_matches_scalar(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    simd_matches_scalar(&techs[1]);
}

static void test_ambient_simd_matches_scalar(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    simd_matches_scalar(&techs[3]);
}

/* ambient's default offset lags the camera transmittance: "auto" keeps the
 * scalar march (same image as "scalar"), "simd" is refused with the reason. */
static void test_ambient_with_offset_keeps_scalar(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    const char *file = write_volume(&storages[0]);
    volux_scene *s = make_scene(ctx, &techs[3], &storages[0], file, 0, 0, 1, 0.002);
    assert_int_equal(volux_scene_set_param(s, "ambient", "offset", 0.5, NULL), VOLUX_OK);
    volux_image a = render_with(ctx, s, "ambient", "scalar"), b = render_with(ctx, s, "ambient", "auto");
    assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * W * H);
    if (volux_packet_avx2_available()) {
        volux_technique *t = NULL;
        assert_int_equal(volux_scene_set_param(s, "ambient", "march_kernel", 0, "simd"), VOLUX_OK);
        volux_context_clear_error(ctx);
        assert_int_equal(volux_technique_create(ctx, "ambient", s, &t), VOLUX_ERR_UNSUPPORTED);
        assert_non_null(strstr(volux_context_error(ctx), "techniques.ambient.offset 0"));
    }
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_ao_simd_matches_scalar(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    simd_matches_scalar(&techs[2]);
    g_point_light = 1; /* the per-lane scalar hook */
    simd_matches_scalar(&techs[2]);
    g_point_light = 0;
}

/* Both widths: the same code over two vocabularies of the same IEEE
 * operations lane by lane, so the same bits. */
static void test_widths_are_bit_identical(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    if (!volux_packet_avx512_available()) {
        fprintf(stderr, "(no AVX-512 on this CPU: only the 8-lane march runs, nothing to compare)\n");
        skip();
    }
    volux_context *ctx = tu_context(2);
    for (int k = 0; k < N_TECHS; k++)
        for (size_t t = 0; t < sizeof storages / sizeof storages[0]; t++) {
            const char *file = write_volume(&storages[t]);
            for (int preint = 0; preint < (techs[k].has_preint ? 2 : 1); preint++) {
                volux_scene *s = make_scene(ctx, &techs[k], &storages[t], file, t % 2, preint, 1, 0.002);
                volux_image a = render_with(ctx, s, techs[k].name, "simd");
                volux_image b = render_with(ctx, s, techs[k].name, "avx2");
                if (memcmp(a.rgb, b.rgb, sizeof(float) * 3 * W * H))
                    fail_msg("%s %s preint=%d: AVX-512 and AVX2 images differ (max %g)", techs[k].name,
                             storages[t].type, preint, tu_max_abs_diff(&a, &b));
                volux_image_free(ctx, &a);
                volux_image_free(ctx, &b);
                volux_scene_destroy(s);
            }
        }
    volux_context_destroy(ctx);
}

static void test_simd_is_thread_count_independent(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    const char *file = write_volume(&storages[0]);
    for (int k = 0; k < N_TECHS; k++) {
        volux_context *c1 = tu_context(1), *c3 = tu_context(3);
        volux_scene *s1 = make_scene(c1, &techs[k], &storages[0], file, 0, 1, 1, 0.002);
        volux_scene *s3 = make_scene(c3, &techs[k], &storages[0], file, 0, 1, 1, 0.002);
        volux_image a = render_with(c1, s1, techs[k].name, "simd"), b = render_with(c3, s3, techs[k].name, "simd");
        if (memcmp(a.rgb, b.rgb, sizeof(float) * 3 * W * H))
            fail_msg("%s: 1 and 3 threads differ (max %g)", techs[k].name, tu_max_abs_diff(&a, &b));
        volux_image_free(c1, &a);
        volux_image_free(c3, &b);
        volux_scene_destroy(s1);
        volux_scene_destroy(s3);
        volux_context_destroy(c1);
        volux_context_destroy(c3);
    }
}

/* Skipped segments lie in exactly empty skip cells: no pixel changes. */
static void test_simd_skipping_is_exact(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    volux_context *ctx = tu_context(2);
    for (int k = 0; k < N_TECHS; k++)
        for (size_t t = 0; t < sizeof storages / sizeof storages[0]; t += 3) {
            const char *file = write_volume(&storages[t]);
            for (int preint = 0; preint < (techs[k].has_preint ? 2 : 1); preint++) {
                volux_scene *on = make_scene(ctx, &techs[k], &storages[t], file, 1, preint, 1, 0.0);
                volux_scene *off = make_scene(ctx, &techs[k], &storages[t], file, 1, preint, 0, 0.0);
                volux_image a = render_with(ctx, on, techs[k].name, "simd");
                volux_image b = render_with(ctx, off, techs[k].name, "simd");
                double d = tu_max_abs_diff(&a, &b) / image_max(&b);
                if (d > 1e-6) fail_msg("%s %s preint=%d: skipping changed pixels by %g", techs[k].name,
                                       storages[t].type, preint, d);
                volux_image_free(ctx, &a);
                volux_image_free(ctx, &b);
                volux_scene_destroy(on);
                volux_scene_destroy(off);
            }
        }
    volux_context_destroy(ctx);
}

static void test_march_kernel_is_validated(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *file = write_volume(&storages[0]);
    for (int k = 0; k < N_TECHS; k++) {
        volux_scene *s = make_scene(ctx, &techs[k], &storages[0], file, 0, 1, 1, 0.002);
        volux_technique *t = NULL;
        assert_int_equal(volux_scene_set_param(s, techs[k].name, "march_kernel", 0, "fast"), VOLUX_OK);
        volux_context_clear_error(ctx);
        assert_int_equal(volux_technique_create(ctx, techs[k].name, s, &t), VOLUX_ERR_INVALID);
        char want[64];
        snprintf(want, sizeof want, "techniques.%s.march_kernel", techs[k].name);
        assert_non_null(strstr(volux_context_error(ctx), want));
        assert_int_equal(volux_scene_set_param(s, techs[k].name, "march_kernel", 0, "scalar"), VOLUX_OK);
        assert_int_equal(volux_technique_create(ctx, techs[k].name, s, &t), VOLUX_OK);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
    }
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lightvol_simd_matches_scalar),
        cmocka_unit_test(test_single_simd_matches_scalar),
        cmocka_unit_test(test_ao_simd_matches_scalar),
        cmocka_unit_test(test_ambient_simd_matches_scalar),
        cmocka_unit_test(test_ambient_with_offset_keeps_scalar),
        cmocka_unit_test(test_widths_are_bit_identical),
        cmocka_unit_test(test_simd_is_thread_count_independent),
        cmocka_unit_test(test_simd_skipping_is_exact),
        cmocka_unit_test(test_march_kernel_is_validated),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
