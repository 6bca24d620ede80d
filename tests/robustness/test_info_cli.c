/*
 * tests/robustness/test_info_cli.c — `volux info`: exit statuses and
 * messages (DESIGN §4: 0 on success, 2 + a message naming the file for bad
 * input or usage).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include "tu_volume.h"

static void test_info_reads_volumes_and_procedurals(void **state) {
    (void)state;
    unsigned char data[24] = {0};
    const char *path = tu_write_parts("ok.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 3 2\nencoding: raw\n\n",
                                      data, sizeof data);
    char args[1024];
    const char *err;
    snprintf(args, sizeof args, "info '%s'", path);
    assert_int_equal(tu_run_cli(args, &err), 0);
    assert_int_equal(tu_run_cli("info procedural:sphere:16", &err), 0);
    assert_int_equal(tu_run_cli("info procedural:cloud:8 --seed 3 --bins 4", &err), 0);
    path = tu_write_file("ok.bin", data, sizeof data);
    snprintf(args, sizeof args, "info '%s' --raw-dims 3 2 2 --raw-type uint16 --raw-endian big --raw-spacing 1 2 3",
             path);
    assert_int_equal(tu_run_cli(args, &err), 0);
}

static void test_info_bad_input_exits_2_naming_the_file(void **state) {
    (void)state;
    const char *err;
    char args[1024];
    const char *path = tu_write_parts("bad.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 3\nencoding: raw\n\n",
                                      "", 0);
    snprintf(args, sizeof args, "info '%s'", path);
    assert_int_equal(tu_run_cli(args, &err), 2);
    assert_non_null(strstr(err, "bad.nrrd"));
    assert_non_null(strstr(err, "sizes"));

    assert_int_equal(tu_run_cli("info /nonexistent/vol.nhdr", &err), 2);
    assert_non_null(strstr(err, "/nonexistent/vol.nhdr"));
    assert_int_equal(tu_run_cli("info procedural:teapot", &err), 2);
    assert_non_null(strstr(err, "teapot"));
    assert_int_equal(tu_run_cli("info procedural:sphere:0", &err), 2);
    assert_int_equal(tu_run_cli("info", &err), 2);
    assert_int_equal(tu_run_cli("info a.nrrd --frobnicate", &err), 2);
    assert_int_equal(tu_run_cli("info x.raw --raw-dims 2 2 2", &err), 2);
    assert_non_null(strstr(err, "--raw-type"));
    assert_int_equal(tu_run_cli("info x.raw --raw-dims 2 2 2 --raw-type int32", &err), 2);
}

/* Runs `volux ARGS` inside the temp folder; returns the exit status. */
static int run_in_temp(const char *args) {
    char dir[512], cmd[2048];
    snprintf(dir, sizeof dir, "%s", tu_temp_path(""));
    snprintf(cmd, sizeof cmd, "cd '%s' && '%s' %s >/dev/null 2>&1", dir, VOLUX_CLI, args);
    int rc = system(cmd);
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

/* "--" ends the options in every subcommand (issue 16): a file whose name
 * starts with '-' is an operand after it, and an option after it is not. */
static void test_double_dash_ends_options(void **state) {
    (void)state;
    unsigned char data[8] = {0};
    tu_write_parts("-dash.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", data, 8);
    assert_int_equal(run_in_temp("info -dash.nrrd"), 2);
    assert_int_equal(run_in_temp("info -- -dash.nrrd"), 0);
    assert_int_equal(run_in_temp("info --bins 4 -- -dash.nrrd"), 0);
    assert_int_equal(run_in_temp("info -- --bins"), 2); /* a file named --bins: missing */
    const char *scene = "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 8, 8]},"
                        " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.5]]},"
                        " \"render\": {\"technique\": \"ea\", \"width\": 8, \"height\": 8}}";
    tu_write_file("-scene.json", scene, strlen(scene));
    assert_int_equal(run_in_temp("render -scene.json -o dd.pfm"), 2);
    assert_int_equal(run_in_temp("render -o dd.pfm --quiet -- -scene.json"), 0);
    assert_int_equal(run_in_temp("render -o -dd.pfm --quiet -- -scene.json"), 0);
    assert_int_equal(run_in_temp("compare -- -dd.pfm dd.pfm"), 0);
    assert_int_equal(run_in_temp("bench --repeat 1 -- -scene.json"), 0);
    /* NaN data: refused, or mapped with a warning on request */
    float f[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    f[3] = f[3] / 0.0f - f[3] / 0.0f; /* NaN without <math.h> */
    tu_write_parts("nan.nrrd", "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nendian: little\nencoding: raw\n\n", f,
                   sizeof f);
    assert_int_equal(run_in_temp("info nan.nrrd"), 2);
    assert_int_equal(run_in_temp("info --allow-nonfinite nan.nrrd"), 0);
}

/* Untrusted text never reaches the terminal raw (issue 16): a file name
 * holding an escape sequence and an invalid byte, in the CLI's own
 * message (an unknown option) and in a library message (a missing file),
 * comes out as \xHH. */
static void test_messages_are_escaped(void **state) {
    (void)state;
    const char *err;
    assert_int_equal(tu_run_cli("info \"$(printf 'evil\\033[2J\\377.nrrd')\"", &err), 2);
    assert_null(strchr(err, 0x1b));
    assert_null(strchr(err, (char)0xff));
    assert_non_null(strstr(err, "evil\\x1b[2J\\xff.nrrd"));
    assert_int_equal(tu_run_cli("info a.nrrd \"$(printf -- '--x\\033]0;t\\007')\"", &err), 2);
    assert_null(strchr(err, 0x1b));
    assert_null(strchr(err, 0x07));
    assert_non_null(strstr(err, "--x\\x1b]0;t\\x07"));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_info_reads_volumes_and_procedurals),
        cmocka_unit_test(test_info_bad_input_exits_2_naming_the_file),
        cmocka_unit_test(test_double_dash_ends_options),
        cmocka_unit_test(test_messages_are_escaped),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
