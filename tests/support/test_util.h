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

/* A context with `threads` threads; fails the test on error. */
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

/* Asserts |a − b| ≤ tol with a readable message. */
#define assert_near(a, b, tol)                                                                         \
    do {                                                                                               \
        double tu_a_ = (double)(a), tu_b_ = (double)(b), tu_t_ = (double)(tol);                        \
        if (!(tu_a_ - tu_b_ <= tu_t_ && tu_b_ - tu_a_ <= tu_t_))                                       \
            fail_msg("%s = %.9g, expected %.9g ± %.3g", #a, tu_a_, tu_b_, tu_t_);                      \
    } while (0)

#endif
