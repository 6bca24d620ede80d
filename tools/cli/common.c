/* tools/cli/common.c — exit codes, context with progress bar, option parsing. */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"

void cli_eprintf(const char *fmt, ...) {
    char msg[8192], safe[8192];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    volux_escape_text(msg, safe, sizeof safe);
    fputs(safe, stderr);
}

int cli_exit_status(volux_status st) {
    if (st == VOLUX_OK) return CLI_OK;
    return volux_status_is_input_error(st) ? CLI_USAGE : CLI_FAIL;
}

int cli_fail(const char *cmd, volux_context *ctx, volux_status st) {
    const char *msg = ctx ? volux_context_error(ctx) : "";
    cli_eprintf("volux %s: %s\n", cmd, msg && *msg ? msg : volux_status_name(st));
    return cli_exit_status(st);
}

/* A one-line progress bar on stderr, redrawn at most every 1/10 of the way
 * (or on task change); cleared when the task finishes. */
typedef struct progress_state {
    char task[64];
    int last_tenth;
} progress_state;

static int progress_bar(void *user, const char *task, double fraction) {
    progress_state *p = user;
    int tenth = (int)(fraction * 40.0);
    if (tenth == p->last_tenth && !strcmp(p->task, task)) return 0;
    p->last_tenth = tenth;
    snprintf(p->task, sizeof p->task, "%s", task);
    if (fraction >= 1.0) {
        fprintf(stderr, "\r\033[K");
        return 0;
    }
    char bar[41];
    for (int i = 0; i < 40; i++) bar[i] = i < tenth ? '#' : '.';
    bar[40] = 0;
    fprintf(stderr, "\r%-20.20s [%s] %3d%%", task, bar, (int)(fraction * 100.0));
    fflush(stderr);
    return 0;
}

/* Library warnings (trailing bytes ignored, non-finite values mapped, a
 * render cut short) go to stderr; the library escapes them. */
static void print_warning(void *user, const char *message) {
    (void)user;
    cli_eprintf("volux: warning: %s\n", message);
}

static progress_state bar_state = {"", -1};

void cli_progress(const char *task, double fraction) {
    if (isatty(STDERR_FILENO)) progress_bar(&bar_state, task, fraction);
}

volux_context *cli_context(int threads) {
    progress_state *state = &bar_state;
    volux_context_desc d = {0};
    d.threads = threads;
    if (isatty(STDERR_FILENO)) {
        d.progress = progress_bar;
        d.progress_user = state;
    }
    volux_context *ctx = NULL;
    if (volux_context_create(&d, &ctx) != VOLUX_OK) {
        cli_eprintf("volux: out of memory\n");
        return NULL;
    }
    volux_context_set_warning(ctx, print_warning, NULL);
    return ctx;
}

int cli_parse_int(const char *cmd, const char *opt, const char *s, long lo, long hi, long *out) {
    char *end;
    errno = 0;
    long v = s ? strtol(s, &end, 10) : 0;
    if (!s || errno || end == s || *end || v < lo || v > hi) {
        cli_eprintf("volux %s: %s: expected an integer in [%ld, %ld], got '%s'\n", cmd, opt, lo, hi,
                s ? s : "(missing)");
        return 0;
    }
    *out = v;
    return 1;
}

int cli_parse_double(const char *cmd, const char *opt, const char *s, double *out) {
    char *end;
    errno = 0;
    double v = s ? strtod(s, &end) : 0;
    if (!s || errno || end == s || *end) {
        cli_eprintf("volux %s: %s: expected a number, got '%s'\n", cmd, opt, s ? s : "(missing)");
        return 0;
    }
    *out = v;
    return 1;
}

double cli_now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}
