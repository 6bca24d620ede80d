/*
 * Issue 26: the arithmetic of the error-time plane (tools/cli/pareto_math.c)
 * on series whose answer is known in closed form, `volux render --time-ms`
 * counting the preparation (the render gets the budget minus what preparing
 * took, read back from the CLI's own report, not timed), and a small
 * `volux bench --pareto` run.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pareto_math.h"
#include "test_util.h"

/* A pure power law: t = 5·spp ms, e = 1/spp, no preparation. Then t = 5/e
 * exactly, which log-log interpolation reproduces between any two points. */
static void test_loglog_interpolation_is_exact_on_a_power_law(void **state) {
    (void)state;
    pareto_point s[4] = {{1, 5, 1.0}, {2, 10, 0.5}, {4, 20, 0.25}, {8, 40, 0.125}};
    int where = 7;
    assert_float_equal(pareto_time_to_error(s, 4, 0.0, 0.3, &where), 5.0 / 0.3, 1e-9);
    assert_int_equal(where, 0);
    assert_float_equal(pareto_time_to_error(s, 4, 0.0, 0.25, &where), 20.0, 1e-9);
    assert_float_equal(pareto_time_to_error(s, 4, 0.0, 0.2, &where), 25.0, 1e-9);
    /* S = T_pathtrace(e) / T_technique */
    assert_float_equal(pareto_speedup(s, 4, 0.0, 0.2, 5.0, &where), 5.0, 1e-9);
}

/* With preparation: t = 10 + 5·spp. Past the ends the error is taken as
 * e ∝ 1/spp and only the render part scales. */
static void test_extrapolation_past_both_ends(void **state) {
    (void)state;
    pareto_point s[4] = {{1, 15, 1.0}, {2, 20, 0.5}, {4, 30, 0.25}, {8, 50, 0.125}};
    int where = 0;
    /* above: 0.0625 = 1/16 → 16 spp → 10 + 80 */
    assert_float_equal(pareto_time_to_error(s, 4, 10.0, 0.0625, &where), 90.0, 1e-9);
    assert_int_equal(where, 1);
    /* below: e = 2 → half a sample → 10 + 2.5 */
    assert_float_equal(pareto_time_to_error(s, 4, 10.0, 2.0, &where), 12.5, 1e-9);
    assert_int_equal(where, -1);
    assert_float_equal(pareto_speedup(s, 4, 10.0, 0.0625, 9.0, &where), 10.0, 1e-9);
    /* at a point of the series: its time */
    assert_float_equal(pareto_time_to_error(s, 4, 10.0, 1.0, &where), 15.0, 1e-9);
    assert_int_equal(where, 0);
}

/* A noisy series (not monotone): the first point at or below e counts. */
static void test_first_crossing_counts(void **state) {
    (void)state;
    pareto_point s[4] = {{1, 10, 1.0}, {2, 20, 0.4}, {4, 40, 0.5}, {8, 80, 0.1}};
    /* between (10 ms, 1.0) and (20 ms, 0.4), not past the 0.5 at 4 spp */
    assert_float_equal(pareto_time_to_error(s, 4, 0.0, 0.45, NULL), 10.0 * pow(2.0, log(0.45) / log(0.4)), 1e-9);
    assert_true(pareto_time_to_error(s, 4, 0.0, 0.45, NULL) <= 20.0);
}

static void test_undefined_inputs(void **state) {
    (void)state;
    pareto_point s[1] = {{1, 10, 1.0}};
    assert_true(pareto_time_to_error(NULL, 0, 0.0, 0.5, NULL) < 0.0);
    assert_true(pareto_time_to_error(s, 1, 0.0, 0.0, NULL) < 0.0);
    assert_true(pareto_time_to_error(s, 1, 0.0, NAN, NULL) < 0.0);
    assert_true(pareto_speedup(s, 1, 0.0, 0.5, 0.0, NULL) < 0.0);
}

static void test_remaining_budget(void **state) {
    (void)state;
    int one = -1;
    assert_float_equal(pareto_remaining_budget(0.0, 500.0, &one), 0.0, 0.0); /* no budget */
    assert_int_equal(one, 0);
    assert_float_equal(pareto_remaining_budget(1000.0, 300.0, &one), 700.0, 1e-12);
    assert_int_equal(one, 0);
    assert_float_equal(pareto_remaining_budget(1000.0, 1000.0, &one), 0.0, 0.0);
    assert_int_equal(one, 1); /* spent: one complete pass, no limit inside it */
    pareto_remaining_budget(1000.0, 2500.0, &one);
    assert_int_equal(one, 1);
}

