/*
 * tests/support/test_util.h — helpers shared by the cmocka suites.
 *
 * Include after <cmocka.h>'s prerequisites; this header pulls them in.
 */
#ifndef VOLUX_TEST_UTIL_H
#define VOLUX_TEST_UTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "volux/volux.h"

/* A context with `threads` threads whose cache folder is "cache" in the
 * per-process temp folder (tests never touch the user's cache); fails the
 * test on error. */
volux_context *tu_context(int threads);

/* Writes `size` bytes to a fresh file in a per-process temp folder and
 * returns its path (static storage, valid until the next call with the same
 * `name`). */
const char *tu_write_file(const char *name, const void *data, size_t size);
/* Path of a file in the temp folder (not created). */
const char *tu_temp_path(const char *name);

/* Runs the volux CLI with `args` (a shell-quoted string), capturing stderr
 * into *err (static buffer). Returns the exit status. */
int tu_run_cli(const char *args, const char **err);

/* What a context's message callback delivered: counts per level and the
 * last message's text. Install with
 * volux_context_set_message(ctx, tu_collect_messages, &messages). */
typedef struct tu_messages {
    int warnings;
    int notes;
    char last[512];
} tu_messages;
void tu_collect_messages(void *user, volux_message_level level, const char *text);

/* Asserts |a − b| ≤ tol with a readable message. */
#define assert_near(a, b, tol)                                                                         \
    do {                                                                                               \
        double tu_a_ = (double)(a), tu_b_ = (double)(b), tu_t_ = (double)(tol);                        \
        if (!(tu_a_ - tu_b_ <= tu_t_ && tu_b_ - tu_a_ <= tu_t_))                                       \
            fail_msg("%s = %.9g, expected %.9g ± %.3g", #a, tu_a_, tu_b_, tu_t_);                      \
    } while (0)

#endif

#ifndef VOLUX_TEST_UTIL_RENDER
#define VOLUX_TEST_UTIL_RENDER
/* Loads a scene from a JSON string (relative paths against the temp dir). */
volux_scene *tu_scene(volux_context *ctx, const char *json);
/* Renders the scene's spp with a fresh instance of `technique` (NULL: the
 * scene's) and returns the resolved image (caller frees). */
volux_image tu_render(volux_context *ctx, volux_scene *s, const char *technique);
/* Renders with an existing technique into a fresh framebuffer. */
volux_image tu_render_with(volux_context *ctx, volux_scene *s, volux_technique *t);
/* Largest |a − b| over all channels (asserts equal sizes). */
double tu_max_abs_diff(const volux_image *a, const volux_image *b);
/* Mean Rec. 709 luminance of an image. */
double tu_mean_luminance(const volux_image *img);
/* Pixel channel c at (x, y). */
float tu_pixel(const volux_image *img, int x, int y, int c);
#endif
