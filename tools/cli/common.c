/* tools/cli/common.c — exit codes, context with progress bar, option parsing. */
#include <errno.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
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

int cli_context_exit_status(volux_context *ctx, volux_status st) {
    /* An allocation the memory limit refused surfaces as "out of memory"
     * (or a reader's failure) from its caller; the message printed is the
     * limit's, and so is the exit status (2: a size to lower, not a machine
     * failure). */
    if (st != VOLUX_OK && ctx && volux_context_error_status(ctx) == VOLUX_ERR_LIMIT) st = VOLUX_ERR_LIMIT;
    return cli_exit_status(st);
}

int cli_fail(const char *cmd, volux_context *ctx, volux_status st) {
    const char *msg = ctx ? volux_context_error(ctx) : "";
    cli_eprintf("volux %s: %s\n", cmd, msg && *msg ? msg : volux_status_name(st));
    return cli_context_exit_status(ctx, st);
}

/* Progress on stderr. On a terminal: a one-line bar with the time left,
 * redrawn at most every 1/40 of the way (or on task change), cleared when
 * the task finishes. Elsewhere (a log): one line per 10 % for tasks that
 * have run for more than 5 s, so short renders stay quiet. */
typedef struct progress_state {
    char task[64];
    int last_step;
    int tty;
    int quiet; /* draw nothing (interrupts still stop the library) */
    double start_ms;
} progress_state;

static volatile sig_atomic_t stop_signal;

static void on_interrupt(int sig) {
    if (stop_signal) { /* the second one: at once, leaving no temporary file */
        volux_file_abandon_writes();
        _exit(128 + sig);
    }
    stop_signal = sig;
    static const char msg[] = "\nvolux: stopping; an image in progress is written with what it has "
                              "(press Ctrl-C again to abort at once)\n";
    ssize_t w = write(STDERR_FILENO, msg, sizeof msg - 1);
    (void)w;
}

