/*
 * manylights against the reference path tracer (public API only).
 *
 * Scene: a procedural cloud (32³, σt up to 0.8 per voxel), albedo 0.9,
 * HG g = 0.3, a directional light and a dim constant sky, max_depth 4 —
 * a medium where multiple scattering is a large part of the light (single
 * scattering alone is off by rel_mse ≈ 0.02). manylights is close to
 * exact here: small VSLs (radius 0.5 voxel, `ball` kernel, so the
 * regularisation bias is small), 1000 VLs, fine AVSMs (12² × 6 × 12).
 *
 * Measured (24×24, pathtrace 1024 spp, whose own noise is rel_mse
 * 1.9·10⁻⁴ against an 8192-spp render): rel_mse 0.0021 (VL-set variance
 * dominates: 0.0013 with 2000 VLs); single scattering alone 0.02.
 * Bounds: rel_mse < 0.003; multiple scattering must cut the single-only
 * error at least 5×; mean luminance, averaged over eight VL sets (seeds
 * 1–8), within 4 % of the reference. One set's mean scatters by 3.3 %
 * (standard deviation over seeds 1–11, whose mean is +0.7 % against a
 * 4096-spp reference), so the 8-set mean has a standard error of 1.2 %;
 * the single set this test used to check against 3 % (−1.8 %) passed
 * only because the direct term was several per cent too bright before
 * the midpoint fix of render.c (−3.4 % after it). The test fails for a wrong
 * VL weight: dropping ρ(x_k) of the VL's own vertex (ml_weights) gives
 * rel_mse 0.0037 and an 8 % brighter image (both bounds fail).
 */
#include <math.h>
#include <stdio.h>

#include "test_util.h"

static const char *scene_json =
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [32, 32, 32]},"
    " \"transfer_function\": {\"extinction\": [[0, 0], [40, 0.0], [255, 0.8]],"
    "   \"color\": [[0, 1, 1, 1], [255, 0.9, 0.8, 0.7]], \"albedo\": 0.9, \"anisotropy\": 0.3},"
    " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}, \"fov_y\": 30},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.5, -0.8, -0.3], \"irradiance\": 3.0},"
    "   {\"type\": \"environment\", \"radiance\": 0.3, \"color\": [0.6, 0.7, 1.0], \"visible\": false}],"
    " \"render\": {\"width\": 24, \"height\": 24, \"spp\": 16, \"max_depth\": 4},"
    " \"techniques\": {\"manylights\": {\"vl_count\": 1000, \"vsl_radius\": 0.5, \"vsl_kernel\": \"ball\","
    "                                 \"samples\": 4, \"avsm_resolution\": 12, \"avsm_nodes\": 12}}}";

