/* The denoiser (volux/denoise.h) and the first-hit features it is guided
 * by (volux_framebuffer_set_features): a constant field stays constant; an
 * edge between two media that the colour alone cannot tell from noise is
 * kept by the features (and leaks without them); the denoised error is
 * below the raw error against a converged reference on procedural scenes
 * at 1–64 spp; at high spp the output stays within the stated band of the
 * raw accumulation; features leave the colour bit-identical; EXR layers;
 * the CLI's options. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_util.h"

/* A deterministic noise in [-1, 1]. */
static float noise(uint32_t i) {
    i ^= i >> 16, i *= 0x7feb352dU, i ^= i >> 15, i *= 0x846ca68bU, i ^= i >> 16;
    return (float)(i & 0xffffff) / (float)0x800000 - 1.0f;
}

typedef struct synth {
    volux_image img;
    volux_features f;
} synth;

/* w×h of colour c (grey) per side of a vertical edge at x = w/2, with
 * uniform noise of amplitude amp (variance amp²/3 per "sample", spp
 * samples), features per side. */
static synth make_synth(volux_context *ctx, int w, int h, float left, float right, float amp, float albedo_l,
                        float albedo_r, uint32_t spp, int features) {
    synth s;
    memset(&s, 0, sizeof s);
    assert_int_equal(volux_image_create(ctx, w, h, &s.img), VOLUX_OK);
    size_t n = (size_t)w * (size_t)h;
    s.f.width = w, s.f.height = h;
    s.f.variance = calloc(n, sizeof(float));
    if (features) {
        s.f.coverage = calloc(n, sizeof(float));
        s.f.depth = calloc(n, sizeof(float));
        s.f.albedo = calloc(3 * n, sizeof(float));
        s.f.normal = calloc(3 * n, sizeof(float));
        s.f.density = calloc(n, sizeof(float));
    }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * (size_t)w + (size_t)x;
            int right_side = x >= w / 2;
            float v = (right_side ? right : left) + amp * noise((uint32_t)p * 7919u + 17u);
            for (int c = 0; c < 3; c++) s.img.rgb[3 * p + (size_t)c] = v;
            s.f.variance[p] = spp >= 2 ? amp * amp / 3.0f : -1.0f;
            if (!features) continue;
            s.f.coverage[p] = 1.0f;
            s.f.depth[p] = right_side ? 2.0f : 1.0f;
            for (int c = 0; c < 3; c++) s.f.albedo[3 * p + (size_t)c] = right_side ? albedo_r : albedo_l;
            s.f.normal[3 * p + 2] = -1.0f;
        }
    return s;
}

static void free_synth(volux_context *ctx, synth *s) {
    volux_image_free(ctx, &s->img);
    free(s->f.variance), free(s->f.coverage), free(s->f.depth), free(s->f.albedo), free(s->f.normal),
        free(s->f.density);
}

static void test_constant_field_stays_constant(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    for (int features = 0; features <= 1; features++)
        for (uint32_t spp = 1; spp <= 16; spp *= 16) {
            synth s = make_synth(ctx, 61, 47, 0.37f, 0.37f, 0.0f, 0.5f, 0.5f, spp, features);
            /* a variance as a noisy pixel would claim: the filter still may
             * only average equal values */
            for (size_t p = 0; p < 61 * 47; p++) s.f.variance[p] = spp >= 2 ? 0.01f : -1.0f;
            volux_image out = {0};
            assert_int_equal(volux_denoise(ctx, &s.img, &s.f, spp, NULL, &out), VOLUX_OK);
            for (size_t i = 0; i < 3 * 61 * 47; i++) assert_near(out.rgb[i], 0.37f, 1e-6);
            volux_image_free(ctx, &out);
            free_synth(ctx, &s);
        }
    volux_context_destroy(ctx);
}

/* Mean over the rows of column x. */
static double column_mean(const volux_image *img, int x) {
    double s = 0.0;
    for (int y = 0; y < img->height; y++) s += tu_pixel(img, x, y, 1);
    return s / img->height;
}

