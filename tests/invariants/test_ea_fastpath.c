/* The SIMD kernel (dvr_simd_impl.h: 16 lanes in dvr_avx512.c, 8 in
 * dvr_avx2.c) of `ea` and `shaded` against the scalar reference (dvr.c),
 * and the two widths against each other (bit for bit):
 * same image within a stated float tolerance on every storage type, with
 * and without pre-integration, skipping and early termination, for
 * perspective and orthographic cameras; thread-count independence;
 * skipping exact; all of it again at coarse steps (the prefetching path);
 * the `kernel` parameter validated.
 *
 * Tolerances (radiance in [0, 1]; the scene's pixels reach ~0.9):
 *   - without pre-integration the kernels take bit-identical samples and
 *     differ only by the vector exp (≤ 2 ulp) and summation rounding:
 *     max 2e-6, mean 5e-8 absolute per channel (measured: 3e-7, 8e-9);
 *   - with pre-integration the SIMD kernel reads float integral tables
 *     (the scalar one double); the error bound per segment is
 *     ≈ 3·2⁻²⁴·len·(n−1)·σ̄ (dvr_avx2.c), summed over a ray and weighted by
 *     transmittance: max 1e-4, mean 1e-6 (measured: 1.8e-5, 1.4e-7);
 *   - `shaded` adds vector sqrt/log/exp in Blinn–Phong (same gradient,
 *     same operation order, for both `gradient` choices: the cell's
 *     trilinear gradient and the cached central differences): the same
 *     bounds hold.
 * The corner-word layout (`volume_layout: "corner_words"`, dvr_corners.c)
 * reads the same bytes as the bricked gathers: bit-identical images. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "techniques/dvr/dvr.h"
#include "test_util.h"

enum { NX = 40, NY = 36, NZ = 44, W = 37, H = 29 };

typedef struct storage_case {
    const char *type; /* scene "type" */
    double lo, hi;    /* file values the signal [0, 1] maps to */
    int bytes;
} storage_case;

static const storage_case storages[] = {
    {"uint8", 0, 255, 1},
    {"uint16", 0, 65535, 2},
    {"int16", -1000, 3000, 2}, /* stored as uint16 + offset */
    {"float32", -2.5, 7.5, 4},
};

/* Smooth field in [0, 1] with shells, a blob and empty corners, so rays
 * cross empty macrocells, thin opacity peaks and dense regions. */
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
    snprintf(name, sizeof name, "fastpath_%s.raw", sc->type);
    const char *path = tu_write_file(name, buf, n * (size_t)sc->bytes);
    free(buf);
    return strrchr(path, '/') + 1; /* scenes resolve it against the temp dir */
}

static double g_step = 0.45; /* render.step of the scenes below (voxels) */
static int g_spp = 2;        /* render.spp of the scenes below */

/* Scene JSON for storage `sc`; TF positions are fractions of its range. */
static volux_scene *make_scene_t(volux_context *ctx, const char *tech, const storage_case *sc, const char *file,
                                 int ortho, int preint, int skip, double early) {
#define S_(f) (sc->lo + (sc->hi - sc->lo) * (f))
    char json[4096];
    snprintf(json, sizeof json,
             "{\"volume\": {\"file\": \"%s\", \"dims\": [%d, %d, %d], \"type\": \"%s\", \"endian\": \"little\"},"
             " \"transfer_function\": {"
             "   \"opacity\": [[%g, 0], [%g, 0], [%g, 0.5], [%g, 0.02], [%g, 0.02], [%g, 0.9], [%g, 0.95]],"
             "   \"color\": [[%g, 0.2, 0.4, 1], [%g, 1, 0.9, 0.6], [%g, 1, 0.4, 0.1], [%g, 1, 1, 1]]},"
             " \"camera\": {%s\"orbit\": {\"azimuth\": %s, \"elevation\": %s}},"
             " \"background\": [0.1, 0.2, 0.3],"
             " \"lights\": [{\"type\": \"directional\", \"direction\": [-1, -0.5, -0.8], \"irradiance\": 1.5},"
             "              {\"type\": \"directional\", \"direction\": [0.6, -1, 0.2], \"irradiance\": 0.7,"
             "               \"color\": [1, 0.7, 0.4]}],"
             " \"render\": {\"width\": %d, \"height\": %d, \"spp\": %d, \"step\": %g},"
             " \"techniques\": {\"%s\": {\"preintegrate\": %s, \"skip_empty\": %s, \"early_termination\": %g}}}",
             file, NX, NY, NZ, sc->type, S_(0), S_(0.3), S_(0.36), S_(0.42), S_(0.6), S_(0.8), S_(1.0), S_(0),
             S_(0.36), S_(0.7), S_(1.0), ortho ? "\"type\": \"orthographic\", " : "", ortho ? "-60" : "35",
             ortho ? "10" : "25", W, H, g_spp, g_step, tech, preint ? "true" : "false", skip ? "true" : "false", early);
#undef S_
    return tu_scene(ctx, json);
}

