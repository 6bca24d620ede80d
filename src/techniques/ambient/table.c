/*
 * techniques/ambient/table.c — Monte-Carlo preintegration of ambient
 * scattering in a homogeneous unit sphere (Ament et al. 2013, §4.1), its
 * lookup, the cached get and the public write/inspect entry points. The
 * table type, its file format and its cache entry are in
 * io/ambient_table_file.c.
 *
 * THE ESTIMATOR. The paper traces n walks per table entry from x_o(θ)
 * towards the centre and needed 2–20 h single-threaded. We get the same
 * quantity with far less work from four observations:
 *
 *  1. Symmetry. The medium is homogeneous and the sphere round, so the walk
 *     started at x_o(θ) is the walk started at the pole (0,0,1) rotated by
 *     R_θ (the tilt taking the pole to x_o(θ)), composed with any spin S_ψ
 *     about the pole. Only the boundary condition (Eq. 11) depends on the
 *     orientation. So one walk from the pole is scored against *every* θ
 *     entry by rotating its exit point and direction — a column of nθ
 *     entries costs one walk, not nθ walks. K spins ψ = ψ0 + 2πk/K (ψ0
 *     random per vertex) average the azimuth.
 *  2. The uncollided term is analytic (volux_ambient_uncollided): the walk
 *     is forced to collide inside the sphere (truncated exponential), its
 *     weight multiplied by the collision probability 1 − e^{−2σ̃t}.
 *  3. Expected-value escape scoring: after every scattering event the walk
 *     scores the probability e^{−σ̃t ℓ} of leaving along the sampled
 *     direction (ℓ = distance to the sphere) times the boundary radiance
 *     there, and then continues with a forced collision inside. Every
 *     vertex contributes, so the first-scatter term has one sample per walk
 *     at zero extra tracing cost.
 *  4. Absorption as a weight (×albedo per event) with Russian roulette only
 *     below a weight of 1/8.
 *
 * The estimate of an entry is L0 + E[Σ_vertices β_k e^{−σ̃t ℓ_k} L̃s(...)],
 * unbiased for the same integral as the paper's estimator; tests compare
 * both (tests/physics/test_ambient_table.c).
 *
 * DETERMINISM. Work items are (σ̃t, g) columns; the walk j of column c uses
 * the counter-based stream (seed, c, j), and a column is summed by one
 * thread in walk order, so the table is bit-identical for any thread count.
 */
#include "table.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "core/simd.h"
#include "techniques/scatter/hg.h"

/* VOLUX_AMBIENT_TABLE_ESTIMATOR (io/ambient_table_file.h) names this
 * estimator in files and cache names: bump it whenever the results change. */
#define MIS_MIN_G 0.6
#define BATCHES 16        /* batch means for the per-entry standard error */
#define RR_WEIGHT 0.125   /* Russian roulette below this weight (4.)      */
#define MAX_VERTICES 4096 /* safety bound; never reached with albedo < 1  */

static double table_theta(const volux_ambient_table_desc *d, int it) {
    return 3.14159265358979323846 * (double)it / (double)(d->n_theta - 1);
}
static double table_sigma(const volux_ambient_table_desc *d, int is) {
    return d->sigma_max * (double)is / (double)(d->n_sigma - 1);
}
static double table_g(const volux_ambient_table_desc *d, int ig) {
    return d->g_min + (d->g_max - d->g_min) * (double)ig / (double)(d->n_g - 1);
}

double volux_ambient_uncollided(double theta, double sigma, double g) {
    double c = cos(theta);
    return exp(-sigma * (2.0 + 2.0 * fmax(0.0, -c))) * scatter_hg_d(g, c);
}

/* Eq. 11 at a sphere point with height z, for light travelling with
 * z-component w: the front crossed d = z + |z| = 2·max(0, z) inside. */
static double boundary_radiance(double z, double w, double sigma, double g) {
    return exp(-2.0 * sigma * fmax(0.0, z)) * scatter_hg_d(g, w);
}

/* Distance from x (inside the unit sphere) along unit d to the sphere. */
static double exit_distance(scatter_dvec3 x, scatter_dvec3 d) {
    double b = x.x * d.x + x.y * d.y + x.z * d.z;
    double c = x.x * x.x + x.y * x.y + x.z * x.z - 1.0;
    double disc = b * b - c;
    double l = -b + sqrt(disc > 0.0 ? disc : 0.0);
    return l > 0.0 ? l : 0.0;
}