static void test_edge_between_media_is_preserved(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    /* 0.45 | 0.55 under noise of σ = 0.15/√3·… ≈ 0.087 per pixel: the
     * colour weight cannot separate them, the albedo guide (0.3 | 0.9) can. */
    const int w = 64, h = 64;
    synth s = make_synth(ctx, w, h, 0.45f, 0.55f, 0.15f, 0.3f, 0.9f, 4, 1);
    volux_denoise_settings no_blend = {0};
    no_blend.no_blend = 1; /* the filter itself, not rescued by the blend */
    volux_image out = {0};
    assert_int_equal(volux_denoise(ctx, &s.img, &s.f, 4, &no_blend, &out), VOLUX_OK);
    double leak = 0.0, raw_err = 0.0, den_err = 0.0;
    for (int x = 0; x < w; x++) {
        double truth = x >= w / 2 ? 0.55 : 0.45;
        leak = fmax(leak, fabs(column_mean(&out, x) - truth));
    }
    for (size_t p = 0; p < (size_t)(w * h); p++) {
        double truth = (int)(p % (size_t)w) >= w / 2 ? 0.55 : 0.45;
        raw_err += pow(s.img.rgb[3 * p + 1] - truth, 2);
        den_err += pow(out.rgb[3 * p + 1] - truth, 2);
    }
    /* No column, the ones next to the edge included, moves by more than a
     * fifth of the step towards the other side; and the noise fell. */
    if (!(leak < 0.02)) fail_msg("leak across the edge %.4f (bound 0.02)", leak);
    if (!(den_err < 0.25 * raw_err)) fail_msg("denoised squared error %.4g vs raw %.4g", den_err, raw_err);
    volux_image_free(ctx, &out);

    /* The same filter without the features blurs the edge: the bound above
     * is what the features buy. */
    volux_features colour_only = s.f;
    colour_only.coverage = colour_only.depth = colour_only.albedo = colour_only.normal = NULL;
    assert_int_equal(volux_denoise(ctx, &s.img, &colour_only, 4, &no_blend, &out), VOLUX_OK);
    double leak0 = 0.0;
    for (int x = 0; x < w; x++) leak0 = fmax(leak0, fabs(column_mean(&out, x) - (x >= w / 2 ? 0.55 : 0.45)));
    if (!(leak0 > 0.02)) fail_msg("without features the edge leaks only %.4f: the test would not see a defect", leak0);
    volux_image_free(ctx, &out);
    free_synth(ctx, &s);
    volux_context_destroy(ctx);
}

static const char *scenes[] = {
    /* a CT-like phantom, directional light */
    "{\"volume\": {\"procedural\": \"phantom\", \"dims\": [32, 32, 32]},"
    " \"transfer_function\": {\"color\": [[0, 0.2, 0.3, 0.6], [60, 0.9, 0.5, 0.3], [255, 1, 1, 1]],"
    "   \"opacity\": [[0, 0], [30, 0], [60, 0.05], [140, 0.3], [255, 0.9]], \"albedo\": 0.9},"
    " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}, \"fov_y\": 30},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.5, -0.7, -0.5], \"irradiance\": 2}],"
    " \"background\": [0.02, 0.02, 0.03],"
    " \"render\": {\"technique\": \"pathtrace\", \"width\": 40, \"height\": 40, \"spp\": 1, \"max_depth\": 16}}",
    /* a cloud under a constant sky and a sun */
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [32, 32, 32]},"
    " \"transfer_function\": {\"color\": [[0, 1, 1, 1], [255, 1, 1, 1]],"
    "   \"opacity\": [[0, 0], [40, 0.1], [255, 0.8]], \"albedo\": 0.95},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.3, -0.9, -0.2], \"irradiance\": 2},"
    "              {\"type\": \"environment\", \"radiance\": 0.3, \"color\": [0.6, 0.75, 1.0]}],"
    " \"render\": {\"technique\": \"pathtrace\", \"width\": 40, \"height\": 40, \"spp\": 1, \"max_depth\": 16}}",
};