static volux_scene *make_scene(volux_context *ctx, const storage_case *sc, const char *file, int ortho, int preint,
                               int skip, double early) {
    return make_scene_t(ctx, "ea", sc, file, ortho, preint, skip, early);
}

static const char *g_gradient = "cell"; /* `gradient` of the shaded scenes */

static volux_image render_kernel_t(volux_context *ctx, volux_scene *s, const char *tech, const char *kernel) {
    assert_int_equal(volux_scene_set_param(s, tech, "kernel", 0, kernel), VOLUX_OK);
    if (!strcmp(tech, "shaded")) assert_int_equal(volux_scene_set_param(s, tech, "gradient", 0, g_gradient), VOLUX_OK);
    return tu_render(ctx, s, tech);
}

static volux_image render_kernel(volux_context *ctx, volux_scene *s, const char *kernel) {
    return render_kernel_t(ctx, s, "ea", kernel);
}

static double mean_abs_diff(const volux_image *a, const volux_image *b) {
    double sum = 0.0;
    size_t n = (size_t)a->width * (size_t)a->height * 3;
    for (size_t i = 0; i < n; i++) sum += fabs((double)a->rgb[i] - (double)b->rgb[i]);
    return sum / (double)n;
}

static int simd_or_skip(void) {
    if (volux_dvr_simd_available()) return 1;
    fprintf(stderr, "(no AVX2+FMA on this CPU: the SIMD kernel is not available, nothing to compare)\n");
    return 0;
}

static void simd_matches_scalar(const char *tech) {
    if (!simd_or_skip()) skip();
    volux_context *ctx = tu_context(2);
    double worst[2] = {0, 0}, worst_mean[2] = {0, 0};
    for (size_t t = 0; t < sizeof storages / sizeof storages[0]; t++) {
        const char *file = write_volume(&storages[t]);
        for (int ortho = 0; ortho < 2; ortho++)
            for (int preint = 0; preint < 2; preint++)
                for (int skip_empty = 0; skip_empty < 2; skip_empty++) {
                    double early = skip_empty ? 0.002 : 0.0; /* both on = the defaults */
                    volux_scene *s = make_scene_t(ctx, tech, &storages[t], file, ortho, preint, skip_empty, early);
                    volux_image a = render_kernel_t(ctx, s, tech, "scalar"), b = render_kernel_t(ctx, s, tech, "simd");
                    double d = tu_max_abs_diff(&a, &b), m = mean_abs_diff(&a, &b);
                    double tol = preint ? 1e-4 : 2e-6, tol_mean = preint ? 1e-6 : 5e-8;
                    if (d > worst[preint]) worst[preint] = d;
                    if (m > worst_mean[preint]) worst_mean[preint] = m;
                    if (!(d <= tol) || !(m <= tol_mean))
                        fail_msg("%s %s %s preint=%d skip=%d: SIMD vs scalar max %g (tol %g), mean %g (tol %g)", tech,
                                 storages[t].type, ortho ? "ortho" : "persp", preint, skip_empty, d, tol, m, tol_mean);
                    /* the test is not vacuous: the volume is visible */
                    double sum = 0;
                    for (int i = 0; i < W * H * 3; i++)
                        sum += fabs(a.rgb[i] - (i % 3 == 0 ? 0.1 : i % 3 == 1 ? 0.2 : 0.3));
                    if (sum < 1.0) fail_msg("%s: the volume is not visible (sum %g)", storages[t].type, sum);
                    volux_image_free(ctx, &a);
                    volux_image_free(ctx, &b);
                    volux_scene_destroy(s);
                }
    }
    fprintf(stderr, "%s: worst SIMD-scalar difference: plain max %.3g mean %.3g, pre-integrated max %.3g mean %.3g\n",
            tech, worst[0], worst_mean[0], worst[1], worst_mean[1]);
    volux_context_destroy(ctx);
}

