/* tools/cli/common.c — exit codes, context with progress bar, option parsing. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"

int cli_exit_status(volux_status st) {
    if (st == VOLUX_OK) return CLI_OK;
    return volux_status_is_input_error(st) ? CLI_USAGE : CLI_FAIL;
}

int cli_fail(const char *cmd, volux_context *ctx, volux_status st) {
    const char *msg = ctx ? volux_context_error(ctx) : "";
    fprintf(stderr, "volux %s: %s\n", cmd, msg && *msg ? msg : volux_status_name(st));
    return cli_exit_status(st);
}

/* Progress on stderr. On a terminal: a one-line bar with the time left,
 * redrawn at most every 1/40 of the way (or on task change), cleared when
 * the task finishes. Elsewhere (a log): one line per 10 % for tasks that
 * have run for more than 5 s, so short renders stay quiet. */
typedef struct progress_state {
    char task[64];
    int last_step;
    int tty;
    double start_ms;
} progress_state;

static void format_left(double ms, char *buf, size_t size) {
    long s = (long)(ms * 1e-3 + 0.5);
    if (s >= 3600) snprintf(buf, size, "%ld:%02ld:%02ld left", s / 3600, s / 60 % 60, s % 60);
    else snprintf(buf, size, "%ld:%02ld left", s / 60, s % 60);
}

static int progress_bar(void *user, const char *task, double fraction) {
    progress_state *p = user;
    int steps = p->tty ? 40 : 10, step = (int)(fraction * steps);
    int new_task = strcmp(p->task, task) != 0;
    if (step == p->last_step && !new_task) return 0;
    if (new_task) p->start_ms = cli_now_ms();
    p->last_step = step;
    snprintf(p->task, sizeof p->task, "%s", task);
    double elapsed = cli_now_ms() - p->start_ms;
    char left[32] = "";
    if (fraction > 0.02 && fraction < 1.0 && elapsed > 1000.0)
        format_left(elapsed * (1.0 - fraction) / fraction, left, sizeof left);
    if (!p->tty) {
        if (elapsed > 5000.0 && fraction < 1.0)
            fprintf(stderr, "volux: %s: %d%% %s\n", task, (int)(fraction * 100.0), left);
        return 0;
    }
    if (fraction >= 1.0) {
        fprintf(stderr, "\r\033[K");
        return 0;
    }
    char bar[41];
    for (int i = 0; i < 40; i++) bar[i] = i < step ? '#' : '.';
    bar[40] = 0;
    fprintf(stderr, "\r%-20.20s [%s] %3d%% %s\033[K", task, bar, (int)(fraction * 100.0), left);
    fflush(stderr);
    return 0;
}

static progress_state bar_state = {"", -1, 0, 0.0};

void cli_progress(const char *task, double fraction) {
    if (isatty(STDERR_FILENO)) {
        bar_state.tty = 1;
        progress_bar(&bar_state, task, fraction);
    }
}

/* Warnings and notes from the library, one line each on stderr (a progress
 * bar in the way is cleared first). */
static void print_message(void *user, volux_message_level level, const char *text) {
    progress_state *p = user;
    if (p->tty && p->last_step >= 0) fprintf(stderr, "\r\033[K");
    fprintf(stderr, "volux: %s: %s\n", level == VOLUX_MESSAGE_WARNING ? "warning" : "note", text);
    p->last_step = -1; /* redraw the bar */
}

volux_context *cli_context(int threads) {
    progress_state *state = &bar_state;
    volux_context_desc d = {0};
    d.threads = threads;
    state->tty = isatty(STDERR_FILENO);
    d.progress = progress_bar;
    d.progress_user = state;
    d.message = print_message;
    d.message_user = state;
    volux_context *ctx = NULL;
    if (volux_context_create(&d, &ctx) != VOLUX_OK) {
        fprintf(stderr, "volux: out of memory\n");
        return NULL;
    }
    return ctx;
}

int cli_parse_int(const char *cmd, const char *opt, const char *s, long lo, long hi, long *out) {
    char *end;
    errno = 0;
    long v = s ? strtol(s, &end, 10) : 0;
    if (!s || errno || end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "volux %s: %s: expected an integer in [%ld, %ld], got '%s'\n", cmd, opt, lo, hi,
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
        fprintf(stderr, "volux %s: %s: expected a number, got '%s'\n", cmd, opt, s ? s : "(missing)");
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