double volux_ambient_reference_entry(double theta, double sigma, double g, double albedo, uint64_t paths,
                                     uint64_t seed, double *std_error) {
    double sum = 0.0, sum2 = 0.0;
    for (uint64_t p = 0; p < paths; p++) {
        volux_rng rng = volux_rng_make(seed, 0x7ab1e, p, 0);
        scatter_dvec3 x = {sin(theta), 0.0, cos(theta)};
        scatter_dvec3 d = {-x.x, -x.y, -x.z};
        double score = 0.0;
        for (int v = 0; v < MAX_VERTICES; v++) {
            double l = exit_distance(x, d);
            double s = sigma > 0.0 ? -log1p(-volux_rng_double(&rng)) / sigma : INFINITY;
            if (s >= l) {
                scatter_dvec3 e = {x.x + l * d.x, x.y + l * d.y, x.z + l * d.z};
                score = boundary_radiance(e.z, -d.z, sigma, g);
                break;
            }
            x.x += s * d.x, x.y += s * d.y, x.z += s * d.z;
            if (volux_rng_double(&rng) >= albedo) break; /* absorbed */
            double u0 = volux_rng_double(&rng), u1 = volux_rng_double(&rng);
            d = scatter_hg_sample_dir(g, d, u0, u1);
        }
        sum += score;
        sum2 += score * score;
    }
    double n = (double)paths, mean = sum / n;
    if (std_error) *std_error = paths > 1 ? sqrt(fmax(0.0, (sum2 / n - mean * mean) / (n - 1.0))) : 0.0;
    return mean;
}

/* ------------------------------------------------------------------ build */

typedef struct build_job {
    volux_context *ctx;
    const volux_ambient_table_desc *d;
    float *data, *rel_error;
    const float *cos_t, *sin_t; /* per θ entry */
    unsigned char *scratch;     /* per thread */
    size_t scratch_bytes;
    int done, busy, cancelled;
} build_job;

/* The vertex's escape contribution to every θ entry (tilt R_θ after a
 * spin S_ψ; all vectors below are already spun), as a one-sample MIS
 * (balance heuristic) of two strategies for the direction ω the walk
 * leaves along:
 *   A  ω ~ phase about d (the walk's own sample): P_A = P(ω·d)
 *   B  the light's travel direction w' ~ the boundary lobe about +z in the
 *      entry's frame (Eq. 11), ω = −R_θ^T w': P_B = P(w'_z)
 * Both terms reduce to e^{−σ̃t ℓ}·e^{−2σ̃t max(0, z')}·P_A P_B/(P_A + P_B)
 * with P(μ) = (1 + g² − 2gμ)^{−3/2}; the caller applies (1 − g²)/(4π) once.
 * Strategy B makes sharp lobes cheap to hit; it doubles the cost per entry,
 * which pays off only for |g| ≥ MIS_MIN_G (measured at the paper's
 * resolution), so below that strategy A alone is used (mis = 0). */
__attribute__((target_clones("avx2", "default"))) static void
score_all(float *restrict acc, const float *restrict cos_t, const float *restrict sin_t, int nt, int mis, float weight,
          float sigma, float a, float b, /* vertex */ float x0, float x1, float x2, float d0, float d1, float d2,
          /* A */ float esc_a, float ex, float ez, float wx, float wz, float pa_a,
          /* B */ float v0, float v1, float v2, float pb_b) {
    const float cc = x0 * x0 + x1 * x1 + x2 * x2 - 1.0f;
    if (!mis) {
        /* strategy A alone: e^{−σ̃t ℓ}·e^{−2σ̃t max(0, z')}·P_B */
        for (int i = 0; i < nt; i++) {
            const float c = cos_t[i], s = sin_t[i];
            float z = ez * c - ex * s, wp = wz * c - wx * s;
            float q = a - b * wp;
            acc[i] += weight * esc_a * volux_exp_nonpos_t6(-sigma * (z + fabsf(z))) / (q * sqrtf(q));
        }
        return;
    }
    for (int i = 0; i < nt; i++) {
        const float c = cos_t[i], s = sin_t[i];
        /* A: rotate the sampled exit */
        float z = ez * c - ex * s, wp = wz * c - wx * s;
        float q = a - b * wp, pb_a = 1.0f / (q * sqrtf(q));
        float term_a = esc_a * volux_exp_nonpos_t6(-sigma * (z + fabsf(z))) * pa_a * pb_a / (pa_a + pb_a);
        /* B: the lobe sample w' (v) back into the spun frame, ω = −R_θ^T w' */
        float o0 = -(v0 * c - v2 * s), o1 = -v1, o2 = -(v0 * s + v2 * c);
        float bb = x0 * o0 + x1 * o1 + x2 * o2, disc = bb * bb - cc;
        float l = -bb + sqrtf(0.5f * (disc + fabsf(disc)));
        float e0 = x0 + l * o0, e2 = x2 + l * o2, zb = e2 * c - e0 * s;
        float qa = a - b * (o0 * d0 + o1 * d1 + o2 * d2), pa_b = 1.0f / (qa * sqrtf(qa));
        float term_b = volux_exp_nonpos_t6(-sigma * (l + zb + fabsf(zb))) * pa_b * pb_b / (pa_b + pb_b);
        acc[i] += weight * (term_a + term_b);
    }
}

