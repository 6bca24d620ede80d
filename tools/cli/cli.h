/*
 * tools/cli/cli.h — shared pieces of the `volux` subcommands.
 *
 * Exit statuses (DESIGN §4): 0 success, 1 runtime failure, 2 bad usage or
 * bad input. Every error names the file/parameter on stderr.
 */
#ifndef VOLUX_CLI_H
#define VOLUX_CLI_H

#include "volux/volux.h"

enum { CLI_OK = 0, CLI_FAIL = 1, CLI_USAGE = 2 };

typedef struct cli_command {
    const char *name;
    const char *summary;
    int (*run)(int argc, char **argv); /* argv[0] is the command name */
} cli_command;

int cli_render(int argc, char **argv);
int cli_info(int argc, char **argv);
int cli_compare(int argc, char **argv);
int cli_bench(int argc, char **argv);
/* `volux bench` under mpirun / --distribute (bench_distributed.c);
 * distribute_mode is a dist_mode (tools/mpi/distribute.h). */
int cli_bench_distributed(int argc, char **argv, int distribute_mode);
/* `volux bench --pareto` (bench_pareto.c): the error-time plane, issue 26. */
int cli_bench_pareto(int argc, char **argv);
int cli_techniques(int argc, char **argv);
int cli_ambient_table(int argc, char **argv);
int cli_serve(int argc, char **argv); /* tools/viewer/serve.c */
/* cli_serve with `display_name` standing for the scene file in messages
 * and the page (volux view's generated scene; NULL: the file's name). */
int cli_serve_named(int argc, char **argv, const char *display_name);
int cli_view(int argc, char **argv);  /* tools/viewer/view.c: a volume's quick look in the viewer */

/* Prints "volux CMD: <context error>" and returns the exit status for st. */
int cli_fail(const char *cmd, volux_context *ctx, volux_status st);
/* The exit status for st failing on ctx: the memory limit's refusal (the
 * context's first error) is exit 2 whatever its caller returned. */
int cli_context_exit_status(volux_context *ctx, volux_status st);
/* Exit status for a library status. */
/* fprintf(stderr, ...) with the result escaped (volux_escape_text): the
 * arguments quoted in messages may hold terminal escape sequences or
 * invalid UTF-8. */
void cli_eprintf(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
int cli_exit_status(volux_status st);
/* Creates a context with a terminal progress bar (when stderr is a tty). */
volux_context *cli_context(int threads);
/* Draws the terminal progress bar of cli_context for work the library
 * does not see (nothing when stderr is not a terminal). */
void cli_progress(const char *task, double fraction);
/* No progress output from now on (--quiet); Ctrl-C still stops work. */
void cli_quiet_progress(void);
/* Parses a positive/non-negative integer option value; prints an error. */
int cli_parse_int(const char *cmd, const char *opt, const char *s, long lo, long hi, long *out);
int cli_parse_double(const char *cmd, const char *opt, const char *s, double *out);
/* Median of v[0..n) (n >= 1); sorts v in place. */
double cli_median(double *v, int n);
/* Monotonic wall clock in milliseconds. */
double cli_now_ms(void);

/* SIGINT/SIGTERM: the first asks the running work to stop (the context's
 * progress callback returns "cancel", so a render keeps what it has); the
 * second ends the process at once with 128 + signal. */
void cli_catch_interrupts(void);
/* The signal that asked to stop, or 0. */
int cli_interrupted(void);
/* Holds SIGINT/SIGTERM back (1) or lets them through again (0): a file
 * being written is finished before a second Ctrl-C ends the process. */
void cli_hold_interrupts(int hold);

/* What "$VOLUX_DATA/" names in scene files: the environment variable, else
 * ../shared/data beside the repository the binary was built from. */
const char *cli_data_dir(void);

/* "procedural:NAME[:N]" → a procedural volume (N³, default 64); prints why
 * on a bad N and returns VOLUX_ERR_INVALID with an empty context message.
 * cli_procedural_size_ok checks N without printing. */
int cli_is_procedural(const char *spec);
int cli_procedural_size_ok(const char *spec);
volux_status cli_procedural(volux_context *ctx, const char *cmd, const char *spec, uint64_t seed, volux_volume **out,
                            char *json, size_t json_size);

/* A viridis-like false-colour ramp: t in [0, 1] (clamped; NaN shows as 1)
 * to linear RGB (PNG writing applies sRGB). */
void cli_ramp_color(double t, float *linear_rgb);

/* Checks that `path` can be created (its folder exists and is writable,
 * it is not a folder); else 0 with "OPTION PATH: why" in msg. */
int cli_check_writable(const char *option, const char *path, char *msg, size_t msg_size);
/* 1 if the two output names are one file: the same folder (links
 * resolved) and the same name, or one existing file. */
int cli_same_file(const char *a, const char *b);

#endif
