/*
 * tests/library/test_library_api.c — what a program embedding volux relies
 * on: the version, volumes from the caller's memory (copy and borrow, any
 * strides), scenes with a supplied volume, scene assignment (edits by
 * reloading), and the threading contract (one context per thread renders
 * the same images as serial rendering).
 */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_util.h"
#include "tu_volume.h"

static const char *SCENE_JSON =
    "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [24, 24, 24]},"
    " \"transfer_function\": {\"color\": [[0, 1, 0.6, 0.3], [255, 0.3, 0.6, 1]],"
    "   \"opacity\": [[0, 0], [60, 0.05], [255, 0.6]]},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-1, -1, -1], \"irradiance\": 2}],"
    " \"background\": [0.1, 0.1, 0.1],"
    " \"render\": {\"technique\": \"shaded\", \"width\": 40, \"height\": 32, \"spp\": 1}}";

static void test_version(void **state) {
    (void)state;
    assert_string_equal(volux_version(), VOLUX_VERSION);
    assert_int_equal(volux_version_number(), VOLUX_VERSION_NUMBER);
    char buf[32];
    snprintf(buf, sizeof buf, "%d.%d.%d", VOLUX_VERSION_MAJOR, VOLUX_VERSION_MINOR, VOLUX_VERSION_PATCH);
    assert_string_equal(buf, VOLUX_VERSION);
}

/* "Did you mean" for technique names: typos and prefixes find the
 * registered name, unrelated words and empty names find none, and the
 * library's own message for an unknown technique carries the guess. */
static void test_technique_closest(void **state) {
    (void)state;
    assert_string_equal(volux_technique_closest("pathtrac"), "pathtrace");
    assert_string_equal(volux_technique_closest("pathtracer"), "pathtrace");
    assert_string_equal(volux_technique_closest("path"), "pathtrace");
    assert_string_equal(volux_technique_closest("lightvolume"), "lightvol");
    assert_string_equal(volux_technique_closest("ambeint"), "ambient");
    assert_null(volux_technique_closest("xylophone"));
    assert_null(volux_technique_closest(""));
    assert_null(volux_technique_closest(NULL));
    for (int i = 0; i < volux_technique_count(); i++) {
        const char *name = volux_technique_info_at(i)->name;
        assert_string_equal(volux_technique_closest(name), name);
    }

    volux_context *ctx = tu_context(1);
    volux_scene *scene;
    assert_int_equal(volux_scene_load_string(ctx, SCENE_JSON, NULL, "t.json", NULL, 0, &scene), VOLUX_OK);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "ambeint", scene, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "did you mean 'ambient'?"));
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
}

/* A field with a distinct value per node: f(i,j,k) = i + 10 j + 100 k. */
static float field_value(int i, int j, int k) { return (float)(i + 10 * j + 100 * k); }

static void test_copy_strided(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    enum { NX = 5, NY = 4, NZ = 3 };
    /* Stored as a [x][y][z] double array (z fastest, Fortran order of
     * (z,y,x)) with x reversed: strides are signed and non-packed. */
    double *buf = malloc(sizeof(double) * NX * NY * NZ);
    for (int i = 0; i < NX; i++)
        for (int j = 0; j < NY; j++)
            for (int k = 0; k < NZ; k++) buf[((NX - 1 - i) * NY + j) * NZ + k] = field_value(i, j, k);
    volux_volume_memory_desc d = {.dims = {NX, NY, NZ}, .type = VOLUX_FLOAT64, .mode = VOLUX_MEMORY_COPY};
    d.data = buf + (size_t)(NX - 1) * NY * NZ; /* element (0,0,0) */
    d.strides[0] = -(int64_t)(sizeof(double) * NY * NZ);
    d.strides[1] = (int64_t)(sizeof(double) * NZ);
    d.strides[2] = (int64_t)sizeof(double);
    volux_volume *v;
    assert_int_equal(volux_volume_from_memory(ctx, &d, &v), VOLUX_OK);
    free(buf); /* copied: the buffer may go */
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) assert_true(volux_volume_value_at(v, i, j, k) == field_value(i, j, k));
    assert_int_equal(volux_volume_type(v), VOLUX_FLOAT64);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static int released;
static void on_release(void *user) { released += *(int *)user; }

