/*
 * `volux bench` prints a technique's own statistics (volux_technique_stats)
 * after creation and after each edit, and times progressive updates to
 * their end — generically: `ea` reports none of it, `manylights` reports
 * its VL count and AVSM build time, and an extinction edit (progressive)
 * gets refine metrics while a camera edit (immediate) does not.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_util.h"

static const char *scene =
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [16, 16, 16]},"
    " \"transfer_function\": {\"opacity\": [[0, 0], [60, 0.05], [255, 0.5]]},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.4, -1, -0.3]}],"
    " \"render\": {\"width\": 8, \"height\": 8, \"spp\": 1, \"max_depth\": 4},"
    " \"techniques\": {\"manylights\": {\"vl_count\": 20, \"avsm_resolution\": 2, \"avsm_nodes\": 2,"
    "                                 \"update_budget\": 5}}}";

/* Runs bench and returns its stdout (static buffer). */
static const char *bench(const char *technique) {
    static char out[65536];
    const char *path = tu_write_file("bench.json", scene, strlen(scene));
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "%s bench '%s' --technique %s --json --repeat 1 --edit tf --edit camera > '%s' 2>&1",
             VOLUX_CLI, path, technique, tu_temp_path("bench.out"));
    int rc = system(cmd);
    FILE *f = fopen(tu_temp_path("bench.out"), "rb");
    assert_non_null(f);
    size_t n = fread(out, 1, sizeof out - 1, f);
    out[n] = 0;
    fclose(f);
    if (rc != 0) fail_msg("volux bench failed: %s", out);
    return out;
}

/* The value of "metric" in the JSON lines, or -1 if absent. */
static double metric(const char *out, const char *name) {
    char key[128];
    snprintf(key, sizeof key, "\"metric\":\"%s\",\"value\":", name);
    const char *p = strstr(out, key);
    return p ? atof(p + strlen(key)) : -1.0;
}

static void test_bench_reports_technique_statistics(void **state) {
    (void)state;
    const char *out = bench("manylights");
    assert_true(metric(out, "vl_count") >= 20);
    assert_true(metric(out, "avsm_build_ms") >= 0.0);
    assert_true(metric(out, "avsm_built") >= 20);
    assert_true(metric(out, "update_ms.tf") >= 0.0);
    assert_true(metric(out, "refine_steps.tf") >= 4); /* 20+ VLs, 5 per frame */
    assert_true(metric(out, "refine_ms.tf") >= 0.0);
    assert_true(metric(out, "refine_step_ms.tf") >= 0.0);
    assert_true(metric(out, "avsm_built.tf") == 0.0);  /* rule 2: none at once */
    assert_true(metric(out, "avsm_built.camera") == 0.0);
    assert_true(metric(out, "refine_steps.camera") < 0.0);
    out = bench("ea");
    assert_true(metric(out, "update_ms.tf") >= 0.0);
    assert_true(metric(out, "vl_count") < 0.0);
    assert_true(metric(out, "refine_steps.tf") < 0.0);
}

int main(void) {
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_bench_reports_technique_statistics)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