static void test_simd_matches_scalar(void **state) {
    (void)state;
    simd_matches_scalar("ea");
}

static void test_simd_shaded_cached_gradient_matches_scalar(void **state) {
    (void)state;
    g_gradient = "cached";
    simd_matches_scalar("shaded");
    g_gradient = "cell";
}

static void test_simd_shaded_matches_scalar(void **state) {
    (void)state;
    simd_matches_scalar("shaded");
}

/* Point, spot and sphere lights have no SIMD shading: "auto" keeps the
 * scalar kernel (same image) and "simd" is refused. */
static void test_shaded_with_point_light_uses_scalar(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *file = write_volume(&storages[0]);
    volux_scene *s = make_scene_t(ctx, "shaded", &storages[0], file, 0, 1, 1, 0.002);
    volux_light_desc point;
    volux_light_desc_defaults(&point, VOLUX_LIGHT_POINT);
    point.position = (volux_vec3){40, 30, 40};
    point.intensity = 2000;
    assert_int_equal(volux_scene_set_light(s, 2, &point), VOLUX_OK);
    volux_image a = render_kernel_t(ctx, s, "shaded", "auto"), b = render_kernel_t(ctx, s, "shaded", "scalar");
    assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * W * H);
    volux_technique *t = NULL;
    assert_int_equal(volux_scene_set_param(s, "shaded", "kernel", 0, "simd"), VOLUX_OK);
    assert_int_equal(volux_technique_create(ctx, "shaded", s, &t), VOLUX_ERR_UNSUPPORTED);
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_simd_is_thread_count_independent(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    static const char *techs[] = {"ea", "shaded"};
    for (int t = 0; t < 2; t++)
        for (int preint = 0; preint < 2; preint++) {
            volux_context *c1 = tu_context(1), *c2 = tu_context(2);
            const char *file = write_volume(&storages[0]);
            volux_scene *s1 = make_scene_t(c1, techs[t], &storages[0], file, 0, preint, 1, 0.002);
            volux_scene *s2 = make_scene_t(c2, techs[t], &storages[0], file, 0, preint, 1, 0.002);
            volux_image a = render_kernel_t(c1, s1, techs[t], "simd"), b = render_kernel_t(c2, s2, techs[t], "simd");
            assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * W * H);
            volux_image_free(c1, &a);
            volux_image_free(c2, &b);
            volux_scene_destroy(s1);
            volux_scene_destroy(s2);
            volux_context_destroy(c1);
            volux_context_destroy(c2);
        }
}

/* The SIMD kernel drops only segments inside empty macrocells, whose
 * contribution is exactly 0: skipping must not change pixels. */
