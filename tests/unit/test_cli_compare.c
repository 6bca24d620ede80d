/* tests/unit/test_cli_compare.c — `volux compare`: output forms, exit
 * statuses, the --diff false-colour image. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "image_fixtures.h"
#include "test_util.h"

/* Runs the CLI; stdout goes to *out (static buffer). Returns the exit status. */
static int run(const char *args, const char **out) {
    static char buf[8192];
    const char *path = tu_temp_path("cli.out");
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "%s %s >%s 2>/dev/null", VOLUX_CLI, args, path);
    int rc = system(cmd);
    FILE *f = fopen(path, "rb");
    size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
    if (f) fclose(f);
    buf[n] = 0;
    *out = buf;
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

static const char *save_pattern(const char *name, int w, int h, float offset_at_00) {
    volux_context *ctx = tu_context(1);
    volux_image img;
    fx_pattern(ctx, w, h, &img);
    img.rgb[0] += offset_at_00;
    const char *path = tu_temp_path(name);
    assert_int_equal(volux_image_save(ctx, path, &img, 0.0f), VOLUX_OK);
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
    return path;
}

static void test_identical_images_give_zero_error_and_infinite_psnr(void **state) {
    (void)state;
    const char *a = save_pattern("same.pfm", 8, 6, 0.0f);
    char args[1024];
    const char *out;
    snprintf(args, sizeof args, "compare %s %s --json", a, a);
    assert_int_equal(run(args, &out), 0);
    assert_string_equal(out, "{\"rmse\":0,\"rel_mse\":0,\"psnr\":\"Infinity\",\"max_abs\":0}\n");
    snprintf(args, sizeof args, "compare %s %s", a, a);
    assert_int_equal(run(args, &out), 0);
    assert_string_equal(out, "rmse 0\nrel_mse 0\npsnr inf\nmax_abs 0\n");
}

static void test_metrics_and_diff_image(void **state) {
    (void)state;
    const char *a = save_pattern("a.exr", 8, 6, 3.0f); /* one channel of one pixel off by 3 */
    const char *b = save_pattern("b.exr", 8, 6, 0.0f);
    const char *diff = tu_temp_path("diff.png");
    char args[1024];
    const char *out;
    snprintf(args, sizeof args, "compare %s %s --json --diff %s", a, b, diff);
    assert_int_equal(run(args, &out), 0);
    double rmse = sqrt(9.0 / (8 * 6 * 3));
    char expect[256];
    snprintf(expect, sizeof expect, "{\"rmse\":%.9g,", rmse);
    assert_non_null(strstr(out, expect));
    assert_non_null(strstr(out, "\"max_abs\":3}"));
    /* The diff: the changed pixel is the top of the ramp (yellow), the
     * others its bottom (dark violet). */
    volux_context *ctx = tu_context(1);
    volux_image d;
    assert_int_equal(volux_image_load(ctx, diff, &d), VOLUX_OK);
    assert_int_equal(d.width, 8);
    assert_near(volux_srgb_encode(d.rgb[0]), 0.993, 0.003);
    assert_near(volux_srgb_encode(d.rgb[2]), 0.144, 0.003);
    assert_near(volux_srgb_encode(d.rgb[3]), 0.267, 0.003);
    assert_near(volux_srgb_encode(d.rgb[5]), 0.329, 0.003);
    volux_image_free(ctx, &d);
    /* --scale 6: a difference of 3 sits in the middle of the ramp. */
    snprintf(args, sizeof args, "compare %s %s --diff %s --scale 6", a, b, diff);
    assert_int_equal(run(args, &out), 0);
    assert_int_equal(volux_image_load(ctx, diff, &d), VOLUX_OK);
    assert_near(volux_srgb_encode(d.rgb[1]), 0.567, 0.003);
    volux_image_free(ctx, &d);
    volux_context_destroy(ctx);
}

static void test_bad_input_exits_2_and_runtime_failure_exits_1(void **state) {
    (void)state;
    const char *a = save_pattern("small.pfm", 4, 4, 0.0f);
    const char *b = save_pattern("big.pfm", 5, 4, 0.0f);
    char args[1024];
    const char *err;
    snprintf(args, sizeof args, "compare %s %s", a, b);
    assert_int_equal(tu_run_cli(args, &err), 2);
    assert_non_null(strstr(err, "4x4"));
    assert_non_null(strstr(err, "5x4"));
    snprintf(args, sizeof args, "compare %s %s", a, tu_temp_path("nope.pfm"));
    assert_int_equal(tu_run_cli(args, &err), 2);
    assert_non_null(strstr(err, "nope.pfm"));
    assert_int_equal(tu_run_cli("compare only-one.pfm", &err), 2);
    assert_int_equal(tu_run_cli("compare a.pfm b.pfm --bogus", &err), 2);
    snprintf(args, sizeof args, "compare %s %s --scale -1", a, a);
    assert_int_equal(tu_run_cli(args, &err), 2);
    /* An unwritable diff: a run-time failure, and no output file. */
    snprintf(args, sizeof args, "compare %s %s --diff /nonexistent-volux-dir/d.png", a, a);
    assert_int_equal(tu_run_cli(args, &err), 1);
    assert_non_null(strstr(err, "/nonexistent-volux-dir/d.png"));
    struct stat sb;
    assert_int_equal(stat("/nonexistent-volux-dir", &sb), -1);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_identical_images_give_zero_error_and_infinite_psnr),
        cmocka_unit_test(test_metrics_and_diff_image),
        cmocka_unit_test(test_bad_input_exits_2_and_runtime_failure_exits_1),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