/* Progress after `columns` columns (fractional: within one), from one
 * thread at a time; a cancel from the callback stops every column at its
 * next check. */
static void report_progress(build_job *job, double columns) {
    const volux_ambient_table_desc *d = job->d;
    if (!job->ctx->progress || __atomic_exchange_n(&job->busy, 1, __ATOMIC_ACQUIRE)) return;
    double f = columns / ((double)d->n_sigma * (double)d->n_g * (double)d->n_albedo);
    if (volux_progress(job->ctx, "ambient table", f < 1.0 ? f : 0.999))
        __atomic_store_n(&job->cancelled, 1, __ATOMIC_RELAXED);
    __atomic_store_n(&job->busy, 0, __ATOMIC_RELEASE);
}

/* Walks between checks for a cancel inside one column: a column of 10^9
 * walks (table_paths allows it) must still stop within ~100 ms. */
#define CANCEL_CHECK_WALKS 1024u

static void build_column(void *user, int64_t index, int thread) {
    build_job *job = user;
    if (__atomic_load_n(&job->cancelled, __ATOMIC_RELAXED)) return;
    const volux_ambient_table_desc *d = job->d;
    const int nt = d->n_theta;
    const int is = (int)(index % d->n_sigma), ig = (int)(index / d->n_sigma % d->n_g);
    /* high albedos first (their walks are the longest), so that the short
     * columns fill the end of the parallel loop */
    const int ia = d->n_albedo - 1 - (int)(index / ((int64_t)d->n_sigma * d->n_g));
    const double sigma = table_sigma(d, is), g = table_g(d, ig), albedo = d->albedo[ia];
    const float a = (float)(1.0 + g * g), b = (float)(2.0 * g);
    const double hg_const = (1.0 - g * g) * SCATTER_INV_4PI_D;
    const int mis = fabs(g) >= MIS_MIN_G - 1e-9;

    /* Scratch: acc[nt] floats (one walk), batch[BATCHES][nt] doubles. */
    unsigned char *mem = job->scratch + (size_t)thread * job->scratch_bytes;
    double *batch = (double *)mem;
    float *acc = (float *)(batch + (size_t)BATCHES * (size_t)nt);
    memset(batch, 0, sizeof(double) * (size_t)BATCHES * (size_t)nt);

    const uint64_t paths = d->paths;
    const double p_collide = -expm1(-2.0 * sigma); /* 1 − e^{−2σ̃t} */
    if (sigma > 0.0 && albedo > 0.0) {
        for (uint64_t p = 0; p < paths; p++) {
            if (p % CANCEL_CHECK_WALKS == CANCEL_CHECK_WALKS - 1) {
                report_progress(job, __atomic_load_n(&job->done, __ATOMIC_RELAXED) + (double)p / (double)paths);
                if (__atomic_load_n(&job->cancelled, __ATOMIC_RELAXED)) return;
            }
            volux_rng rng = volux_rng_make(d->seed, (uint64_t)index, p, 0);
            memset(acc, 0, sizeof(float) * (size_t)nt);
            /* Forced first collision on the diameter from the pole. */
            double beta = p_collide;
            double s = -log1p(-volux_rng_double(&rng) * p_collide) / sigma;
            scatter_dvec3 x = {0.0, 0.0, 1.0 - s}, dir = {0.0, 0.0, -1.0};
            for (int v = 0; v < MAX_VERTICES; v++) {
                beta *= albedo;
                double u0 = volux_rng_double(&rng), u1 = volux_rng_double(&rng);
                scatter_dvec3 prev = dir;
                dir = scatter_hg_sample_dir(g, dir, u0, u1);
                double l = exit_distance(x, dir);
                double esc = exp(-sigma * l);
                scatter_dvec3 e = {x.x + l * dir.x, x.y + l * dir.y, x.z + l * dir.z};
                /* spin ψ about the pole; light travels w = −dir back along the walk */
                double psi = 2.0 * 3.14159265358979323846 * volux_rng_double(&rng), cp = cos(psi), sp = sin(psi);
                double mu_a = dir.x * prev.x + dir.y * prev.y + dir.z * prev.z;
                double qa = 1.0 + g * g - 2.0 * g * mu_a;
                /* strategy B: w' about +z with the boundary lobe's HG */
                double mu = scatter_hg_sample_cos(g, volux_rng_double(&rng));
                double phi = 2.0 * 3.14159265358979323846 * volux_rng_double(&rng);
                double st = sqrt(fmax(0.0, 1.0 - mu * mu)), qb = 1.0 + g * g - 2.0 * g * mu;
                score_all(acc, job->cos_t, job->sin_t, nt, mis, (float)beta, (float)sigma, a, b,
                          (float)(x.x * cp - x.y * sp), (float)(x.x * sp + x.y * cp), (float)x.z,
                          (float)(prev.x * cp - prev.y * sp), (float)(prev.x * sp + prev.y * cp), (float)prev.z,
                          (float)esc, (float)(e.x * cp - e.y * sp), (float)e.z, (float)(-(dir.x * cp - dir.y * sp)),
                          (float)-dir.z, (float)(1.0 / (qa * sqrt(qa))), (float)(st * cos(phi)), (float)(st * sin(phi)),
                          (float)mu, (float)(1.0 / (qb * sqrt(qb))));
                double p_stay = -expm1(-sigma * l);
                beta *= p_stay;
                if (beta < RR_WEIGHT) {
                    if (volux_rng_double(&rng) * RR_WEIGHT >= beta) break;
                    beta = RR_WEIGHT;
                }
                s = -log1p(-volux_rng_double(&rng) * p_stay) / sigma;
                x.x += s * dir.x, x.y += s * dir.y, x.z += s * dir.z;
            }
            double *bsum = batch + (size_t)(p * BATCHES / paths) * (size_t)nt;
            for (int i = 0; i < nt; i++) bsum[i] += acc[i];
        }
    }
    /* Mean over walks + the analytic uncollided term; batch-mean errors. */
    for (int i = 0; i < nt; i++) {
        double total = 0.0, sq = 0.0;
        for (int k = 0; k < BATCHES; k++) total += batch[(size_t)k * (size_t)nt + i];
        double mean = total / (double)paths * hg_const;
        double value = volux_ambient_uncollided(table_theta(d, i), sigma, g) + mean;
        double se = 0.0;
        if (paths >= BATCHES && sigma > 0.0 && albedo > 0.0) {
            for (int k = 0; k < BATCHES; k++) {
                uint64_t lo = (uint64_t)k * paths / BATCHES, hi = (uint64_t)(k + 1) * paths / BATCHES;
                double m = batch[(size_t)k * (size_t)nt + i] / (double)(hi - lo) * hg_const - mean;
                sq += m * m;
            }
            se = sqrt(sq / ((double)BATCHES * (BATCHES - 1)));
        }
        size_t at = volux_ambient_table_index4(d, i, is, ig, ia);
        job->data[at] = (float)value;
        job->rel_error[at] = value > 0.0 ? (float)(se / value) : 0.0f;
    }
    report_progress(job, __atomic_add_fetch(&job->done, 1, __ATOMIC_RELAXED));
}

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