static void test_simd_skipping_is_exact(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    volux_context *ctx = tu_context(2);
    for (size_t t = 0; t < sizeof storages / sizeof storages[0]; t++) {
        const char *file = write_volume(&storages[t]);
        for (int preint = 0; preint < 2; preint++) {
            volux_scene *on = make_scene(ctx, &storages[t], file, 1, preint, 1, 0.0);
            volux_scene *off = make_scene(ctx, &storages[t], file, 1, preint, 0, 0.0);
            volux_image a = render_kernel(ctx, on, "simd"), b = render_kernel(ctx, off, "simd");
            double d = tu_max_abs_diff(&a, &b);
            if (d > 1e-6) fail_msg("%s preint=%d: skipping changed pixels by %g", storages[t].type, preint, d);
            volux_image_free(ctx, &a);
            volux_image_free(ctx, &b);
            volux_scene_destroy(on);
            volux_scene_destroy(off);
        }
    }
    volux_context_destroy(ctx);
}

/* The 16-lane AVX-512 packets (dvr_avx512.c) against the 8-lane AVX2 ones
 * (dvr_avx2.c): the same code over two lane vocabularies whose operations
 * are the same IEEE operations lane by lane, so every pixel must have the
 * same bits, on every storage type and setting, ea and shaded. */
static void test_widths_are_bit_identical(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    if (!volux_dvr_avx512_available()) {
        fprintf(stderr, "(no AVX-512 on this CPU: only the 8-lane kernel runs, nothing to compare)\n");
        skip();
    }
    static const char *techs[] = {"ea", "shaded"};
    volux_context *ctx = tu_context(2);
    int compared = 0;
    for (size_t t = 0; t < sizeof storages / sizeof storages[0]; t++) {
        const char *file = write_volume(&storages[t]);
        for (int tech = 0; tech < 2; tech++)
            for (int ortho = 0; ortho < 2; ortho++)
                for (int preint = 0; preint < 2; preint++)
                    for (int skip_empty = 0; skip_empty < 2; skip_empty++) {
                        double early = skip_empty ? 0.002 : 0.0;
                        volux_scene *s =
                            make_scene_t(ctx, techs[tech], &storages[t], file, ortho, preint, skip_empty, early);
                        for (int g = 0; g < (tech ? 2 : 1); g++) { /* shaded: both gradients */
                            g_gradient = g ? "cached" : "cell";
                            volux_image a = render_kernel_t(ctx, s, techs[tech], "simd");
                            volux_image b = render_kernel_t(ctx, s, techs[tech], "avx2");
                            if (memcmp(a.rgb, b.rgb, sizeof(float) * 3 * W * H))
                                fail_msg("%s %s %s preint=%d skip=%d gradient=%s: AVX-512 and AVX2 images differ "
                                         "(max %g)",
                                         techs[tech], storages[t].type, ortho ? "ortho" : "persp", preint, skip_empty,
                                         g_gradient, tu_max_abs_diff(&a, &b));
                            compared++;
                            volux_image_free(ctx, &a);
                            volux_image_free(ctx, &b);
                        }
                        g_gradient = "cell";
                        volux_scene_destroy(s);
                    }
    }
    assert_int_equal(compared, 4 * 3 * 2 * 2 * 2);
    volux_context_destroy(ctx);
}

/* Steps of 2 voxels and more switch on the SIMD kernel's software
 * prefetch of later samples' cells (dvr_simd_impl.h, render_tile_impl:
 * two segments ahead below 3 voxels, one from 3 on) and make skips jump
 * over more segments: the image must still match the scalar kernel within
 * the tolerances above, skipping must not change pixels, and the two
 * widths must give the same bits. */