static void test_denoised_error_below_raw(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    for (int sc = 0; sc < 2; sc++) {
        volux_scene *s = tu_scene(ctx, scenes[sc]);
        volux_technique *t = NULL;
        volux_framebuffer *fb = NULL;
        assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
        /* the converged reference: another seed, 512 spp */
        volux_render_settings rs = *volux_scene_render(s);
        rs.seed = 99;
        assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
        assert_int_equal(volux_framebuffer_create(ctx, 40, 40, &fb), VOLUX_OK);
        volux_render_limits ref_lim = {512, 0, 0};
        volux_image ref = {0};
        assert_int_equal(volux_render(t, s, fb, &ref_lim, NULL), VOLUX_OK);
        assert_int_equal(volux_framebuffer_resolve(fb, &ref), VOLUX_OK);
        rs.seed = 1;
        assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
        assert_int_equal(volux_framebuffer_set_features(fb, 1), VOLUX_OK);
        for (uint32_t spp = 1; spp <= 64; spp *= 4) {
            volux_render_limits lim = {spp, 0, 0};
            assert_int_equal(volux_render(t, s, fb, &lim, NULL), VOLUX_OK);
            assert_int_equal(volux_framebuffer_has_features(fb), 1);
            volux_image raw = {0}, den = {0};
            assert_int_equal(volux_framebuffer_resolve(fb, &raw), VOLUX_OK);
            assert_int_equal(volux_framebuffer_denoise(fb, NULL, &den), VOLUX_OK);
            volux_image_error er, ed;
            assert_int_equal(volux_image_compare(ctx, &raw, &ref, &er), VOLUX_OK);
            assert_int_equal(volux_image_compare(ctx, &den, &ref, &ed), VOLUX_OK);
            print_message("scene %d, %3u spp: rel_mse raw %.3g, denoised %.3g\n", sc, spp, er.rel_mse, ed.rel_mse);
            /* The baseline kernel gives the same bits as the CPU's (AVX2
             * here; 40 columns leave a tail for the 8-lane loop). */
            volux_denoise_settings portable = {.portable = 1};
            volux_image den_p = {0};
            assert_int_equal(volux_framebuffer_denoise(fb, &portable, &den_p), VOLUX_OK);
            size_t differ = 0;
            for (size_t i = 0; i < 3 * (size_t)40 * 40; i++) differ += memcmp(&den.rgb[i], &den_p.rgb[i], 4) != 0;
            if (differ) fail_msg("scene %d at %u spp: %zu values differ between kernels", sc, spp, differ);
            volux_image_free(ctx, &den_p);
            if (!(ed.rel_mse <= er.rel_mse))
                fail_msg("scene %d at %u spp: denoised rel_mse %.4g > raw %.4g", sc, spp, ed.rel_mse, er.rel_mse);
            volux_image_free(ctx, &raw);
            volux_image_free(ctx, &den);
        }
        volux_image_free(ctx, &ref);
        volux_framebuffer_destroy(fb);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
    }
    volux_context_destroy(ctx);
}

/* The blend: the output never leaves raw ± VOLUX_DENOISE_BAND standard
 * errors (of the 3×3 mean variance), so as the variance falls it converges
 * to the raw accumulation. */
static void test_blend_stays_near_raw_at_high_spp(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    const int w = 48, h = 40;
    /* the residual noise of a long render: amplitude 1e-3 on a step */
    synth s = make_synth(ctx, w, h, 0.2f, 0.8f, 1e-3f, 0.5f, 0.5f, 65536, 1);
    for (size_t p = 0; p < (size_t)(w * h); p++) s.f.variance[p] = 1e-6f / 3.0f / 65536.0f;
    volux_image out = {0};
    assert_int_equal(volux_denoise(ctx, &s.img, &s.f, 65536, NULL, &out), VOLUX_OK);
    float band = VOLUX_DENOISE_BAND * sqrtf(1e-6f / 3.0f / 65536.0f);
    for (size_t i = 0; i < (size_t)(3 * w * h); i++) assert_near(out.rgb[i], s.img.rgb[i], band * 1.001f + 1e-7f);
    volux_image_free(ctx, &out);
    free_synth(ctx, &s);

    /* and on a render: the denoised image's distance to the raw one falls
     * as the samples grow (64× the samples: far below a quarter) */
    volux_scene *sc = tu_scene(ctx, scenes[0]);
    volux_technique *t = NULL;
    volux_framebuffer *fb = NULL;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", sc, &t), VOLUX_OK);
    assert_int_equal(volux_framebuffer_create(ctx, 40, 40, &fb), VOLUX_OK);
    assert_int_equal(volux_framebuffer_set_features(fb, 1), VOLUX_OK);
    double d[2];
    for (int k = 0; k < 2; k++) {
        volux_render_limits lim = {k ? 256u : 4u, 0, 0};
        assert_int_equal(volux_render(t, sc, fb, &lim, NULL), VOLUX_OK);
        volux_image raw = {0}, den = {0};
        assert_int_equal(volux_framebuffer_resolve(fb, &raw), VOLUX_OK);
        assert_int_equal(volux_framebuffer_denoise(fb, NULL, &den), VOLUX_OK);
        volux_image_error e;
        assert_int_equal(volux_image_compare(ctx, &den, &raw, &e), VOLUX_OK);
        d[k] = e.rmse;
        volux_image_free(ctx, &raw);
        volux_image_free(ctx, &den);
    }
    print_message("rmse(denoised, raw): 4 spp %.3g, 256 spp %.3g\n", d[0], d[1]);
    if (!(d[1] < 0.25 * d[0])) fail_msg("at 256 spp the denoised image is %.3g from raw (4 spp: %.3g)", d[1], d[0]);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(sc);
    volux_context_destroy(ctx);
}

