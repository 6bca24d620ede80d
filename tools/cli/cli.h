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
int cli_techniques(int argc, char **argv);
int cli_ambient_table(int argc, char **argv);

/* Prints "volux CMD: <context error>" and returns the exit status for st. */
int cli_fail(const char *cmd, volux_context *ctx, volux_status st);
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
/* Parses a positive/non-negative integer option value; prints an error. */
int cli_parse_int(const char *cmd, const char *opt, const char *s, long lo, long hi, long *out);
int cli_parse_double(const char *cmd, const char *opt, const char *s, double *out);
/* Monotonic wall clock in milliseconds. */
double cli_now_ms(void);

#endif