static void test_manylights_vs_pathtrace(void **state) {
    (void)state;
    volux_context *ctx = tu_context(0);
    volux_scene *s = tu_scene(ctx, scene_json);
    volux_render_settings rs = *volux_scene_render(s);
    rs.spp = 1024;
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    volux_image ref = tu_render(ctx, s, "pathtrace");
    rs.spp = 16;
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    volux_image ml = tu_render(ctx, s, "manylights");
    assert_int_equal(volux_scene_set_param(s, "manylights", "multiple_scattering", 0, NULL), VOLUX_OK);
    volux_image ss = tu_render(ctx, s, "manylights");
    volux_image_error e_ml, e_ss;
    assert_int_equal(volux_image_compare(ctx, &ml, &ref, &e_ml), VOLUX_OK);
    assert_int_equal(volux_image_compare(ctx, &ss, &ref, &e_ss), VOLUX_OK);
    double lum_ml1 = tu_mean_luminance(&ml), lum_ref = tu_mean_luminance(&ref), lum_ml = lum_ml1;
    assert_int_equal(volux_scene_set_param(s, "manylights", "multiple_scattering", 1, NULL), VOLUX_OK);
    lum_ml = 0.0;
    for (int k = 1; k <= 8; k++) { /* eight VL sets */
        rs.seed = (uint64_t)k;
        assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
        volux_image other = tu_render(ctx, s, "manylights");
        lum_ml += tu_mean_luminance(&other);
        volux_image_free(ctx, &other);
    }
    lum_ml /= 8.0;
    printf("  manylights rel_mse %.4g (single scattering only %.4g), mean luminance %.4g (this seed %.4g, mean of 8"
           " VL sets %.4g = %+.1f%%) vs %.4g\n",
           e_ml.rel_mse, e_ss.rel_mse, lum_ml, lum_ml1, lum_ml, 100.0 * (lum_ml / lum_ref - 1.0), lum_ref);
    assert_true(e_ml.rel_mse < 0.003);
    assert_true(e_ml.rel_mse * 5.0 < e_ss.rel_mse);
    assert_true(fabs(lum_ml / lum_ref - 1.0) < 0.04);
    volux_image_free(ctx, &ref);
    volux_image_free(ctx, &ml);
    volux_image_free(ctx, &ss);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* Convergence (issue 27). Sample p gathers from VL set p / passes_per_set,
 * so two seeds' images — different VL sets throughout — approach the same
 * limit: their relative difference falls like 1/spp. When the VL set was
 * a function of the seed alone, the accumulated image kept that one set's
 * error for ever and the difference between seeds did not fall
 * (passes_per_set = 0 restores that: measured ratio ≈ 1). Few VLs per set
 * (16) make one set's error dominate, as in the CT scenes where 1000 VLs
 * per 256³ volume left 4-pixel discs. Measured: rel diff 8 spp → 128 spp
 * falls ≈ 16× with fresh sets (bound: > 6×). */
static double seed_diff(volux_context *ctx, volux_scene *s, int spp) {
    volux_render_settings rs = *volux_scene_render(s);
    rs.spp = spp;
    rs.seed = 1;
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    volux_image a = tu_render(ctx, s, "manylights");
    rs.seed = 2;
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    volux_image b = tu_render(ctx, s, "manylights");
    volux_image_error e;
    assert_int_equal(volux_image_compare(ctx, &a, &b, &e), VOLUX_OK);
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    return e.rel_mse;
}

static void test_seeds_converge(void **state) {
    (void)state;
    volux_context *ctx = tu_context(0);
    volux_scene *s = tu_scene(ctx, scene_json);
    volux_render_settings rs = *volux_scene_render(s);
    rs.width = rs.height = 12;
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "vl_count", 16, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "vsl_radius", 1.5, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "avsm_resolution", 6, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "single_scattering", 0, NULL), VOLUX_OK);
    double d8 = seed_diff(ctx, s, 8), d128 = seed_diff(ctx, s, 128);
    printf("  seed 1 vs seed 2 (multiple scattering, 16 VLs per set): rel_mse %.4g at 8 spp, %.4g at 128 spp "
           "(ratio %.1f, 16 expected)\n",
           d8, d128, d8 / d128);
    assert_true(d128 > 0.0);
    assert_true(d128 * 6.0 < d8);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* The cache holds the model (issue 27): with the default `ball` kernel and
 * AVSM (16², footprint steps, 8 nodes, automatic radius), `avsm` and
 * `raymarch` — same seed, so the same VLs, view samples and ball points —
 * differ only by the cache's error. Mean |I_avsm − I_rm| / I_rm over the
 * lit pixels (multiple scattering alone), as bench/manylights/errimage.sh
 * does on the CTs. Measured 1.2 % (+1.0 % mean luminance); when `raymarch` marched the straight
 * path y → x while the AVSM holds the VL's radial ray, the same check gave
 * 10.9 % (bound 5 %, W13's Fig. 3 target). */
static double mean_rel_diff(const volux_image *a, const volux_image *ref) {
    double max = 0.0, sum = 0.0;
    int n = 0;
    for (int y = 0; y < ref->height; y++)
        for (int x = 0; x < ref->width; x++) max = fmax(max, tu_pixel(ref, x, y, 1));
    for (int y = 0; y < ref->height; y++)
        for (int x = 0; x < ref->width; x++) {
            double r = tu_pixel(ref, x, y, 1);
            if (!(r > 1e-3 * max)) continue;
            sum += fabs(tu_pixel(a, x, y, 1) - r) / r;
            n++;
        }
    return n ? sum / n : 0.0;
}

static void test_avsm_matches_raymarch(void **state) {
    (void)state;
    volux_context *ctx = tu_context(0);
    volux_scene *s = tu_scene(ctx, scene_json);
    volux_render_settings rs = *volux_scene_render(s);
    rs.width = rs.height = 16;
    rs.spp = 2;
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "vl_count", 64, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "vsl_radius", 0, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "avsm_resolution", 16, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "avsm_nodes", 8, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "single_scattering", 0, NULL), VOLUX_OK);
    volux_image cached = tu_render(ctx, s, "manylights");
    assert_int_equal(volux_scene_set_param(s, "manylights", "transmittance", 0, "raymarch"), VOLUX_OK);
    volux_image marched = tu_render(ctx, s, "manylights");
    double d = mean_rel_diff(&cached, &marched);
    printf("  ball kernel, AVSM 16^2 vs ray-marched: mean relative difference %.2f%% (mean luminance %+.2f%%)\n",
           100.0 * d, 100.0 * (tu_mean_luminance(&cached) / tu_mean_luminance(&marched) - 1.0));
    assert_true(tu_mean_luminance(&marched) > 0.0);
    assert_true(d < 0.05);
    volux_image_free(ctx, &cached);
    volux_image_free(ctx, &marched);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_seeds_converge),
                                       cmocka_unit_test(test_avsm_matches_raymarch),
                                       cmocka_unit_test(test_manylights_vs_pathtrace)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