/* Features: the colour is bit-identical with them on; they are sane (the
 * rays that miss the volume have coverage 0 and depth +inf, the others a
 * depth inside the camera's range and unit-or-shorter normals facing the
 * camera); the same for 1 and 2 threads. */
static void test_features(void **state) {
    (void)state;
    volux_image colour[2], feat_img[2];
    for (int threads = 1; threads <= 2; threads++) {
        volux_context *ctx = tu_context(threads);
        volux_scene *s = tu_scene(ctx, scenes[0]);
        volux_technique *t = NULL;
        volux_framebuffer *fb = NULL, *plain = NULL;
        assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
        assert_int_equal(volux_framebuffer_create(ctx, 40, 40, &fb), VOLUX_OK);
        assert_int_equal(volux_framebuffer_create(ctx, 40, 40, &plain), VOLUX_OK);
        assert_int_equal(volux_framebuffer_set_features(fb, 1), VOLUX_OK);
        volux_render_limits lim = {3, 0, 0};
        assert_int_equal(volux_render(t, s, fb, &lim, NULL), VOLUX_OK);
        assert_int_equal(volux_render(t, s, plain, &lim, NULL), VOLUX_OK);
        assert_int_equal(volux_framebuffer_has_features(plain), 0);
        volux_image a = {0}, b = {0};
        assert_int_equal(volux_framebuffer_resolve(fb, &a), VOLUX_OK);
        assert_int_equal(volux_framebuffer_resolve(plain, &b), VOLUX_OK);
        assert_memory_equal(a.rgb, b.rgb, 3 * 40 * 40 * sizeof(float));
        volux_image_free(ctx, &b);
        colour[threads - 1] = a;
        volux_features f;
        assert_int_equal(volux_framebuffer_resolve_features(fb, &f), VOLUX_OK);
        assert_non_null(f.depth);
        int covered = 0, empty = 0;
        for (int p = 0; p < 40 * 40; p++) {
            assert_true(f.coverage[p] >= 0.0f && f.coverage[p] <= 1.0f + 1e-5f);
            if (f.coverage[p] == 0.0f) {
                empty++;
                assert_true(isinf(f.depth[p]));
                continue;
            }
            covered++;
            assert_true(isfinite(f.depth[p]) && f.depth[p] > 0.0f);
            float n2 = 0.0f;
            for (int c = 0; c < 3; c++) {
                n2 += f.normal[3 * p + c] * f.normal[3 * p + c];
                assert_true(f.albedo[3 * p + c] >= 0.0f && f.albedo[3 * p + c] <= 0.9f + 1e-4f);
            }
            assert_true(n2 <= 1.0f + 1e-4f);
            assert_true(f.density[p] >= 0.0f);
        }
        print_message("%d pixels covered, %d empty\n", covered, empty);
        assert_true(covered > 100 && empty > 50); /* the phantom, and the background around it */
        /* the features in one image to compare between thread counts */
        assert_int_equal(volux_image_create(ctx, 40, 40, &feat_img[threads - 1]), VOLUX_OK);
        for (int p = 0; p < 40 * 40; p++) {
            feat_img[threads - 1].rgb[3 * p] = f.coverage[p];
            feat_img[threads - 1].rgb[3 * p + 1] = isinf(f.depth[p]) ? -1.0f : f.depth[p];
            feat_img[threads - 1].rgb[3 * p + 2] = f.albedo[3 * p] + f.normal[3 * p + 1];
        }
        volux_features_free(ctx, &f);
        /* turning them off frees them; has_features says so */
        assert_int_equal(volux_framebuffer_set_features(fb, 0), VOLUX_OK);
        assert_int_equal(volux_framebuffer_has_features(fb), 0);
        volux_framebuffer_destroy(fb);
        volux_framebuffer_destroy(plain);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
        volux_context_destroy(ctx);
    }
    assert_memory_equal(colour[0].rgb, colour[1].rgb, 3 * 40 * 40 * sizeof(float));
    assert_memory_equal(feat_img[0].rgb, feat_img[1].rgb, 3 * 40 * 40 * sizeof(float));
    for (int k = 0; k < 2; k++) free(colour[k].rgb), free(feat_img[k].rgb);
}

