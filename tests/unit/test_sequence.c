/*
 * Time-varying volumes: the core sequence (loading on demand, a cache
 * bounded by memory, the shape rule), the scene's time step (VOLUME bumps,
 * atomic failures), the `time_step` edit on a sequence, the io loaders
 * (file lists, printf patterns, the animated cloud), the scene JSON keys
 * and the CLI's --time-step / --all-steps.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "test_util.h"
#include "tu_volume.h"

/* ------------------------------------------------------------------ a synthetic sequence */

typedef struct fake {
    int loads[16];
    int bad_step;  /* this step has other dims (−1: none)  */
    int fail_step; /* this step fails to load (−1: none)   */
    int freed;
} fake;

static volux_status fake_load(void *user, volux_context *ctx, int step, volux_volume **out) {
    fake *f = user;
    if (step == f->fail_step) return VOLUX_ERR_IO;
    f->loads[step]++;
    int n = step == f->bad_step ? 5 : 4;
    float data[5 * 5 * 5];
    for (int i = 0; i < n * n * n; i++) data[i] = (float)step;
    volux_volume_desc d = {{n, n, n}, {1, 1, 1}, {0, 0, 0}, 0, VOLUX_FLOAT32, data, 0};
    return volux_volume_create(ctx, &d, out);
}

static void fake_release(volux_context *ctx, void *user) {
    (void)ctx;
    ((fake *)user)->freed++;
}

static volux_sequence *fake_sequence(volux_context *ctx, fake *f, int steps, uint64_t cache_bytes) {
    memset(f, 0, sizeof *f);
    f->bad_step = f->fail_step = -1;
    volux_sequence_desc d = {steps, fake_load, f, fake_release, "fake", cache_bytes};
    volux_sequence *q;
    assert_int_equal(volux_sequence_create(ctx, &d, &q), VOLUX_OK);
    return q;
}

static float value_of(const volux_volume *v) { return volux_volume_value_at(v, 0, 0, 0); }