volux_status volux_ambient_table_build(volux_context *ctx, const volux_ambient_table_desc *d,
                                       volux_ambient_table *out) {
    volux_status st = volux_ambient_table_desc_validate(ctx, d);
    if (st) return st;
    double t0 = now_ms();
    volux_ambient_table t;
    if (!volux_ambient_table_alloc(ctx, d, 1, &t))
        return volux_error(ctx, VOLUX_ERR_NOMEM, "ambient table: out of memory (%zu values)",
                           volux_ambient_table_values(d));
    int threads = volux_context_threads(ctx);
    const int nt = d->n_theta;
    size_t scratch_bytes = sizeof(double) * (size_t)BATCHES * (size_t)nt + sizeof(float) * (size_t)nt;
    scratch_bytes = (scratch_bytes + 63) & ~(size_t)63;
    size_t trig_bytes = 2 * sizeof(float) * (size_t)nt;
    unsigned char *scratch = volux_malloc(ctx, scratch_bytes * (size_t)threads);
    float *trig = volux_malloc(ctx, trig_bytes);
    if (!scratch || !trig) {
        volux_free(ctx, scratch, scratch_bytes * (size_t)threads);
        volux_free(ctx, trig, trig_bytes);
        volux_ambient_table_free(ctx, &t);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "ambient table: out of memory for scratch");
    }
    for (int i = 0; i < nt; i++) {
        trig[i] = (float)cos(table_theta(d, i));
        trig[nt + i] = (float)sin(table_theta(d, i));
    }
    build_job job = {ctx, d, t.data, t.rel_error, trig, trig + nt, scratch, scratch_bytes, 0, 0, 0};
    volux_parallel_for(threads, (int64_t)d->n_sigma * d->n_g * d->n_albedo, build_column, &job);
    volux_free(ctx, scratch, scratch_bytes * (size_t)threads);
    volux_free(ctx, trig, trig_bytes);
    if (job.cancelled) {
        volux_ambient_table_free(ctx, &t);
        return volux_error(ctx, VOLUX_ERR_CANCELLED, "ambient table: cancelled");
    }
    volux_progress(ctx, "ambient table", 1.0);
    t.build_ms = now_ms() - t0;
    *out = t;
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ lookup */