static void test_coarse_steps(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    static const char *techs[] = {"ea", "shaded"};
    static const double steps[] = {2.5, 4.0};
    static const size_t kinds[] = {0, 3}; /* uint8, float32 */
    const int wide = volux_dvr_avx512_available();
    volux_context *ctx = tu_context(2);
    for (int st = 0; st < 2; st++) {
        g_step = steps[st];
        for (int k = 0; k < 2; k++) {
            const storage_case *sc = &storages[kinds[k]];
            const char *file = write_volume(sc);
            for (int tech = 0; tech < 2; tech++)
                for (int ortho = 0; ortho < 2; ortho++)
                    for (int preint = 0; preint < 2; preint++) {
                        volux_scene *on = make_scene_t(ctx, techs[tech], sc, file, ortho, preint, 1, 0.002);
                        volux_scene *off = make_scene_t(ctx, techs[tech], sc, file, ortho, preint, 0, 0.002);
                        volux_image ref = render_kernel_t(ctx, on, techs[tech], "scalar");
                        volux_image a = render_kernel_t(ctx, on, techs[tech], "simd");
                        volux_image b = render_kernel_t(ctx, off, techs[tech], "simd");
                        volux_image c = render_kernel_t(ctx, on, techs[tech], "avx2");
                        double d = tu_max_abs_diff(&ref, &a), m = mean_abs_diff(&ref, &a);
                        double tol = preint ? 1e-4 : 2e-6, tol_mean = preint ? 1e-6 : 5e-8;
                        if (!(d <= tol) || !(m <= tol_mean))
                            fail_msg("%s %s step %g %s preint=%d: SIMD vs scalar max %g (tol %g), mean %g (tol %g)",
                                     techs[tech], sc->type, g_step, ortho ? "ortho" : "persp", preint, d, tol, m,
                                     tol_mean);
                        if (tu_max_abs_diff(&a, &b) > 1e-6)
                            fail_msg("%s %s step %g preint=%d: skipping changed pixels by %g", techs[tech], sc->type,
                                     g_step, preint, tu_max_abs_diff(&a, &b));
                        if (wide && memcmp(a.rgb, c.rgb, sizeof(float) * 3 * W * H))
                            fail_msg("%s %s step %g preint=%d: AVX-512 and AVX2 images differ (max %g)", techs[tech],
                                     sc->type, g_step, preint, tu_max_abs_diff(&a, &c));
                        /* not vacuous: the volume is visible at this step too */
                        double sum = 0;
                        for (int i = 0; i < W * H * 3; i++)
                            sum += fabs(a.rgb[i] - (i % 3 == 0 ? 0.1 : i % 3 == 1 ? 0.2 : 0.3));
                        if (sum < 1.0) fail_msg("%s step %g: the volume is not visible (sum %g)", sc->type, g_step, sum);
                        volux_image_free(ctx, &ref);
                        volux_image_free(ctx, &a);
                        volux_image_free(ctx, &b);
                        volux_image_free(ctx, &c);
                        volux_scene_destroy(on);
                        volux_scene_destroy(off);
                    }
        }
    }
    g_step = 0.45;
    volux_context_destroy(ctx);
}

/* `volume_layout: "corner_words"` (dvr_corners.c): one 64-bit word per
 * cell holding the 8 corners the bricked gathers read, so every sample —
 * and every pixel — has the same bits, at both widths, fine and coarse
 * steps (the prefetch path), ea and shaded (whose gradient reads the
 * bricks). The technique's memory grows by exactly the words (8 bytes per
 * cell of the bricked copy), so the comparison is not vacuous. */