static const char *scene_json =
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [24, 24, 24]},"
    " \"transfer_function\": {\"opacity\": [[0, 0], [60, 0.05], [255, 0.5]], \"albedo\": 0.9},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.4, -1, -0.3]}],"
    " \"render\": {\"width\": 8, \"height\": 8, \"spp\": 8, \"max_depth\": 8}}";

/* A number after `key` in text, or −1. */
static double after(const char *text, const char *key) {
    const char *p = strstr(text, key);
    return p ? atof(p + strlen(key)) : -1.0;
}

/* The render is handed the budget minus the preparation: the CLI's report
 * of both adds up to the budget (to its rounding). Before issue 26 the
 * render got the whole budget (and the report had no "left"). */
static void test_render_budget_counts_preparation(void **state) {
    (void)state;
    const char *path = tu_write_file("budget.json", scene_json, strlen(scene_json));
    char args[4096];
    const char *err = NULL;
    snprintf(args, sizeof args, "render '%s' --technique lightvol --time-ms 100000 -o '%s'", path,
             tu_temp_path("budget.pfm"));
    assert_int_equal(tu_run_cli(args, &err), 0);
    double prepare = after(err, "prepare "), left = after(err, "budget 100000 ms: ");
    if (prepare < 0.0 || left < 0.0) fail_msg("no prepare/budget report: %s", err);
    assert_true(prepare > 0.0);
    assert_float_equal(prepare + left, 100000.0, 0.11);

    /* A budget the preparation spends: one complete pass (not a first pass
     * cut short, which would be darker), with a note. */
    snprintf(args, sizeof args, "render '%s' --technique pathtrace --time-ms 0.000001 -o '%s'", path,
             tu_temp_path("budget1.pfm"));
    assert_int_equal(tu_run_cli(args, &err), 0);
    if (!strstr(err, "rendering one pass") || !strstr(err, ", 1 spp")) fail_msg("expected one pass: %s", err);
    assert_null(strstr(err, "cut short"));
}

/* `volux bench --pareto` on a tiny scene: every metric of the contract,
 * pathtrace's series converging towards its reference, and each technique's
 * speed-up reported. */
static void test_bench_pareto_runs(void **state) {
    (void)state;
    const char *path = tu_write_file("pareto.json", scene_json, strlen(scene_json));
    char cmd[4096];
    snprintf(cmd, sizeof cmd,
             "%s bench '%s' --pareto --json --techniques ea,single --ref-spp 256 --series-spp 8 > '%s' 2>/dev/null",
             VOLUX_CLI, path, tu_temp_path("pareto.out"));
    assert_int_equal(system(cmd), 0);
    static char out[65536];
    FILE *f = fopen(tu_temp_path("pareto.out"), "rb");
    assert_non_null(f);
    size_t n = fread(out, 1, sizeof out - 1, f);
    out[n] = 0;
    fclose(f);
    /* the full-depth series: spp 1 … 8, error falling with spp */
    double e1 = after(out, "\"metric\":\"pareto_series\",\"value\":");
    const char *p8 = strstr(out, "\"max_depth\":8,\"spp\":8,");
    assert_non_null(p8);
    const char *line = p8;
    while (line > out && line[-1] != '\n') line--;
    double e8 = after(line, "\"value\":");
    assert_true(e1 > 0.0 && e8 > 0.0);
    assert_true(e8 < 0.5 * e1);
    for (const char *t = "ea\0single\0"; *t; t += strlen(t) + 1) {
        char key[128];
        snprintf(key, sizeof key, "\"technique\":\"%s\",\"metric\":\"pareto_speedup\",\"value\":", t);
        if (after(out, key) <= 0.0) fail_msg("no pareto_speedup for %s:\n%s", t, out);
        snprintf(key, sizeof key, "\"technique\":\"%s\",\"metric\":\"rel_mse_full\",\"value\":", t);
        assert_true(after(out, key) > 0.0);
    }
    assert_non_null(strstr(out, "\"threads\":"));
    assert_non_null(strstr(out, "\"width\":8,\"height\":8"));
}

static void test_bench_pareto_rejects_bad_technique(void **state) {
    (void)state;
    const char *path = tu_write_file("pareto_bad.json", scene_json, strlen(scene_json));
    char args[4096];
    const char *err = NULL;
    snprintf(args, sizeof args, "bench '%s' --pareto --techniques single,nope", path);
    assert_int_equal(tu_run_cli(args, &err), 2);
    assert_non_null(strstr(err, "'nope'"));
}

/* The rule on a table of its own: more budget never means a larger
 * expected error, a choice that fits is predicted within the budget, and
 * nothing fitting gives the fastest row. */