static void test_exr_layers_and_cli(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image img = {0};
    assert_int_equal(volux_image_create(ctx, 5, 4, &img), VOLUX_OK);
    float depth[20], albedo[60];
    for (int i = 0; i < 60; i++) img.rgb[i] = albedo[i] = 0.01f * (float)i;
    for (int i = 0; i < 20; i++) depth[i] = (float)i;
    volux_image_layer layers[2] = {{NULL, 1, {"Z", NULL, NULL, NULL}, depth},
                                   {"albedo", 3, {"R", "G", "B", NULL}, albedo}};
    const char *path = tu_temp_path("layers.exr");
    assert_int_equal(volux_image_save_layers(ctx, path, &img, 0.0f, NULL, layers, 2), VOLUX_OK);
    volux_image back = {0};
    assert_int_equal(volux_image_load(ctx, path, &back), VOLUX_OK);
    assert_memory_equal(back.rgb, img.rgb, 60 * sizeof(float)); /* R, G, B are still the image */
    volux_image_free(ctx, &back);
    /* the channel list names the layers */
    FILE *f = fopen(path, "rb");
    char head[2048];
    size_t n = fread(head, 1, sizeof head, f);
    fclose(f);
    int found = 0;
    for (size_t i = 0; i + 8 < n; i++) found |= !memcmp(head + i, "albedo.R", 8);
    assert_true(found);
    /* layers need EXR; a repeated channel is refused */
    assert_int_equal(volux_image_save_layers(ctx, tu_temp_path("layers.png"), &img, 0.0f, NULL, layers, 2),
                     VOLUX_ERR_INVALID);
    layers[1].layer = NULL, layers[1].names[0] = "Z";
    assert_int_equal(volux_image_save_layers(ctx, path, &img, 0.0f, NULL, layers, 2), VOLUX_ERR_INVALID);
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);

    const char *err = NULL;
    char args[1024];
    snprintf(args, sizeof args, "render procedural:phantom:24 --technique pathtrace --width 24 --height 24 --spp 2 "
                                "-o %s --aov depth",
             tu_temp_path("x.png"));
    assert_int_equal(tu_run_cli(args, &err), 2);
    assert_non_null(strstr(err, "--aov"));
    snprintf(args, sizeof args, "render procedural:phantom:24 --technique pathtrace --width 24 --height 24 --spp 2 "
                                "-o %s --aov depht",
             tu_temp_path("x.exr"));
    assert_int_equal(tu_run_cli(args, &err), 2);
    assert_non_null(strstr(err, "depth"));
    snprintf(args, sizeof args, "render procedural:phantom:24 --technique pathtrace --width 24 --height 24 --spp 2 "
                                "-o %s --aov all --denoise --quiet",
             tu_temp_path("x.exr"));
    assert_int_equal(tu_run_cli(args, &err), 0);
    volux_context *c2 = tu_context(1);
    volux_image_meta meta;
    assert_int_equal(volux_image_load_meta(c2, tu_temp_path("x.exr"), &back, &meta), VOLUX_OK);
    assert_string_equal(volux_image_meta_get(&meta, "volux.denoised"), "true");
    volux_image_free(c2, &back);
    volux_context_destroy(c2);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_constant_field_stays_constant),
        cmocka_unit_test(test_edge_between_media_is_preserved),
        cmocka_unit_test(test_denoised_error_below_raw),
        cmocka_unit_test(test_blend_stays_near_raw_at_high_spp),
        cmocka_unit_test(test_features),
        cmocka_unit_test(test_exr_layers_and_cli),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