static void test_corner_words_are_bit_identical(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    static const char *techs[] = {"ea", "shaded"};
    static const double steps[] = {0.45, 4.0};
    const char *kernels[2] = {"simd", "avx2"};
    const int nk = volux_dvr_avx512_available() ? 2 : 1;
    volux_context *ctx = tu_context(2);
    const char *file = write_volume(&storages[0]); /* uint8 */
    const size_t bricks = (size_t)((NX - 1 + 7) / 8) * ((NY - 1 + 7) / 8) * ((NZ - 1 + 7) / 8);
    for (int st = 0; st < 2; st++) {
        g_step = steps[st];
        for (int tech = 0; tech < 2; tech++)
            for (int preint = 0; preint < 2; preint++)
                for (int k = 0; k < nk; k++) {
                    volux_scene *s = make_scene_t(ctx, techs[tech], &storages[0], file, 0, preint, 1, 0.002);
                    assert_int_equal(volux_scene_set_param(s, techs[tech], "kernel", 0, kernels[k]), VOLUX_OK);
                    assert_int_equal(volux_scene_set_param(s, techs[tech], "volume_layout", 0, "bricked"), VOLUX_OK);
                    volux_technique *t = NULL;
                    assert_int_equal(volux_technique_create(ctx, techs[tech], s, &t), VOLUX_OK);
                    volux_image a = tu_render_with(ctx, s, t);
                    size_t mem_bricked = volux_technique_memory_bytes(t);
                    volux_technique_destroy(t);
                    assert_int_equal(volux_scene_set_param(s, techs[tech], "volume_layout", 0, "corner_words"),
                                     VOLUX_OK);
                    assert_int_equal(volux_technique_create(ctx, techs[tech], s, &t), VOLUX_OK);
                    volux_image b = tu_render_with(ctx, s, t);
                    assert_int_equal(volux_technique_memory_bytes(t) - mem_bricked, bricks * 512 * 8);
                    volux_technique_destroy(t);
                    if (memcmp(a.rgb, b.rgb, sizeof(float) * 3 * W * H))
                        fail_msg("%s step %g preint=%d %s: corner words and bricks differ (max %g)", techs[tech],
                                 steps[st], preint, kernels[k], tu_max_abs_diff(&a, &b));
                    volux_image_free(ctx, &a);
                    volux_image_free(ctx, &b);
                    volux_scene_destroy(s);
                }
    }
    g_step = 0.45;
    volux_context_destroy(ctx);
}

/* `volume_layout: "auto"` (the default): the rule of dvr.c — corner words
 * on Intel CPUs from DVR_CORNER_WORDS_MIN_STEP voxels, the bricked copy
 * elsewhere — decides, on this CPU, at a fine and a coarse step and when
 * an edit moves the step across the threshold (the layout follows
 * RENDER): the technique holds the corner words exactly when the rule
 * says so, and renders the same bits as the explicit layouts. */
static void test_auto_layout_follows_the_rule(void **state) {
    (void)state;
    assert_int_equal(volux_dvr_auto_corner_words(1, 4.0f), 1);
    assert_int_equal(volux_dvr_auto_corner_words(1, DVR_CORNER_WORDS_MIN_STEP), 1);
    assert_int_equal(volux_dvr_auto_corner_words(1, 0.5f), 0);
    assert_int_equal(volux_dvr_auto_corner_words(0, 4.0f), 0);
    assert_int_equal(volux_dvr_auto_corner_words(0, 0.5f), 0);
    if (!simd_or_skip()) skip();
    const int intel = volux_dvr_cpu_is_intel();
    printf("  this CPU: %s\n", intel ? "Intel" : "not Intel");
    volux_context *ctx = tu_context(2);
    const char *file = write_volume(&storages[0]); /* uint8 */
    const size_t words = (size_t)((NX - 1 + 7) / 8) * ((NY - 1 + 7) / 8) * ((NZ - 1 + 7) / 8) * 512 * 8;
    static const double steps[] = {0.45, 4.0};
    g_step = steps[0];
    volux_scene *s = make_scene_t(ctx, "ea", &storages[0], file, 0, 1, 1, 0.002);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "ea", s, &t), VOLUX_OK); /* auto, the default */
    const size_t base = volux_technique_memory_bytes(t) -
                        (volux_dvr_auto_corner_words(intel, (float)steps[0]) ? words : 0);
    for (int i = 0; i < 2; i++) {
        volux_render_settings rs = *volux_scene_render(s);
        rs.step = (float)steps[i];
        assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
        assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
        const int want = volux_dvr_auto_corner_words(intel, (float)steps[i]);
        assert_int_equal(volux_technique_memory_bytes(t), base + (want ? words : 0));
        volux_image a = tu_render_with(ctx, s, t);
        for (int l = 0; l < 2; l++) {
            assert_int_equal(volux_scene_set_param(s, "ea", "volume_layout", 0, l ? "corner_words" : "bricked"),
                             VOLUX_OK);
            volux_image b = tu_render(ctx, s, "ea");
            if (memcmp(a.rgb, b.rgb, sizeof(float) * 3 * W * H))
                fail_msg("step %g: auto and %s differ", steps[i], l ? "corner_words" : "bricked");
            volux_image_free(ctx, &b);
        }
        assert_int_equal(volux_scene_set_param(s, "ea", "volume_layout", 0, "auto"), VOLUX_OK);
        assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
        volux_image_free(ctx, &a);
    }
    /* a bad value names the parameter */
    assert_int_equal(volux_scene_set_param(s, "ea", "volume_layout", 0, "diagonal"), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "volume_layout"));
    volux_context_clear_error(ctx);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    g_step = 0.45;
    volux_context_destroy(ctx);
}