static void test_borrow(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    enum { N = 16 };
    float *buf = malloc(sizeof(float) * N * N * N);
    for (int k = 0; k < N; k++)
        for (int j = 0; j < N; j++)
            for (int i = 0; i < N; i++) buf[(k * N + j) * N + i] = field_value(i, j, k);
    int one = 1;
    released = 0;
    volux_volume_memory_desc d = {.dims = {N, N, N}, .type = VOLUX_FLOAT32, .data = buf,
                                  .mode = VOLUX_MEMORY_BORROW, .release = on_release, .release_user = &one};
    volux_volume *borrowed, *copied;
    uint64_t before = volux_context_bytes_in_use(ctx);
    assert_int_equal(volux_volume_from_memory(ctx, &d, &borrowed), VOLUX_OK);
    /* No copy of the grid: far less than N³ floats were allocated. */
    assert_true(volux_context_bytes_in_use(ctx) - before < sizeof(float) * N * N * N / 4);
    d.mode = VOLUX_MEMORY_COPY;
    assert_int_equal(volux_volume_from_memory(ctx, &d, &copied), VOLUX_OK);
    assert_true(volux_volume_value_at(borrowed, 3, 5, 7) == field_value(3, 5, 7));
    double lo, hi;
    volux_volume_range(borrowed, &lo, &hi);
    assert_true(lo == 0.0 && hi == field_value(N - 1, N - 1, N - 1));

    /* A render from the borrowed grid equals one from the copy, bit for bit. */
    volux_image img[2];
    volux_volume *vols[2] = {borrowed, copied};
    for (int n = 0; n < 2; n++) {
        volux_scene *s;
        assert_int_equal(volux_scene_load_string_with_volume(ctx, SCENE_JSON, NULL, "t.json", NULL, 0, vols[n], &s),
                         VOLUX_OK);
        assert_ptr_equal(volux_scene_volume(s), vols[n]);
        img[n] = tu_render(ctx, s, NULL);
        volux_scene_destroy(s);
    }
    assert_true(tu_max_abs_diff(&img[0], &img[1]) == 0.0);
    volux_image_free(ctx, &img[0]);
    volux_image_free(ctx, &img[1]);

    /* The release callback runs once, at the last release, not before. */
    volux_volume_retain(borrowed);
    volux_volume_release(borrowed);
    assert_int_equal(released, 0);
    volux_volume_release(borrowed);
    assert_int_equal(released, 1);
    volux_volume_release(copied);
    assert_int_equal(released, 1);
    free(buf);
    volux_context_destroy(ctx);
}

static void expect_refusal(volux_context *ctx, const volux_volume_memory_desc *d, volux_status want,
                           const char *words) {
    volux_volume *v = NULL;
    volux_context_clear_error(ctx);
    released = 0;
    assert_int_equal(volux_volume_from_memory(ctx, d, &v), want);
    assert_null(v);
    assert_int_equal(released, 0); /* a failed create calls nothing */
    if (!strstr(volux_context_error(ctx), words))
        fail_msg("message '%s' lacks '%s'", volux_context_error(ctx), words);
}

static void test_memory_refusals(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    static float f[8 * 8 * 8];
    static int16_t s16[8 * 8 * 8];
    int one = 1;
    volux_volume_memory_desc d = {.dims = {8, 8, 8}, .type = VOLUX_FLOAT32, .data = f,
                                  .mode = VOLUX_MEMORY_BORROW, .release = on_release, .release_user = &one};
    d.data = NULL;
    expect_refusal(ctx, &d, VOLUX_ERR_INVALID, "data is NULL");
    d.data = f;
    d.mode = (volux_memory_mode)7;
    expect_refusal(ctx, &d, VOLUX_ERR_INVALID, "mode 7");
    d.mode = VOLUX_MEMORY_BORROW;
    d.dims[1] = 0;
    expect_refusal(ctx, &d, VOLUX_ERR_LIMIT, "dims[1] = 0");
    d.dims[1] = 8;
    d.strides[0] = 4, d.strides[1] = 0, d.strides[2] = 256;
    expect_refusal(ctx, &d, VOLUX_ERR_INVALID, "strides[1] is 0");
    d.strides[1] = 64, d.strides[0] = 8, d.strides[2] = 512; /* every other x: not packed */
    d.dims[0] = 4;
    expect_refusal(ctx, &d, VOLUX_ERR_UNSUPPORTED, "not packed");
    memset(d.strides, 0, sizeof d.strides);
    d.dims[0] = 8;
    d.data = (const char *)f + 2;
    d.dims[2] = 7; /* stays inside f */
    expect_refusal(ctx, &d, VOLUX_ERR_UNSUPPORTED, "not aligned");
    d.data = s16, d.type = VOLUX_INT16, d.dims[2] = 8;
    expect_refusal(ctx, &d, VOLUX_ERR_UNSUPPORTED, "only uint8, uint16 and float32");
    f[3 + 8 * (2 + 8 * 1)] = NAN;
    d.data = f, d.type = VOLUX_FLOAT32;
    expect_refusal(ctx, &d, VOLUX_ERR_UNSUPPORTED, "non-finite value at (3, 2, 1)");
    /* Copying is fine and turns NaN into 0. */
    d.mode = VOLUX_MEMORY_COPY;
    volux_volume *v;
    assert_int_equal(volux_volume_from_memory(ctx, &d, &v), VOLUX_OK);
    assert_true(volux_volume_value_at(v, 3, 2, 1) == 0.0f);
    volux_volume_release(v);
    assert_int_equal(released, 0); /* COPY never calls release */
    f[3 + 8 * (2 + 8 * 1)] = 0.0f;
    volux_context_destroy(ctx);
}