double volux_ambient_g_interp(double uncollided_g, double a, double ua, double b, double ub, double f) {
    double ca = a - ua, cb = b - ub; /* the collided parts at the two g nodes */
    double c = ca > 0.0 && cb > 0.0 ? exp(log(ca) * (1.0 - f) + log(cb) * f) : ca * (1.0 - f) + cb * f;
    return uncollided_g + c;
}

/* Bilinear in (θ, σ̃t) of the values at g (volux_ambient_g_interp at each
 * of the four nodes), at albedo block ia. */
static double eval_block(const volux_ambient_table *t, const int i0[3], const double f[3], double g, int ia) {
    const volux_ambient_table_desc *d = &t->desc;
    double ga = table_g(d, i0[2]), gb = table_g(d, i0[2] + 1), v[2][2];
    for (int j = 0; j < 2; j++)
        for (int k = 0; k < 2; k++) {
            int it = i0[0] + k, is = i0[1] + j;
            double th = table_theta(d, it), sg = table_sigma(d, is);
            v[j][k] = volux_ambient_g_interp(volux_ambient_uncollided(th, sg, g),
                                             t->data[volux_ambient_table_index4(d, it, is, i0[2], ia)],
                                             volux_ambient_uncollided(th, sg, ga),
                                             t->data[volux_ambient_table_index4(d, it, is, i0[2] + 1, ia)],
                                             volux_ambient_uncollided(th, sg, gb), f[2]);
        }
    return (v[0][0] * (1 - f[0]) + v[0][1] * f[0]) * (1 - f[1]) + (v[1][0] * (1 - f[0]) + v[1][1] * f[0]) * f[1];
}

int volux_ambient_table_albedo_bracket(const volux_ambient_table_desc *d, double albedo, double *frac) {
    if (d->n_albedo == 1 || albedo <= d->albedo[0]) {
        *frac = 0.0;
        return 0;
    }
    for (int i = 0; i + 1 < d->n_albedo; i++)
        if (albedo <= d->albedo[i + 1]) {
            *frac = (albedo - d->albedo[i]) / (d->albedo[i + 1] - d->albedo[i]);
            return i;
        }
    *frac = 1.0;
    return d->n_albedo - 2;
}