static void test_auto_rule(void **state) {
    (void)state;
    const pareto_auto_row rows[] = {
        {"pathtrace", 1.0, 1000.0, 0.1, 1}, /* 1 ms/Mvoxel, 1 s per Mpixel and pass */
        {"cheap", 5.0, 100.0, 0.05, 0},
        {"slow", 100.0, 500.0, 0.002, 0},
    };
    pareto_auto_choice c;
    assert_int_equal(pareto_auto_choose(rows, 3, 0.0, 1e6, 1e6, 64, &c), 0); /* no budget */
    /* 1 Mvoxel, 1 Mpixel: cheap = 105 ms, slow = 600 ms, pathtrace = 1 + 1000·spp */
    assert_int_equal(pareto_auto_choose(rows, 3, 50.0, 1e6, 1e6, 64, &c), 1);
    assert_string_equal(c.technique, "cheap"); /* nothing fits: the fastest */
    assert_int_equal(c.fits, 0);
    pareto_auto_choose(rows, 3, 200.0, 1e6, 1e6, 64, &c);
    assert_string_equal(c.technique, "cheap");
    assert_int_equal(c.fits, 1);
    pareto_auto_choose(rows, 3, 700.0, 1e6, 1e6, 64, &c);
    assert_string_equal(c.technique, "slow");
    /* 0.1/spp < 0.002 from 51 spp on: 51 passes = 51 001 ms */
    pareto_auto_choose(rows, 3, 51001.0, 1e6, 1e6, 64, &c);
    assert_string_equal(c.technique, "pathtrace");
    assert_int_equal(c.spp, 51);
    assert_true(c.predicted_ms <= 51001.0);
    pareto_auto_choose(rows, 3, 1e9, 1e6, 1e6, 64, &c);
    assert_int_equal(c.spp, 64); /* capped */
    double last = INFINITY;
    for (double b = 10.0; b < 1e8; b *= 1.7) {
        pareto_auto_choose(rows, 3, b, 1e6, 1e6, 1 << 20, &c);
        if (c.fits) assert_true(c.predicted_ms <= b);
        assert_true(c.expected_error <= last);
        last = c.expected_error;
    }
}

/* `--technique auto` on the shipped scenes that need no data (scenes/
 * demo.json, cloud_animation.json) with the measured table: the choice is
 * a note; as the budget grows its expected error never rises and its
 * predicted time stays within the budget; a huge budget gets pathtrace;
 * no budget is a usage error naming render.time_ms. */
static void test_auto_on_shipped_scenes(void **state) {
    (void)state;
    const char *scenes[] = {"demo.json", "cloud_animation.json"};
    for (int k = 0; k < 2; k++) {
        char args[4096];
        const char *err = NULL;
        double last = INFINITY;
        const char *dump = tu_temp_path("auto_dump.json");
        for (double b = 1.0; b <= 1e8; b *= 100.0) {
            snprintf(args, sizeof args, "render '%s/scenes/%s' --technique auto --time-ms %g --dump-scene '%s'",
                     VOLUX_SOURCE_DIR, scenes[k], b, dump);
            assert_int_equal(tu_run_cli(args, &err), 0);
            const char *note = strstr(err, "auto: chose ");
            if (!note) fail_msg("no auto note: %s", err);
            double predicted = after(note, "(predicted "), e = after(note, "expected rel_mse ");
            assert_true(predicted > 0.0 && e > 0.0);
            if (!strstr(note, "nothing fits")) assert_true(predicted <= b);
            assert_true(e <= last * (1.0 + 1e-9));
            last = e;
            if (b == 1e8) assert_non_null(strstr(note, "auto: chose pathtrace"));
        }
        snprintf(args, sizeof args, "render '%s/scenes/%s' --technique auto -o '%s'", VOLUX_SOURCE_DIR, scenes[k],
                 tu_temp_path("auto.png"));
        assert_int_equal(tu_run_cli(args, &err), 2);
        assert_non_null(strstr(err, "render.time_ms"));
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_loglog_interpolation_is_exact_on_a_power_law),
        cmocka_unit_test(test_extrapolation_past_both_ends),
        cmocka_unit_test(test_first_crossing_counts),
        cmocka_unit_test(test_undefined_inputs),
        cmocka_unit_test(test_remaining_budget),
        cmocka_unit_test(test_render_budget_counts_preparation),
        cmocka_unit_test(test_bench_pareto_runs),
        cmocka_unit_test(test_bench_pareto_rejects_bad_technique),
        cmocka_unit_test(test_auto_rule),
        cmocka_unit_test(test_auto_on_shipped_scenes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