/* Allocation failure at every point of the new entry points: a status, no
 * leak, no release call, and the first success is complete. */
static void test_memory_oom(void **state) {
    (void)state;
    enum { N = 12 };
    static float f[N * N * N];
    for (int i = 0; i < N * N * N; i++) f[i] = (float)(i % 7);
    for (int mode = 0; mode < 2; mode++) {
        int ok = 0;
        for (long k = 1; k < 200 && !ok; k++) {
            tu_alloc_stats stats = {0};
            volux_context *ctx = tu_context_counting(0, &stats);
            size_t base = stats.live; /* the context's own storage */
            stats.fail_at = stats.count + k;
            int one = 1;
            released = 0;
            volux_volume_memory_desc d = {.dims = {N, N, N}, .type = VOLUX_FLOAT32, .data = f,
                                          .mode = (volux_memory_mode)mode, .release = on_release,
                                          .release_user = &one};
            volux_volume *v = NULL;
            volux_scene *s = NULL;
            volux_status st = volux_volume_from_memory(ctx, &d, &v);
            if (st == VOLUX_OK) {
                st = volux_scene_load_string_with_volume(ctx, SCENE_JSON, NULL, "t.json", NULL, 0, v, &s);
                if (st == VOLUX_OK) {
                    ok = 1;
                    assert_true(volux_volume_value_at(v, 5, 6, 7) == f[5 + N * (6 + N * 7)]);
                    volux_scene_destroy(s);
                } else
                    assert_int_equal(st, VOLUX_ERR_NOMEM);
                volux_volume_release(v);
                assert_int_equal(released, mode == VOLUX_MEMORY_BORROW ? 1 : 0);
            } else {
                assert_int_equal(st, VOLUX_ERR_NOMEM);
                assert_int_equal(released, 0);
            }
            assert_int_equal(stats.live, base);
            volux_context_destroy(ctx);
        }
        assert_true(ok);
    }
}

/* The scene's "volume" key is not read when a volume is supplied: not even
 * a missing file is opened. */
static void test_supplied_volume_ignores_key(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v;
    int dims[3] = {8, 8, 8};
    assert_int_equal(volux_volume_procedural(ctx, "sphere", dims, 1, &v), VOLUX_OK);
    const char *json = "{\"volume\": {\"file\": \"does-not-exist.nrrd\"}, \"transfer_function\": "
                       "{\"opacity\": [[0, 0], [255, 1]]}}";
    volux_scene *s;
    assert_int_equal(volux_scene_load_string_with_volume(ctx, json, NULL, "t.json", NULL, 0, v, &s), VOLUX_OK);
    assert_ptr_equal(volux_scene_volume(s), v);
    volux_scene_destroy(s);
    /* Without it, the same scene fails naming the file. */
    volux_context_clear_error(ctx);
    assert_int_not_equal(volux_scene_load_string(ctx, json, NULL, "t.json", NULL, 0, &s), VOLUX_OK);
    assert_non_null(strstr(volux_context_error(ctx), "does-not-exist.nrrd"));
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* Assigning a reloaded scene with one --set change bumps only that aspect,
 * and the live scene then renders what a fresh load renders. */
static void test_assign(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *live = tu_scene(ctx, SCENE_JSON);
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "shaded", live, &t), VOLUX_OK);
    static const struct {
        const char *set;
        uint32_t what;
    } edits[] = {
        {"camera.orbit.azimuth=75", VOLUX_CHANGE_CAMERA},
        {"lights.0.irradiance=3.5", VOLUX_CHANGE_LIGHTS},
        {"transfer_function.color=[[0,1,0,0],[255,0,0,1]]", VOLUX_CHANGE_COLOR},
        {"background=[0.5,0.2,0.1]", VOLUX_CHANGE_RENDER},
        {"lights.1={\"type\":\"point\",\"position\":[30,0,0],\"intensity\":200}", VOLUX_CHANGE_LIGHTS},
    };
    const char *applied[8];
    int n = 0;
    for (size_t e = 0; e < sizeof edits / sizeof edits[0]; e++) {
        applied[n++] = edits[e].set;
        volux_scene *next;
        assert_int_equal(volux_scene_load_string(ctx, SCENE_JSON, NULL, "t.json", applied, n, &next), VOLUX_OK);
        assert_int_equal(volux_scene_assign(live, next, 1), VOLUX_OK);
        volux_change_set c;
        assert_int_equal(volux_technique_update(t, live, &c), VOLUX_OK);
        if (c.what != edits[e].what) fail_msg("%s: change bits 0x%x, expected 0x%x", edits[e].set, c.what, edits[e].what);
        volux_image inc = tu_render_with(ctx, live, t), fresh = tu_render(ctx, next, "shaded");
        if (tu_max_abs_diff(&inc, &fresh) != 0.0) fail_msg("%s: assigned scene renders differently", edits[e].set);
        volux_image_free(ctx, &inc);
        volux_image_free(ctx, &fresh);
        volux_scene_destroy(next);
    }
    volux_technique_destroy(t);
    volux_scene_destroy(live);
    volux_context_destroy(ctx);
}