/* The gradient of the trilinear interpolant (`gradient: "cell"`) is exact
 * for a linear field, whatever the cell and fractions: s = 3i − 2j + 5k on
 * spacing (0.5, 2, 1.25) has the world gradient (6, −1, 4) everywhere
 * (float32 storage: the node values are exact). */
static void test_cell_gradient_of_linear_field(void **state) {
    (void)state;
    enum { N = 12 };
    float *buf = malloc(sizeof(float) * N * N * N);
    assert_non_null(buf);
    for (int k = 0, p = 0; k < N; k++)
        for (int j = 0; j < N; j++)
            for (int i = 0; i < N; i++) buf[p++] = (float)(3 * i - 2 * j + 5 * k);
    const char *path = tu_write_file("fastpath_linear.raw", buf, sizeof(float) * N * N * N);
    free(buf);
    volux_context *ctx = tu_context(1);
    char json[512];
    snprintf(json, sizeof json,
             "{\"volume\": {\"file\": \"%s\", \"dims\": [%d, %d, %d], \"type\": \"float32\","
             " \"spacing\": [0.5, 2, 1.25]}}",
             strrchr(path, '/') + 1, N, N, N);
    volux_volume *v = NULL;
    volux_scene *s = tu_scene(ctx, json);
    v = (volux_volume *)volux_scene_volume(s);
    assert_int_equal(volux_volume_build_bricks(v), VOLUX_OK);
    const float q[][3] = {{0.25f, 0.5f, 0.75f}, {7.9f, 3.1f, 8.5f}, {10.99f, 10.99f, 0.01f}, {5.5f, 9.25f, 4.0f}};
    for (size_t n = 0; n < sizeof q / sizeof q[0]; n++) {
        volux_vec3 g = volux_cell_gradient_bricked(v, v3(q[n][0], q[n][1], q[n][2]));
        assert_float_equal(g.x, 6.0f, 1e-4f);
        assert_float_equal(g.y, -1.0f, 1e-4f);
        assert_float_equal(g.z, 4.0f, 1e-4f);
    }
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_kernel_parameter_is_validated(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *file = write_volume(&storages[0]);
    volux_scene *s = make_scene(ctx, &storages[0], file, 0, 1, 1, 0.002);
    volux_technique *t = NULL;
    assert_int_equal(volux_scene_set_param(s, "ea", "kernel", 0, "fast"), VOLUX_OK);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_technique_create(ctx, "ea", s, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "techniques.ea.kernel"));
    /* the layout and (shaded) the gradient are validated too */
    assert_int_equal(volux_scene_set_param(s, "ea", "kernel", 0, "auto"), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "ea", "volume_layout", 0, "packed"), VOLUX_OK);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_technique_create(ctx, "ea", s, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "techniques.ea.volume_layout"));
    assert_int_equal(volux_scene_set_param(s, "ea", "volume_layout", 0, "bricked"), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "shaded", "gradient", 0, "sobel"), VOLUX_OK);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_technique_create(ctx, "shaded", s, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "techniques.shaded.gradient"));
    /* the scalar kernel is always there */
    assert_int_equal(volux_scene_set_param(s, "ea", "kernel", 0, "scalar"), VOLUX_OK);
    assert_int_equal(volux_technique_create(ctx, "ea", s, &t), VOLUX_OK);
    /* switching kernels is a parameter edit: update, not rebuild */
    assert_int_equal(volux_scene_set_param(s, "ea", "kernel", 0, volux_dvr_simd_available() ? "simd" : "auto"),
                     VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    /* "avx2" (the 8-lane packets) exists where the SIMD kernel does, and is
     * refused with the CPU named where it does not */
    assert_int_equal(volux_scene_set_param(s, "ea", "kernel", 0, "avx2"), VOLUX_OK);
    volux_context_clear_error(ctx);
    if (volux_dvr_simd_available()) {
        assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    } else {
        assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_ERR_UNSUPPORTED);
        assert_non_null(strstr(volux_context_error(ctx), "AVX2"));
    }
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}