static void test_steps_load_once_while_cached(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    fake f;
    volux_sequence *q = fake_sequence(ctx, &f, 8, 0);
    for (int round = 0; round < 3; round++)
        for (int s = 0; s < 8; s++) {
            volux_volume *v;
            assert_int_equal(volux_sequence_acquire(q, s, &v), VOLUX_OK);
            assert_true(value_of(v) == (float)s);
            volux_volume_release(v);
        }
    for (int s = 0; s < 8; s++) assert_int_equal(f.loads[s], 1);
    assert_int_equal(volux_sequence_loads(q), 8);
    assert_true(volux_sequence_cached_bytes(q) > 0);
    volux_sequence_destroy(q);
    assert_int_equal(f.freed, 1);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_cache_stays_within_its_memory_bound(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    fake f;
    volux_sequence *probe = fake_sequence(ctx, &f, 1, 0);
    volux_volume *v;
    assert_int_equal(volux_sequence_acquire(probe, 0, &v), VOLUX_OK);
    uint64_t one = volux_sequence_cached_bytes(probe);
    volux_volume_release(v);
    volux_sequence_destroy(probe);

    volux_sequence *q = fake_sequence(ctx, &f, 8, 3 * one); /* room for three steps */
    for (int s = 0; s < 8; s++) {
        assert_int_equal(volux_sequence_acquire(q, s, &v), VOLUX_OK);
        volux_volume_release(v);
        assert_true(volux_sequence_cached_bytes(q) <= 3 * one);
    }
    /* the three most recent steps are cached, the oldest were dropped */
    for (int s = 5; s < 8; s++) {
        assert_int_equal(volux_sequence_acquire(q, s, &v), VOLUX_OK);
        volux_volume_release(v);
        assert_int_equal(f.loads[s], 1);
    }
    assert_int_equal(volux_sequence_acquire(q, 0, &v), VOLUX_OK);
    assert_int_equal(f.loads[0], 2);
    /* a volume handed out survives its eviction */
    for (int s = 1; s < 5; s++) {
        volux_volume *w;
        assert_int_equal(volux_sequence_acquire(q, s, &w), VOLUX_OK);
        volux_volume_release(w);
    }
    assert_true(value_of(v) == 0.0f);
    volux_volume_release(v);
    /* lowering the bound drops steps now */
    volux_sequence_set_cache_limit(q, one);
    assert_true(volux_sequence_cached_bytes(q) <= one);
    volux_sequence_destroy(q);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_a_step_of_another_shape_is_a_format_error(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    fake f;
    volux_sequence *q = fake_sequence(ctx, &f, 4, 0);
    f.bad_step = 2;
    volux_volume *v;
    assert_int_equal(volux_sequence_acquire(q, 0, &v), VOLUX_OK);
    volux_volume_release(v);
    assert_int_equal(volux_sequence_acquire(q, 2, &v), VOLUX_ERR_FORMAT);
    tu_assert_error_mentions(ctx, "fake", "time step 2", "5x5x5", "step 0", "4x4x4", "dims", NULL);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_sequence_acquire(q, 4, &v), VOLUX_ERR_INVALID);
    assert_int_equal(volux_sequence_acquire(q, -1, &v), VOLUX_ERR_INVALID);
    volux_sequence_destroy(q);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static uint32_t volume_changed(volux_scene *s, volux_scene_stamp *seen) {
    volux_change_set c = volux_scene_changes_since(s, seen);
    *seen = volux_scene_stamp_now(s);
    return c.what;
}

static void test_scene_time_step_bumps_volume_only_when_it_changes(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s;
    assert_int_equal(volux_scene_create(ctx, &s), VOLUX_OK);
    fake f;
    volux_sequence *q = fake_sequence(ctx, &f, 5, 0);
    assert_int_equal(volux_scene_set_sequence(s, q, 3), VOLUX_OK);
    assert_ptr_equal(volux_scene_sequence(s), q);
    assert_int_equal(volux_scene_time_steps(s), 5);
    assert_int_equal(volux_scene_time_step(s), 3);
    assert_true(value_of(volux_scene_volume(s)) == 3.0f);
    assert_non_null(volux_scene_transfer_lut(s));
    volux_scene_stamp seen = volux_scene_stamp_now(s);
    assert_int_equal(volux_scene_set_time_step(s, 3), VOLUX_OK);
    assert_int_equal(volume_changed(s, &seen), 0);
    assert_int_equal(volux_scene_set_time_step(s, 1), VOLUX_OK);
    assert_int_equal(volume_changed(s, &seen), VOLUX_CHANGE_VOLUME);
    assert_true(value_of(volux_scene_volume(s)) == 1.0f);
    /* failures leave the scene as it was */
    assert_int_equal(volux_scene_set_time_step(s, 5), VOLUX_ERR_INVALID);
    tu_assert_error_mentions(ctx, "time step 5", "[0, 5)", NULL);
    volux_context_clear_error(ctx);
    f.fail_step = 4;
    assert_int_equal(volux_scene_set_time_step(s, 4), VOLUX_ERR_IO);
    volux_context_clear_error(ctx);
    f.bad_step = 2;
    assert_int_equal(volux_scene_set_time_step(s, 2), VOLUX_ERR_FORMAT);
    volux_context_clear_error(ctx);
    assert_int_equal(volume_changed(s, &seen), 0);
    assert_int_equal(volux_scene_time_step(s), 1);
    /* the time_step edit plays the sequence forward, wrapping */
    const volux_edit *e = volux_edit_find("time_step");
    f.bad_step = f.fail_step = -1;
    for (int k = 0; k < 6; k++) {
        assert_int_equal(volux_edit_apply(e, s, k), VOLUX_OK);
        assert_int_equal(volux_scene_time_step(s), (2 + k) % 5);
        assert_int_equal(volume_changed(s, &seen), VOLUX_CHANGE_VOLUME);
    }
    /* a single volume replaces the sequence: one step */
    volux_volume *v;
    assert_int_equal(volux_sequence_acquire(q, 0, &v), VOLUX_OK);
    assert_int_equal(volux_scene_set_volume(s, v), VOLUX_OK);
    volux_volume_release(v);
    assert_int_equal(f.freed, 1);
    assert_null(volux_scene_sequence(s));
    assert_int_equal(volux_scene_time_steps(s), 1);
    assert_int_equal(volux_scene_set_time_step(s, 0), VOLUX_OK);
    assert_int_equal(volux_scene_set_time_step(s, 1), VOLUX_ERR_INVALID);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_set_sequence_failure_keeps_the_callers_sequence(void **state) {
    (void)state;
    for (long k = 1;; k++) {
        tu_alloc_stats stats = {0};
        volux_context *ctx = tu_context_counting(0, &stats);
        volux_scene *s;
        assert_int_equal(volux_scene_create(ctx, &s), VOLUX_OK);
        fake f;
        volux_sequence *q = fake_sequence(ctx, &f, 3, 0);
        stats.fail_at = stats.count + k;
        volux_status st = volux_scene_set_sequence(s, q, 1);
        stats.fail_at = 0;
        if (st) {
            assert_int_equal(st, VOLUX_ERR_NOMEM);
            assert_null(volux_scene_sequence(s));
            volux_sequence_destroy(q); /* still ours */
        }
        volux_scene_destroy(s);
        assert_int_equal(f.freed, 1);
        assert_int_equal(volux_context_bytes_in_use(ctx), 0);
        volux_context_destroy(ctx);
        if (!st) break;
        assert_true(k < 1000);
    }
}

/* ------------------------------------------------------------------ io: the animated cloud */

static double mean_abs_diff(const volux_volume *a, const volux_volume *b) {
    int d[3];
    volux_volume_dims(a, d);
    double sum = 0.0;
    for (int k = 0; k < d[2]; k++)
        for (int j = 0; j < d[1]; j++)
            for (int i = 0; i < d[0]; i++)
                sum += fabs(volux_volume_value_at(a, i, j, k) - volux_volume_value_at(b, i, j, k));
    return sum / ((double)d[0] * d[1] * d[2]);
}

static void test_cloud_moves_smoothly_with_time(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    int dims[3] = {32, 32, 32};
    volux_volume *still, *t0, *t1, *t2, *far;
    assert_int_equal(volux_volume_procedural(ctx, "cloud", dims, 7, &still), VOLUX_OK);
    assert_int_equal(volux_volume_procedural_at(ctx, "cloud", dims, 7, 0.0, &t0), VOLUX_OK);
    assert_int_equal(volux_volume_procedural_at(ctx, "cloud", dims, 7, 0.05, &t1), VOLUX_OK);
    assert_int_equal(volux_volume_procedural_at(ctx, "cloud", dims, 7, 0.1, &t2), VOLUX_OK);
    assert_int_equal(volux_volume_procedural_at(ctx, "cloud", dims, 7, 2.0, &far), VOLUX_OK);
    assert_true(mean_abs_diff(still, t0) == 0.0); /* time 0 is the static cloud */
    double d1 = mean_abs_diff(t0, t1), d2 = mean_abs_diff(t0, t2), dfar = mean_abs_diff(t0, far);
    printf("  mean |Δ| at t = 0.05: %.2f, 0.1: %.2f, 2: %.2f\n", d1, d2, dfar);
    assert_true(d1 > 0.0);      /* it moves... */
    assert_true(d2 > 1.5 * d1); /* ...more with more time... */
    assert_true(dfar > 4 * d1); /* ...and far away in time it is another cloud */
    volux_volume *sphere;
    assert_int_equal(volux_volume_procedural_at(ctx, "sphere", dims, 1, 0.5, &sphere), VOLUX_ERR_INVALID);
    tu_assert_error_mentions(ctx, "sphere", "not animated", NULL);
    volux_volume_release(still);
    volux_volume_release(t0);
    volux_volume_release(t1);
    volux_volume_release(t2);
    volux_volume_release(far);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ scene JSON */

static const char *scene_with(const char *volume) {
    static char buf[2048];
    snprintf(buf, sizeof buf,
             "{\"volume\": %s, \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.5]]},"
             " \"render\": {\"technique\": \"ea\", \"width\": 8, \"height\": 8}}",
             volume);
    return buf;
}

static volux_status load_scene(volux_context *ctx, const char *json, volux_scene **out) {
    return volux_scene_load_string(ctx, json, tu_temp_path(""), "seq.json", NULL, 0, out);
}

/* Raw frames f<i>.raw of 4×4×n uint8 with value 10·i. */
static void write_frame(int i, int n) {
    unsigned char b[4 * 4 * 8];
    memset(b, 10 * i, sizeof b);
    char name[32];
    snprintf(name, sizeof name, "f%d.raw", i);
    tu_write_file(name, b, (size_t)(4 * 4 * n));
}

static void test_scene_json_reads_sequences(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    for (int i = 0; i < 3; i++) write_frame(i, 4);
    const char *raw = "\"dims\": [4, 4, 4], \"type\": \"uint8\"";
    char vol[512];
    volux_scene *s;
    /* a list */
    snprintf(vol, sizeof vol, "{\"files\": [\"f2.raw\", \"f0.raw\"], %s}", raw);
    assert_int_equal(load_scene(ctx, scene_with(vol), &s), VOLUX_OK);
    assert_int_equal(volux_scene_time_steps(s), 2);
    assert_true(value_of(volux_scene_volume(s)) == 20.0f);
    assert_int_equal(volux_scene_set_time_step(s, 1), VOLUX_OK);
    assert_true(value_of(volux_scene_volume(s)) == 0.0f);
    volux_scene_destroy(s);
    /* a pattern over a range, with render.time_step */
    snprintf(vol, sizeof vol, "{\"pattern\": \"f%%d.raw\", \"range\": [0, 2], %s, \"cache_mb\": 1}", raw);
    char json[2048];
    snprintf(json, sizeof json, "%s", scene_with(vol));
    const char *ov[1] = {"render.time_step=2"};
    assert_int_equal(volux_scene_load_string(ctx, json, tu_temp_path(""), "seq.json", ov, 1, &s), VOLUX_OK);
    assert_int_equal(volux_scene_time_steps(s), 3);
    assert_int_equal(volux_scene_time_step(s), 2);
    assert_true(value_of(volux_scene_volume(s)) == 20.0f);
    volux_scene_destroy(s);
    /* a stride */
    snprintf(vol, sizeof vol, "{\"pattern\": \"f%%d.raw\", \"range\": [0, 2, 2], %s}", raw);
    assert_int_equal(load_scene(ctx, scene_with(vol), &s), VOLUX_OK);
    assert_int_equal(volux_scene_time_steps(s), 2);
    volux_scene_destroy(s);
    /* the animated cloud */
    assert_int_equal(load_scene(ctx, scene_with("{\"procedural\": \"cloud\", \"dims\": [8, 8, 8], \"steps\": 4,"
                                                " \"time_per_step\": 0.5, \"time\": 1}"),
                                &s),
                     VOLUX_OK);
    assert_int_equal(volux_scene_time_steps(s), 4);
    volux_volume *at2, *direct;
    assert_int_equal(volux_sequence_acquire(volux_scene_sequence(s), 2, &at2), VOLUX_OK);
    int d8[3] = {8, 8, 8};
    assert_int_equal(volux_volume_procedural_at(ctx, "cloud", d8, 1, 2.0, &direct), VOLUX_OK);
    assert_true(mean_abs_diff(at2, direct) == 0.0);
    volux_volume_release(at2);
    volux_volume_release(direct);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void expect_error(volux_context *ctx, const char *volume, const char *override, volux_status want,
                         const char *mention1, const char *mention2) {
    volux_scene *s = NULL;
    const char *ov[1] = {override};
    char json[2048];
    snprintf(json, sizeof json, "%s", scene_with(volume));
    volux_status st = volux_scene_load_string(ctx, json, tu_temp_path(""), "seq.json", ov, override ? 1 : 0, &s);
    if (st != want) fail_msg("%s: got %s (%s)", volume, volux_status_name(st), volux_context_error(ctx));
    tu_assert_error_mentions(ctx, "seq.json", mention1, mention2, NULL);
    volux_context_clear_error(ctx);
}

static void test_scene_json_rejects_bad_sequences(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    write_frame(0, 4);
    write_frame(1, 8); /* other dims */
    const char *raw = "\"dims\": [4, 4, 4], \"type\": \"uint8\"";
    char vol[512];
    /* frames of another size: the layout says 4×4×4, f1 holds 4×4×8 bytes */
    snprintf(vol, sizeof vol, "{\"files\": [\"f0.raw\", \"f1.raw\"], %s}", raw);
    volux_scene *s;
    assert_int_equal(load_scene(ctx, scene_with(vol), &s), VOLUX_OK); /* raw: shape from the layout... */
    assert_int_equal(volux_scene_set_time_step(s, 1), VOLUX_ERR_FORMAT); /* ...the data is checked on load */
    volux_context_clear_error(ctx);
    volux_scene_destroy(s);
    /* headers that disagree: two NRRD frames of other dims */
    const char *h0 = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n\n";
    const char *h1 = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 5\nencoding: raw\n\n";
    unsigned char zeros[80] = {0};
    tu_write_parts("n0.nrrd", h0, zeros, 64);
    tu_write_parts("n1.nrrd", h1, zeros, 80);
    expect_error(ctx, "{\"files\": [\"n0.nrrd\", \"n1.nrrd\"]}", NULL, VOLUX_ERR_FORMAT, "n1.nrrd", "4x4x5");
    expect_error(ctx, "{\"pattern\": \"n%d.nrrd\", \"range\": [0, 1]}", NULL, VOLUX_ERR_FORMAT, "volume.pattern",
                 "must share dims");
    tu_write_parts("m0.nrrd", h0, zeros, 64);
    expect_error(ctx, "{\"pattern\": \"m%d.nrrd\", \"range\": [0, 2]}", NULL, VOLUX_ERR_IO, "m1.nrrd", "time step 1");
    expect_error(ctx, "{\"pattern\": \"n%s.nrrd\", \"range\": [0, 1]}", NULL, VOLUX_ERR_INVALID, "volume.pattern",
                 "integer conversion");
    expect_error(ctx, "{\"pattern\": \"n%d%d.nrrd\", \"range\": [0, 1]}", NULL, VOLUX_ERR_INVALID, "volume.pattern",
                 "exactly one");
    expect_error(ctx, "{\"pattern\": \"n%d.nrrd\"}", NULL, VOLUX_ERR_INVALID, "volume.range", "range");
    expect_error(ctx, "{\"pattern\": \"n%d.nrrd\", \"range\": [2, 1]}", NULL, VOLUX_ERR_INVALID, "volume.range",
                 "empty");
    expect_error(ctx, "{\"file\": \"n0.nrrd\", \"range\": [0, 1]}", NULL, VOLUX_ERR_INVALID, "volume.range",
                 "only with a pattern");
    expect_error(ctx, "{\"file\": \"n0.nrrd\", \"cache_mb\": 4}", NULL, VOLUX_ERR_INVALID, "volume.cache_mb", "files");
    expect_error(ctx, "{\"file\": \"n0.nrrd\", \"files\": [\"n0.nrrd\"]}", NULL, VOLUX_ERR_INVALID, "volume",
                 "exactly one");
    expect_error(ctx, "{\"files\": []}", NULL, VOLUX_ERR_INVALID, "volume.files", "non-empty");
    expect_error(ctx, "{\"procedural\": \"sphere\", \"steps\": 3}", NULL, VOLUX_ERR_INVALID, "volume",
                 "not animated");
    expect_error(ctx, "{\"procedural\": \"cloud\", \"dims\": [8, 8, 8], \"steps\": 3}", "render.time_step=3",
                 VOLUX_ERR_INVALID, "render.time_step", "[0, 3)");
    expect_error(ctx, "{\"procedural\": \"cloud\", \"dims\": [8, 8, 8]}", "render.time_step=1", VOLUX_ERR_INVALID,
                 "render.time_step", "1 time step");
    expect_error(ctx, "{\"procedural\": \"cloud\", \"dims\": [8, 8, 8], \"frames\": 2}", NULL, VOLUX_ERR_INVALID,
                 "volume.frames", "unknown");
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ CLI */

static int exists(const char *path) {
    struct stat st;
    return stat(path, &st) == 0;
}

static void test_cli_renders_one_or_all_steps(void **state) {
    (void)state;
    const char *json = scene_with("{\"procedural\": \"cloud\", \"dims\": [12, 12, 12], \"steps\": 3}");
    char scene[512]; /* tu_* paths share static storage */
    snprintf(scene, sizeof scene, "%s", tu_write_file("cli_seq.json", json, strlen(json)));
    char args[2400], out[512], a[512], b[512];
    const char *err;
    snprintf(out, sizeof out, "%s", tu_temp_path("steps.pfm"));
    snprintf(args, sizeof args, "render '%s' -o '%s' --all-steps --quiet", scene, out);
    assert_int_equal(tu_run_cli(args, &err), 0);
    for (int i = 0; i < 3; i++) {
        char name[64];
        snprintf(name, sizeof name, "steps_%04d.pfm", i);
        if (!exists(tu_temp_path(name))) fail_msg("missing %s (%s)", name, err);
    }
    assert_false(exists(tu_temp_path("steps_0003.pfm")));
    /* --time-step N renders the image --all-steps wrote for step N */
    snprintf(a, sizeof a, "%s", tu_temp_path("one.pfm"));
    snprintf(args, sizeof args, "render '%s' -o '%s' --time-step 2 --quiet", scene, a);
    assert_int_equal(tu_run_cli(args, &err), 0);
    snprintf(b, sizeof b, "%s", tu_temp_path("steps_0002.pfm"));
    snprintf(args, sizeof args, "compare '%s' '%s' --json", a, b);
    assert_int_equal(tu_run_cli(args, &err), 0);
    volux_context *ctx = tu_context(1);
    volux_image ia, ib;
    assert_int_equal(volux_image_load(ctx, a, &ia), VOLUX_OK);
    assert_int_equal(volux_image_load(ctx, b, &ib), VOLUX_OK);
    assert_true(tu_max_abs_diff(&ia, &ib) == 0.0);
    volux_image_free(ctx, &ia);
    volux_image_free(ctx, &ib);
    volux_context_destroy(ctx);
    /* a printf-numbered output */
    snprintf(args, sizeof args, "render '%s' -o '%s' --all-steps --quiet", scene, tu_temp_path("frame%02d.png"));
    assert_int_equal(tu_run_cli(args, &err), 0);
    assert_true(exists(tu_temp_path("frame00.png")) && exists(tu_temp_path("frame02.png")));
    /* bad usage and bad steps: exit 2, no file */
    snprintf(args, sizeof args, "render '%s' -o '%s' --all-steps --time-step 1", scene, tu_temp_path("x.png"));
    assert_int_equal(tu_run_cli(args, &err), 2);
    snprintf(args, sizeof args, "render '%s' -o '%s' --time-step 3", scene, tu_temp_path("x.png"));
    assert_int_equal(tu_run_cli(args, &err), 2);
    if (!strstr(err, "render.time_step")) fail_msg("%s", err);
    snprintf(args, sizeof args, "render '%s' -o '%s' --all-steps", scene, tu_temp_path("x%s.png"));
    assert_int_equal(tu_run_cli(args, &err), 2);
    assert_false(exists(tu_temp_path("x.png")));
    snprintf(args, sizeof args, "render '%s' -o '%s' --all-steps", scene, tu_temp_path("x%d_%d.png"));
    assert_int_equal(tu_run_cli(args, &err), 2);
    if (!strstr(err, "holds one %d")) fail_msg("%s", err);
    snprintf(args, sizeof args, "render '%s' -o '%s'", scene, tu_temp_path("x%d.png"));
    assert_int_equal(tu_run_cli(args, &err), 2);
    if (!strstr(err, "needs --all-steps")) fail_msg("%s", err);
    /* frames whose headers disagree: exit 2 naming the file */
    const char *h0 = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n\n";
    const char *h1 = "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 4 4 4\nendian: little\nencoding: raw\n\n";
    unsigned char zeros[128] = {0};
    tu_write_parts("c0.nrrd", h0, zeros, 64);
    tu_write_parts("c1.nrrd", h1, zeros, 128);
    const char *bad = scene_with("{\"files\": [\"c0.nrrd\", \"c1.nrrd\"]}");
    snprintf(scene, sizeof scene, "%s", tu_write_file("cli_bad.json", bad, strlen(bad)));
    snprintf(args, sizeof args, "render '%s' -o '%s' --all-steps", scene, tu_temp_path("bad.png"));
    assert_int_equal(tu_run_cli(args, &err), 2);
    assert_non_null(strstr(err, "c1.nrrd"));
    assert_non_null(strstr(err, "type"));
    assert_false(exists(tu_temp_path("bad_0000.png")));
}

/* The step-number check both the pattern loader and numbered outputs use:
 * only %d, %Nd and %0Nd count, "%%" is literal, anything else is refused. */
static void test_pattern_conversions(void **state) {
    (void)state;
    assert_int_equal(volux_sequence_pattern_conversions("t.nhdr"), 0);
    assert_int_equal(volux_sequence_pattern_conversions("t%d.nhdr"), 1);
    assert_int_equal(volux_sequence_pattern_conversions("t%3d.nhdr"), 1);
    assert_int_equal(volux_sequence_pattern_conversions("out/t%03d_100%%.png"), 1);
    assert_int_equal(volux_sequence_pattern_conversions("a%d/b%04d.nrrd"), 2);
    assert_int_equal(volux_sequence_pattern_conversions("t%s.nhdr"), -1);
    assert_int_equal(volux_sequence_pattern_conversions("t%10d.nhdr"), -1); /* width over 9 */
    assert_int_equal(volux_sequence_pattern_conversions("t%ld.nhdr"), -1);
    assert_int_equal(volux_sequence_pattern_conversions("t%n.nhdr"), -1);
    assert_int_equal(volux_sequence_pattern_conversions("t%"), -1);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pattern_conversions),
        cmocka_unit_test(test_steps_load_once_while_cached),
        cmocka_unit_test(test_cache_stays_within_its_memory_bound),
        cmocka_unit_test(test_a_step_of_another_shape_is_a_format_error),
        cmocka_unit_test(test_scene_time_step_bumps_volume_only_when_it_changes),
        cmocka_unit_test(test_set_sequence_failure_keeps_the_callers_sequence),
        cmocka_unit_test(test_cloud_moves_smoothly_with_time),
        cmocka_unit_test(test_scene_json_reads_sequences),
        cmocka_unit_test(test_scene_json_rejects_bad_sequences),
        cmocka_unit_test(test_cli_renders_one_or_all_steps),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