double volux_ambient_table_eval(const volux_ambient_table *t, double theta, double sigma, double g, double albedo) {
    const volux_ambient_table_desc *d = &t->desc;
    double u[3] = {theta / 3.14159265358979323846 * (d->n_theta - 1), sigma / d->sigma_max * (d->n_sigma - 1),
                   (g - d->g_min) / (d->g_max - d->g_min) * (d->n_g - 1)};
    int n[3] = {d->n_theta, d->n_sigma, d->n_g}, i0[3];
    double f[3];
    for (int a = 0; a < 3; a++) {
        double x = u[a] < 0.0 ? 0.0 : (u[a] > n[a] - 1 ? n[a] - 1 : u[a]);
        int i = (int)x;
        if (i > n[a] - 2) i = n[a] - 2;
        i0[a] = i;
        f[a] = x - i;
    }
    double fa;
    int ia = volux_ambient_table_albedo_bracket(d, albedo, &fa);
    double gc = g < d->g_min ? d->g_min : (g > d->g_max ? d->g_max : g); /* the g axis is clamped */
    double v = eval_block(t, i0, f, gc, ia);
    if (d->n_albedo > 1) v = v * (1.0 - fa) + eval_block(t, i0, f, gc, ia + 1) * fa;
    return v;
}

static int cmp_float(const void *a, const void *b) {
    float x = *(const float *)a, y = *(const float *)b;
    return x < y ? -1 : x > y;
}

int volux_ambient_table_noise_summary(volux_context *ctx, const volux_ambient_table *t, double floor,
                                      volux_ambient_table_noise *out) {
    memset(out, 0, sizeof *out);
    if (!t->rel_error) return 0;
    size_t n = volux_ambient_table_values(&t->desc), m = 0;
    float *v = volux_malloc(ctx, n * sizeof(float));
    if (!v) return 0;
    double sum = 0.0;
    for (size_t i = 0; i < n; i++)
        if (t->data[i] > floor) {
            v[m++] = t->rel_error[i];
            sum += t->rel_error[i];
        }
    if (m) {
        qsort(v, m, sizeof *v, cmp_float);
        out->median = v[m / 2];
        out->p90 = v[(size_t)(0.90 * (double)(m - 1))];
        out->p99 = v[(size_t)(0.99 * (double)(m - 1))];
        out->max = v[m - 1];
        out->mean = sum / (double)m;
        out->entries = m;
    }
    volux_free(ctx, v, n * sizeof(float));
    return m > 0;
}

/* ------------------------------------------------------------------ cache */

volux_status volux_ambient_table_get(volux_context *ctx, const volux_ambient_table_desc *d, volux_ambient_table *out,
                                     int *built) {
    volux_status st = volux_ambient_table_desc_validate(ctx, d);
    if (st) return st;
    volux_ambient_table_desc builtin;
    volux_ambient_table_desc_builtin(&builtin);
    if (volux_ambient_table_desc_equal(d, &builtin)) {
        size_t size;
        const unsigned char *bytes = volux_ambient_builtin_table(&size);
        if (bytes && volux_ambient_table_builtin_load(ctx, bytes, size, out)) {
            if (volux_ambient_table_desc_equal(&out->desc, d)) {
                if (built) *built = 0;
                return VOLUX_OK;
            }
            volux_ambient_table_free(ctx, out);
        }
    }
    if (volux_ambient_table_cache_load(ctx, d, out)) {
        if (built) *built = 0;
        return VOLUX_OK;
    }
    char path[4400];
    int have_path = volux_ambient_table_cache_path(ctx, d, path, sizeof path);
    volux_message(ctx, VOLUX_MESSAGE_NOTE,
                  "ambient: building the preintegration table once: %d x %d x %d entries x %d albed%s, %llu walks "
                  "per column (the built-in table is 64 x 64 x 10 x 12; the paper's size takes minutes)%s%s",
                  d->n_theta, d->n_sigma, d->n_g, d->n_albedo, d->n_albedo > 1 ? "os" : "o",
                  (unsigned long long)d->paths, have_path ? "; it will be kept in " : "; the disk cache is off, so it "
                  "lives in memory only", have_path ? path : "");
    volux_ambient_table t;
    if ((st = volux_ambient_table_build(ctx, d, &t))) return st;
    /* failing to store only means the table lives in memory */
    int stored = volux_ambient_table_cache_store(ctx, &t);
    volux_message(ctx, VOLUX_MESSAGE_NOTE, "ambient: table built in %.1f s%s%s", t.build_ms * 1e-3,
                  stored ? ", kept in " : have_path ? ", but the cache folder cannot be written: " : "",
                  stored || have_path ? path : "");
    if (built) *built = 1;
    *out = t;
    return VOLUX_OK;
}

/* ------------------------------------------------------------ public API */