/* The scalar kernel marches the rays of a tile two at a time (dvr.c,
 * tile_pairs: the operations of volux_ea_march per ray, in the same
 * order). volux_render_part on an ordinary volume still marches one ray at
 * a time (volux_raycaster_tile_part + volux_ea_march) and adds the
 * background behind it, so for one sample per pixel both give the same
 * bits: on every storage type, with and without pre-integration, skipping
 * and early termination (rays of a pair ending at different segments),
 * ea and shaded, and an odd number of rays per tile (37×29 pixels). */
static void test_scalar_pairs_match_single_ray_march(void **state) {
    (void)state;
    static const char *techs[] = {"ea", "shaded"};
    volux_context *ctx = tu_context(2);
    g_spp = 1;
    int compared = 0;
    for (size_t t = 0; t < sizeof storages / sizeof storages[0]; t++) {
        const char *file = write_volume(&storages[t]);
        for (int tech = 0; tech < 2; tech++)
            for (int preint = 0; preint < 2; preint++)
                for (int skip_empty = 0; skip_empty < 2; skip_empty++)
                    for (int early = 0; early < 2; early++) {
                        volux_scene *s = make_scene_t(ctx, techs[tech], &storages[t], file, early, preint,
                                                      skip_empty, early ? 0.3 : 0.0);
                        volux_image a = render_kernel_t(ctx, s, techs[tech], "scalar");
                        volux_technique *tq = NULL;
                        assert_int_equal(volux_technique_create(ctx, techs[tech], s, &tq), VOLUX_OK);
                        float *rgbt = malloc(sizeof(float) * 4 * W * H);
                        assert_non_null(rgbt);
                        assert_int_equal(volux_render_part(tq, s, 0, rgbt, NULL, NULL), VOLUX_OK);
                        int differ = 0;
                        for (int p = 0; p < W * H; p++)
                            for (int c = 0; c < 3; c++) differ += a.rgb[3 * p + c] != rgbt[4 * p + c];
                        if (differ)
                            fail_msg("%s %s preint=%d skip=%d early=%d: %d channels differ between the paired and "
                                     "the single-ray scalar march",
                                     techs[tech], storages[t].type, preint, skip_empty, early, differ);
                        compared++;
                        free(rgbt);
                        volux_technique_destroy(tq);
                        volux_image_free(ctx, &a);
                        volux_scene_destroy(s);
                    }
    }
    g_spp = 2;
    assert_int_equal(compared, 4 * 2 * 2 * 2 * 2);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_simd_matches_scalar),
        cmocka_unit_test(test_simd_shaded_matches_scalar),
        cmocka_unit_test(test_simd_shaded_cached_gradient_matches_scalar),
        cmocka_unit_test(test_corner_words_are_bit_identical),
        cmocka_unit_test(test_auto_layout_follows_the_rule),
        cmocka_unit_test(test_cell_gradient_of_linear_field),
        cmocka_unit_test(test_shaded_with_point_light_uses_scalar),
        cmocka_unit_test(test_simd_is_thread_count_independent),
        cmocka_unit_test(test_simd_skipping_is_exact),
        cmocka_unit_test(test_widths_are_bit_identical),
        cmocka_unit_test(test_coarse_steps),
        cmocka_unit_test(test_kernel_parameter_is_validated),
        cmocka_unit_test(test_scalar_pairs_match_single_ray_march),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