/* Threading contract (docs/API.md): objects of one context are used by one
 * thread at a time; different contexts may render at once. Two threads,
 * each with its own context and a different scene, give the images of a
 * serial run, bit for bit. */
typedef struct job {
    const char *technique;
    const char *set;
    volux_image img;
    int ok;
} job;

static void *run_job(void *arg) {
    job *j = arg;
    volux_context *ctx;
    volux_context_desc cd = {.threads = 2, .cache_dir = ""};
    if (volux_context_create(&cd, &ctx)) return NULL;
    volux_scene *s;
    const char *sets[1] = {j->set};
    if (volux_scene_load_string(ctx, SCENE_JSON, NULL, "t.json", sets, 1, &s) == VOLUX_OK) {
        volux_technique *t;
        volux_framebuffer *fb;
        if (volux_technique_create(ctx, j->technique, s, &t) == VOLUX_OK) {
            const volux_render_settings *r = volux_scene_render(s);
            if (volux_framebuffer_create(ctx, r->width, r->height, &fb) == VOLUX_OK) {
                volux_image img;
                /* the image is copied out with malloc: the context dies here */
                if (volux_render(t, s, fb, NULL, NULL) == VOLUX_OK && volux_framebuffer_resolve(fb, &img) == VOLUX_OK) {
                    size_t bytes = sizeof(float) * 3 * (size_t)img.width * (size_t)img.height;
                    j->img.width = img.width, j->img.height = img.height;
                    j->img.rgb = malloc(bytes);
                    memcpy(j->img.rgb, img.rgb, bytes);
                    volux_image_free(ctx, &img);
                    j->ok = 1;
                }
                volux_framebuffer_destroy(fb);
            }
            volux_technique_destroy(t);
        }
        volux_scene_destroy(s);
    }
    volux_context_destroy(ctx);
    return NULL;
}

static void test_two_threads_equal_serial(void **state) {
    (void)state;
    job serial[2] = {{"pathtrace", "render.spp=4", {0, 0, NULL}, 0}, {"shaded", "camera.orbit.azimuth=120", {0, 0, NULL}, 0}};
    job parallel[2] = {serial[0], serial[1]};
    for (int i = 0; i < 2; i++) run_job(&serial[i]);
    for (int round = 0; round < 3; round++) {
        pthread_t th[2];
        for (int i = 0; i < 2; i++) assert_int_equal(pthread_create(&th[i], NULL, run_job, &parallel[i]), 0);
        for (int i = 0; i < 2; i++) pthread_join(th[i], NULL);
        for (int i = 0; i < 2; i++) {
            assert_true(serial[i].ok && parallel[i].ok);
            assert_true(tu_max_abs_diff(&serial[i].img, &parallel[i].img) == 0.0);
            free(parallel[i].img.rgb);
            parallel[i].ok = 0;
        }
    }
    /* The two scenes really differ (the comparison above can fail). */
    assert_true(serial[0].img.width == serial[1].img.width);
    assert_true(tu_max_abs_diff(&serial[0].img, &serial[1].img) > 0.0);
    for (int i = 0; i < 2; i++) free(serial[i].img.rgb);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_version),
        cmocka_unit_test(test_technique_closest),
        cmocka_unit_test(test_copy_strided),
        cmocka_unit_test(test_borrow),
        cmocka_unit_test(test_memory_refusals),
        cmocka_unit_test(test_memory_oom),
        cmocka_unit_test(test_supplied_volume_ignores_key),
        cmocka_unit_test(test_assign),
        cmocka_unit_test(test_two_threads_equal_serial),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