void cli_catch_interrupts(void) {
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_interrupt;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

int cli_interrupted(void) { return (int)stop_signal; }

void cli_hold_interrupts(int hold) {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    sigprocmask(hold ? SIG_BLOCK : SIG_UNBLOCK, &set, NULL);
}

static void format_left(double ms, char *buf, size_t size) {
    long s = (long)(ms * 1e-3 + 0.5);
    if (s >= 3600) snprintf(buf, size, "%ld:%02ld:%02ld left", s / 3600, s / 60 % 60, s % 60);
    else snprintf(buf, size, "%ld:%02ld left", s / 60, s % 60);
}

static int progress_bar(void *user, const char *task, double fraction) {
    progress_state *p = user;
    if (stop_signal) return 1; /* asks the library to stop */
    if (p->quiet) return 0;
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

static progress_state bar_state = {"", -1, 0, 0, 0.0};

void cli_quiet_progress(void) { bar_state.quiet = 1; }

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
    cli_eprintf("volux: %s: %s\n", level == VOLUX_MESSAGE_WARNING ? "warning" : "note", text);
    p->last_step = -1; /* redraw the bar */
}

volux_context *cli_context(int threads) {
    progress_state *state = &bar_state;
    volux_context_desc d = {0};
    d.threads = threads;
    state->tty = isatty(STDERR_FILENO);
    /* Always installed: it is also how an interrupt reaches the library. */
    d.progress = progress_bar;
    d.progress_user = state;
    d.message = print_message;
    d.message_user = state;
    volux_context *ctx = NULL;
    if (volux_context_create(&d, &ctx) != VOLUX_OK) {
        cli_eprintf("volux: out of memory\n");
        return NULL;
    }
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

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

double cli_median(double *v, int n) {
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double cli_now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

const char *cli_data_dir(void) {
    const char *env = getenv("VOLUX_DATA");
    if (env && *env) return env;
#ifdef VOLUX_DEFAULT_DATA_DIR
    return VOLUX_DEFAULT_DATA_DIR;
#else
    return NULL;
#endif
}

int cli_is_procedural(const char *spec) { return !strncmp(spec, "procedural:", strlen("procedural:")); }

int cli_procedural_size_ok(const char *spec) {
    const char *colon = strchr(spec + strlen("procedural:"), ':');
    if (!colon) return 1;
    char *end = NULL;
    errno = 0;
    long n = strtol(colon + 1, &end, 10);
    return !errno && end != colon + 1 && !*end && n >= 1 && n <= VOLUX_MAX_DIM;
}

volux_status cli_procedural(volux_context *ctx, const char *cmd, const char *spec, uint64_t seed, volux_volume **out,
                            char *json, size_t json_size) {
    char name[64];
    const char *rest = spec + strlen("procedural:");
    const char *colon = strchr(rest, ':');
    size_t len = colon ? (size_t)(colon - rest) : strlen(rest);
    if (len >= sizeof name) len = sizeof name - 1;
    memcpy(name, rest, len);
    name[len] = 0;
    long n = 64;
    if (colon && !cli_parse_int(cmd, spec, colon + 1, 1, VOLUX_MAX_DIM, &n)) return VOLUX_ERR_INVALID;
    int dims[3] = {(int)n, (int)n, (int)n};
    volux_status st = volux_volume_procedural(ctx, name, dims, seed, out);
    if (!st && json)
        snprintf(json, json_size, "{\"procedural\": \"%s\", \"dims\": [%ld, %ld, %ld], \"seed\": %llu}", name, n, n, n,
                 (unsigned long long)seed);
    return st;
}

int cli_check_writable(const char *option, const char *path, char *msg, size_t msg_size) {
    /* The library's rules for every output (volux_file_check_output). */
    volux_context *ctx = NULL;
    if (volux_context_create(NULL, &ctx) != VOLUX_OK) {
        snprintf(msg, msg_size, "%s %s: out of memory", option, path);
        return 0;
    }
    volux_status st = volux_file_check_output(ctx, path);
    if (st) snprintf(msg, msg_size, "%s: %s", option, volux_context_error(ctx));
    volux_context_destroy(ctx);
    return st == VOLUX_OK;
}

/* "folder/name" with the folder resolved (the name may not exist yet). */
static int canonical_output(const char *path, char *out, size_t n) {
    const char *slash = strrchr(path, '/');
    char dir[4096], real[4096];
    if (!slash) snprintf(dir, sizeof dir, ".");
    else if (slash == path) snprintf(dir, sizeof dir, "/");
    else snprintf(dir, sizeof dir, "%.*s", (int)(slash - path) < 4000 ? (int)(slash - path) : 4000, path);
    if (!realpath(dir, real)) return 0;
    return snprintf(out, n, "%s/%s", real, slash ? slash + 1 : path) < (int)n;
}

int cli_same_file(const char *a, const char *b) {
    struct stat sa, sb;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    char ca[8200], cb[8200];
    return canonical_output(a, ca, sizeof ca) && canonical_output(b, cb, sizeof cb) && !strcmp(ca, cb);
}

/* A viridis-like ramp (after matplotlib's viridis, van der Walt & Smith
 * 2015): sRGB colours at t = 0, 1/8, ..., 1, interpolated linearly in sRGB.
 * Perceptually ordered and readable with colour-vision deficiency. */
static const float ramp[9][3] = {
    {0.267f, 0.005f, 0.329f}, {0.283f, 0.141f, 0.458f}, {0.230f, 0.322f, 0.546f},
    {0.173f, 0.449f, 0.558f}, {0.128f, 0.567f, 0.551f}, {0.158f, 0.684f, 0.502f},
    {0.369f, 0.789f, 0.383f}, {0.678f, 0.864f, 0.190f}, {0.993f, 0.906f, 0.144f},
};

void cli_ramp_color(double t, float *linear_rgb) {
    if (!(t >= 0.0)) t = t < 0.0 ? 0.0 : 1.0; /* NaN differences show as the maximum */
    if (t > 1.0) t = 1.0;
    double u = t * 8.0;
    int i = u >= 8.0 ? 7 : (int)u;
    float f = (float)(u - i);
    for (int k = 0; k < 3; k++) {
        float s = ramp[i][k] + (ramp[i + 1][k] - ramp[i][k]) * f;
        /* The image holds linear values; PNG writing re-applies sRGB. */
        linear_rgb[k] = volux_srgb_decode(s);
    }
}

