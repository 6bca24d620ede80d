/* tools/cli/pareto_math.c — see pareto_math.h. */
#include "pareto_math.h"

#include <math.h>

/* Past an end of the series: e ∝ 1/spp, so spp_x = spp·e_end/e, and the
 * render time (without preparation) scales with spp. */
static double extrapolate(const pareto_point *p, double prepare_ms, double e) {
    double render = p->ms - prepare_ms;
    if (render < 0.0) render = 0.0;
    return prepare_ms + render * (p->rel_mse / e);
}

double pareto_time_to_error(const pareto_point *s, int n, double prepare_ms, double e, int *where) {
    if (where) *where = 0;
    if (!s || n <= 0 || !(e > 0.0) || !isfinite(e)) return -1.0;
    int i = 0;
    while (i < n && s[i].rel_mse > e) i++;
    if (i == 0) {
        if (s[0].rel_mse == e) return s[0].ms;
        if (where) *where = -1;
        return extrapolate(&s[0], prepare_ms, e);
    }
    if (i == n) {
        if (where) *where = 1;
        return extrapolate(&s[n - 1], prepare_ms, e);
    }
    /* s[i-1].rel_mse > e >= s[i].rel_mse: log-log between them */
    const pareto_point *a = &s[i - 1], *b = &s[i];
    if (!(b->rel_mse > 0.0) || !(a->ms > 0.0) || !(b->ms > 0.0)) return b->ms;
    double f = log(e / a->rel_mse) / log(b->rel_mse / a->rel_mse);
    return exp(log(a->ms) + f * (log(b->ms) - log(a->ms)));
}

double pareto_speedup(const pareto_point *s, int n, double prepare_ms, double e, double technique_ms, int *where) {
    double t = pareto_time_to_error(s, n, prepare_ms, e, where);
    if (t < 0.0 || !(technique_ms > 0.0)) return -1.0;
    return t / technique_ms;
}

double pareto_remaining_budget(double budget_ms, double elapsed_ms, int *one_pass) {
    *one_pass = 0;
    if (!(budget_ms > 0.0)) return 0.0;
    double left = budget_ms - (elapsed_ms > 0.0 ? elapsed_ms : 0.0);
    if (left > 0.0) return left;
    *one_pass = 1;
    return 0.0;
}

int pareto_auto_choose(const pareto_auto_row *rows, int n, double budget_ms, double voxels, double pixels,
                       int max_spp, pareto_auto_choice *out) {
    if (!rows || n <= 0 || !(budget_ms > 0.0) || max_spp < 1) return 0;
    double mv = voxels * 1e-6, mp = pixels * 1e-6;
    pareto_auto_choice best = {0}, fastest = {0};
    for (int i = 0; i < n; i++) {
        const pareto_auto_row *r = &rows[i];
        double prep = r->prepare_ms_per_mvoxel * mv, pass = r->pass_ms_per_mpixel * mp;
        double one = prep + pass;
        if (!fastest.technique || one < fastest.predicted_ms)
            fastest = (pareto_auto_choice){r->technique, 1, one, r->rel_mse_full, 0};
        int spp = 1;
        if (r->progressive && pass > 0.0) {
            double k = floor((budget_ms - prep) / pass);
            spp = k < 1.0 ? 1 : k > max_spp ? max_spp : (int)k;
        }
        double t = prep + spp * pass;
        if (t > budget_ms) continue;
        double e = r->progressive ? r->rel_mse_full / spp : r->rel_mse_full;
        if (!best.technique || e < best.expected_error || (e == best.expected_error && t < best.predicted_ms))
            best = (pareto_auto_choice){r->technique, spp, t, e, 1};
    }
    *out = best.technique ? best : fastest;
    return 1;
}
