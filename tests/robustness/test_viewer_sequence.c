/*
 * tests/robustness/test_viewer_sequence.c — `volux serve` on a time-varying
 * volume (the animated procedural cloud): /api/state reports the sequence
 * (the page shows its step slider then), an edit of render.time_step moves
 * the live scene to that step through the scene document (the sequence is
 * kept), the final frame changes and equals `volux render --time-step N` of
 * the original scene and `volux render` of the saved scene bit for bit, and
 * a step out of range is refused with the CLI's message and the scene
 * unchanged.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "http_client.h"
#include "test_util.h"

#define assert_contains(hay, needle)                                                                   \
    do {                                                                                               \
        const char *h_ = (hay), *n_ = (needle);                                                        \
        if (!h_ || !strstr(h_, n_)) fail_msg("expected \"%s\" in \"%s\"", n_, h_ ? h_ : "(null)");     \
    } while (0)

/* Five steps of the drifting cloud; ea keeps the frames cheap. */
static const char *SCENE =
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [32, 32, 32], \"steps\": 5, \"time_per_step\": 0.2},\n"
    " \"transfer_function\": {\"color\": [[0, 0.6, 0.7, 1], [255, 1, 1, 1]],\n"
    "                       \"opacity\": [[0, 0], [40, 0.05], [255, 0.9]]},\n"
    " \"camera\": {\"orbit\": {\"azimuth\": 20, \"elevation\": 15}},\n"
    " \"render\": {\"technique\": \"ea\", \"width\": 64, \"height\": 48, \"spp\": 1}}\n";

static char scene_path[1024];
static tu_server server;

static int setup(void **state) {
    (void)state;
    return tu_server_start_scene(&server, "viewer_seq", SCENE, scene_path, sizeof scene_path) ? 0 : -1;
}

static int teardown(void **state) {
    (void)state;
    int rc = tu_server_stop(&server);
    if (rc != 0) fprintf(stderr, "volux serve exited with %d\n", rc);
    return rc == 0 ? 0 : -1;
}

static tu_reply get(const char *path) {
    tu_reply r;
    assert_true(tu_http(server.port, "GET", path, NULL, NULL, &r));
    return r;
}

static tu_reply post(const char *body) {
    tu_reply r;
    assert_true(tu_http(server.port, "POST", "/api/edit", NULL, body, &r));
    return r;
}

/* The state's "sequence" must say steps 5 and this step. */
static void expect_step(int step) {
    tu_reply r = get("/api/state");
    assert_int_equal(r.status, 200);
    char want[64];
    snprintf(want, sizeof want, "\"sequence\":{\"steps\":5,\"step\":%d}", step);
    assert_contains(r.body, want);
    tu_reply_free(&r);
}

/* The final frame of the current scene version, loaded. */
static void final_frame(volux_context *ctx, const char *name, volux_image *out) {
    tu_reply r = get("/api/frame?wait=final&format=png&timeout=60000");
    assert_int_equal(r.status, 200);
    assert_string_equal(tu_reply_header(&r, "X-Volux-Kind"), "final");
    char file[1100];
    snprintf(file, sizeof file, "%s", tu_temp_path(name));
    FILE *f = fopen(file, "wb");
    assert_non_null(f);
    fwrite(r.body, 1, r.body_len, f);
    fclose(f);
    tu_reply_free(&r);
    assert_int_equal(volux_image_load(ctx, file, out), VOLUX_OK);
}

/* `volux render ARGS -o FILE`, loaded. */
static void cli_render(volux_context *ctx, const char *args, const char *name, volux_image *out) {
    char file[1100], cmd[3000];
    snprintf(file, sizeof file, "%s", tu_temp_path(name));
    snprintf(cmd, sizeof cmd, "render %s -o '%s' --quiet", args, file);
    const char *err;
    if (tu_run_cli(cmd, &err) != 0) fail_msg("volux %s: %s", cmd, err);
    assert_int_equal(volux_image_load(ctx, file, out), VOLUX_OK);
}

static void test_time_step_slider(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    expect_step(0);
    volux_image step0, step3, cli, saved_img;
    final_frame(ctx, "viewer_seq_0.png", &step0);

    /* What the page's slider sends. */
    tu_reply r = post("[{\"path\": \"render.time_step\", \"value\": 3}]");
    assert_int_equal(r.status, 200);
    assert_contains(r.body, "\"changed\":[\"volume\"]");
    tu_reply_free(&r);
    expect_step(3);
    final_frame(ctx, "viewer_seq_3.png", &step3);
    assert_true(tu_max_abs_diff(&step0, &step3) > 0.01); /* the cloud drifted */

    /* = volux render --time-step 3 of the original scene */
    char args[1400];
    snprintf(args, sizeof args, "'%s' --time-step 3", scene_path);
    cli_render(ctx, args, "viewer_seq_cli3.png", &cli);
    assert_near(tu_max_abs_diff(&step3, &cli), 0, 0);
    volux_image_free(ctx, &cli);
    /* and step 0 of the CLI is the first frame */
    snprintf(args, sizeof args, "'%s'", scene_path);
    cli_render(ctx, args, "viewer_seq_cli0.png", &cli);
    assert_near(tu_max_abs_diff(&step0, &cli), 0, 0);
    volux_image_free(ctx, &cli);

    /* The saved scene keeps the step and renders the same image. */
    r = get("/api/scene");
    assert_int_equal(r.status, 200);
    assert_contains(r.body, "\"time_step\":3");
    tu_reply_free(&r);
    r = get("/api/scene?paths=absolute");
    assert_int_equal(r.status, 200);
    char saved[1100];
    snprintf(saved, sizeof saved, "%s", tu_temp_path("viewer_seq_saved.json"));
    FILE *f = fopen(saved, "w");
    assert_non_null(f);
    fwrite(r.body, 1, r.body_len, f);
    fclose(f);
    tu_reply_free(&r);
    snprintf(args, sizeof args, "'%s'", saved);
    cli_render(ctx, args, "viewer_seq_saved.png", &saved_img);
    assert_near(tu_max_abs_diff(&step3, &saved_img), 0, 0);

    /* Out of range: 400, the CLI's message, the step unchanged. */
    r = post("[{\"path\": \"render.time_step\", \"value\": 5}]");
    assert_int_equal(r.status, 400);
    assert_contains(r.body, "time step 5 is outside [0, 5)");
    snprintf(args, sizeof args, "render '%s' -o /dev/null.png --set render.time_step=5", scene_path);
    const char *err;
    assert_int_equal(tu_run_cli(args, &err), 2);
    const char *msg = strstr(err, "volux render: ");
    assert_non_null(msg);
    char want[1200];
    snprintf(want, sizeof want, "\"error\":\"%.*s\"", (int)strcspn(msg + 14, "\n"), msg + 14);
    assert_contains(r.body, want);
    tu_reply_free(&r);
    expect_step(3);

    /* A TF edit at step 3 keeps the step. */
    r = post("[{\"path\": \"transfer_function.opacity.2.1\", \"value\": 0.5}]");
    assert_int_equal(r.status, 200);
    tu_reply_free(&r);
    expect_step(3);
    assert_true(tu_server_alive(&server));
    volux_image_free(ctx, &step0);
    volux_image_free(ctx, &step3);
    volux_image_free(ctx, &saved_img);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_time_step_slider),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