static void summarise(volux_context *ctx, const volux_ambient_table *t, volux_ambient_table_summary *out) {
    memset(out, 0, sizeof *out);
    out->desc = t->desc;
    out->build_ms = t->build_ms;
    out->has_noise = volux_ambient_table_noise_summary(ctx, t, VOLUX_AMBIENT_TABLE_NOISE_FLOOR, &out->noise);
}

volux_status volux_ambient_table_write(volux_context *ctx, const volux_ambient_table_desc *d, const char *path,
                                       volux_ambient_table_summary *out) {
    volux_ambient_table t;
    volux_status st = volux_ambient_table_build(ctx, d, &t);
    if (st) return st;
    if (!(st = volux_ambient_table_save(ctx, &t, path)) && out) summarise(ctx, &t, out);
    volux_ambient_table_free(ctx, &t);
    return st;
}

volux_status volux_ambient_table_strip(volux_context *ctx, const char *in, const char *out) {
    volux_ambient_table t;
    volux_status st = volux_ambient_table_load(ctx, in, &t);
    if (st) return st;
    if (t.rel_error) volux_free(ctx, t.rel_error, volux_ambient_table_values(&t.desc) * sizeof(float));
    t.rel_error = NULL;
    st = volux_ambient_table_save(ctx, &t, out);
    volux_ambient_table_free(ctx, &t);
    return st;
}

volux_status volux_ambient_table_inspect(volux_context *ctx, const char *path, volux_ambient_table_summary *out) {
    volux_ambient_table t;
    volux_status st = volux_ambient_table_load(ctx, path, &t);
    if (st) return st;
    summarise(ctx, &t, out);
    volux_ambient_table_free(ctx, &t);
    return VOLUX_OK;
}

/* ------------------------------------------------------------- slices */

typedef struct slice_job {
    const volux_ambient_table *t; /* NULL: the paper's estimator */
    double g, albedo, sigma_max;
    int n_theta, n_sigma;
    uint64_t paths, seed;
    float *out;
} slice_job;

static void slice_entry(void *user, int64_t i, int thread) {
    (void)thread;
    const slice_job *j = user;
    int it = (int)(i % j->n_theta), is = (int)(i / j->n_theta);
    double theta = 3.14159265358979323846 * it / (j->n_theta - 1), sigma = j->sigma_max * is / (j->n_sigma - 1);
    j->out[i] = (float)(j->t ? volux_ambient_table_eval(j->t, theta, sigma, j->g, j->albedo)
                             : volux_ambient_reference_entry(theta, sigma, j->g, j->albedo, j->paths,
                                                             j->seed ^ (uint64_t)i, NULL));
}

volux_status volux_ambient_table_slice(volux_context *ctx, const char *path, double g, double albedo, int n_theta,
                                       int n_sigma, uint64_t reference_paths, float *out) {
    if (!(g > -1.0 && g < 1.0)) return volux_error(ctx, VOLUX_ERR_INVALID, "ambient table slice: g: %g is not in (-1, 1)", g);
    if (!(albedo >= 0.0 && albedo <= 1.0))
        return volux_error(ctx, VOLUX_ERR_INVALID, "ambient table slice: albedo: %g is not in [0, 1]", albedo);
    if (n_theta < 2 || n_theta > VOLUX_AMBIENT_TABLE_MAX_DIM || n_sigma < 2 || n_sigma > VOLUX_AMBIENT_TABLE_MAX_DIM)
        return volux_error(ctx, VOLUX_ERR_INVALID, "ambient table slice: size: %d x %d is not in [2, %d]", n_theta,
                           n_sigma, VOLUX_AMBIENT_TABLE_MAX_DIM);
    if (!out) return volux_error(ctx, VOLUX_ERR_INVALID, "ambient table slice: no output buffer");
    volux_ambient_table t;
    volux_status st;
    if (path) st = volux_ambient_table_load(ctx, path, &t);
    else {
        volux_ambient_table_desc d;
        volux_ambient_table_desc_builtin(&d);
        st = volux_ambient_table_get(ctx, &d, &t, NULL);
    }
    if (st) return st;
    slice_job j = {reference_paths ? NULL : &t, g, albedo, t.desc.sigma_max, n_theta, n_sigma, reference_paths,
                   t.desc.seed, out};
    volux_parallel_for(volux_context_threads(ctx), (int64_t)n_theta * n_sigma, slice_entry, &j);
    volux_ambient_table_free(ctx, &t);
    return VOLUX_OK;
}
