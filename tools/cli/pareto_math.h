/*
 * tools/cli/pareto_math.h — the arithmetic of `volux bench --pareto` and of
 * `volux render`'s time budget, kept free of the library so that unit tests
 * can check it on known numbers.
 *
 * DOES NOT: render, time or print anything.
 */
#ifndef VOLUX_TOOLS_PARETO_MATH_H
#define VOLUX_TOOLS_PARETO_MATH_H

/* One point of pathtrace's convergence series: after `spp` samples per
 * pixel, `ms` milliseconds since the technique's creation began (prepare +
 * every render so far) and the relative MSE against the reference. */
typedef struct pareto_point {
    double spp, ms, rel_mse;
} pareto_point;

/* The time pathtrace needs to reach the error e, from its series (n points,
 * spp increasing) and its preparation time prepare_ms:
 *  - inside the series: the first point at or below e and the one before it,
 *    interpolated linearly in (log error, log time);
 *  - past either end: rel_mse ∝ 1/spp (an unbiased estimator's variance),
 *    render time ∝ spp, from the nearest end point (below the first point
 *    this is a fractional spp: an optimistic pathtrace, so a conservative S).
 * *where (may be NULL) is −1 below the series, 0 inside, +1 above it.
 * Returns −1 when it cannot say (no points, e ≤ 0 or not finite). */
double pareto_time_to_error(const pareto_point *series, int n, double prepare_ms, double e, int *where);

/* The equal-error speed-up S = T_pathtrace(e) / technique_ms; −1 when
 * either time is unknown. */
double pareto_speedup(const pareto_point *series, int n, double prepare_ms, double e, double technique_ms, int *where);

/* `volux render --time-ms`: what is left of budget_ms for the render after
 * elapsed_ms of preparation. budget_ms 0 (no budget) stays 0. When the
 * preparation used it all, *one_pass is set: render one complete pass (a
 * budget of ~0 would cut the first pass's paths short and darken it) and
 * no more; the returned budget is then 0 (no limit on that one pass). */
double pareto_remaining_budget(double budget_ms, double elapsed_ms, int *one_pass);

/* `--technique auto` (issue 26): one row per technique of the measured
 * error-time table (docs/CHOOSING.md, bench/pareto/run.sh). Costs are
 * linear models fitted to that run: preparation per million voxels and one
 * pass (1 spp) per million pixels, on its machine and thread count. */
typedef struct pareto_auto_row {
    const char *technique;
    double prepare_ms_per_mvoxel;
    double pass_ms_per_mpixel;
    double rel_mse_full; /* median error against the all-orders reference
                            (a progressive row: at 1 spp, falling as 1/spp) */
    int progressive;     /* more passes lower the error (pathtrace)         */
} pareto_auto_row;

typedef struct pareto_auto_choice {
    const char *technique;
    int spp;               /* passes to render (progressive rows)           */
    double predicted_ms;   /* prepare + render, from the cost model         */
    double expected_error; /* the row's error (progressive: e₁/spp)         */
    int fits;              /* 0: nothing fits the budget; the fastest row   */
} pareto_auto_choice;

/* The rule of `--technique auto`: among the rows whose predicted time
 * (prepare + spp passes) fits budget_ms, the least expected error; a
 * progressive row takes as many passes as fit (at most max_spp). Ties: the
 * faster. When nothing fits, the row with the least predicted time at one
 * pass (fits = 0). Returns 0 (and no choice) for an empty table or a
 * budget ≤ 0. */
int pareto_auto_choose(const pareto_auto_row *rows, int n, double budget_ms, double voxels, double pixels,
                       int max_spp, pareto_auto_choice *out);

/* The measured table (pareto_math.c) and its row count. */
extern const pareto_auto_row pareto_auto_table[];
extern const int pareto_auto_table_rows;

#endif
