/*
 * techniques/ambient/table.c — Monte-Carlo preintegration of ambient
 * scattering in a homogeneous unit sphere (Ament et al. 2013, §4.1), the
 * table file and its cache.
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
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "table_internal.h"
#include "core/simd.h"
#include "techniques/scatter/hg.h"

#define TABLE_MAGIC "VXAMBTAB"
#define TABLE_HEADER_BYTES 128
#define TABLE_FLAG_ERRORS 1u
#define ESTIMATOR_ID 3u /* 3: escape scoring, with MIS against boundary-lobe sampling for |g| ≥ MIS_MIN_G */
#define MIS_MIN_G 0.6
#define BATCHES 16        /* batch means for the per-entry standard error */
#define RR_WEIGHT 0.125   /* Russian roulette below this weight (4.)      */
#define MAX_VERTICES 4096 /* safety bound; never reached with albedo < 1  */

void volux_ambient_table_desc_defaults(volux_ambient_table_desc *d) {
    memset(d, 0, sizeof *d);
    d->n_theta = 256;
    d->n_sigma = 256;
    d->n_g = 19;
    d->sigma_max = 20.0;
    d->g_min = -0.9;
    d->g_max = 0.9;
    d->albedo = 0.9;
    d->paths = 16384;
    d->seed = 1;
}

volux_status volux_ambient_table_desc_validate(volux_context *ctx, const volux_ambient_table_desc *d) {
    const char *P = "ambient table";
    int dims[3] = {d->n_theta, d->n_sigma, d->n_g};
    const char *names[3] = {"n_theta", "n_sigma", "n_g"};
    for (int a = 0; a < 3; a++)
        if (dims[a] < 2 || dims[a] > VOLUX_AMBIENT_TABLE_MAX_DIM)
            return volux_error(ctx, VOLUX_ERR_INVALID, "%s: %s: must be in [2, %d], got %d", P, names[a],
                               VOLUX_AMBIENT_TABLE_MAX_DIM, dims[a]);
    if (!(d->sigma_max > 0.0) || !(d->sigma_max <= 1e4))
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s: sigma_max: must be in (0, 1e4], got %g", P, d->sigma_max);
    if (!(d->g_min > -1.0) || !(d->g_max < 1.0) || !(d->g_min < d->g_max))
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s: g range: need -1 < g_min < g_max < 1, got [%g, %g]", P,
                           d->g_min, d->g_max);
    if (!(d->albedo >= 0.0) || !(d->albedo <= 1.0))
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s: albedo: must be in [0, 1], got %g", P, d->albedo);
    if (d->paths < 1 || d->paths > (1ull << 40))
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s: paths: must be in [1, 2^40], got %llu", P,
                           (unsigned long long)d->paths);
    return VOLUX_OK;
}

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

static void build_column(void *user, int64_t index, int thread) {
    build_job *job = user;
    if (__atomic_load_n(&job->cancelled, __ATOMIC_RELAXED)) return;
    const volux_ambient_table_desc *d = job->d;
    const int nt = d->n_theta;
    const int is = (int)(index % d->n_sigma), ig = (int)(index / d->n_sigma);
    const double sigma = table_sigma(d, is), g = table_g(d, ig), albedo = d->albedo;
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
        size_t at = volux_ambient_table_index(d, i, is, ig);
        job->data[at] = (float)value;
        job->rel_error[at] = value > 0.0 ? (float)(se / value) : 0.0f;
    }
    int done = __atomic_add_fetch(&job->done, 1, __ATOMIC_RELAXED);
    if (job->ctx->progress && !__atomic_exchange_n(&job->busy, 1, __ATOMIC_ACQUIRE)) {
        double f = (double)done / ((double)d->n_sigma * (double)d->n_g);
        if (volux_progress(job->ctx, "ambient table", f < 1.0 ? f : 0.999))
            __atomic_store_n(&job->cancelled, 1, __ATOMIC_RELAXED);
        __atomic_store_n(&job->busy, 0, __ATOMIC_RELEASE);
    }
}

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static size_t table_values(const volux_ambient_table_desc *d) {
    return (size_t)d->n_theta * (size_t)d->n_sigma * (size_t)d->n_g;
}

void volux_ambient_table_free(volux_context *ctx, volux_ambient_table *t) {
    if (!t) return;
    size_t n = table_values(&t->desc) * sizeof(float);
    if (t->data) volux_free(ctx, t->data, n);
    if (t->rel_error) volux_free(ctx, t->rel_error, n);
    t->data = t->rel_error = NULL;
}

static volux_status table_alloc(volux_context *ctx, const volux_ambient_table_desc *d, int with_errors,
                                volux_ambient_table *t) {
    memset(t, 0, sizeof *t);
    t->desc = *d;
    size_t n = table_values(d) * sizeof(float);
    t->data = volux_malloc(ctx, n);
    if (with_errors) t->rel_error = volux_malloc(ctx, n);
    if (!t->data || (with_errors && !t->rel_error)) {
        volux_ambient_table_free(ctx, t);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "ambient table: out of memory (%zu bytes)", n);
    }
    return VOLUX_OK;
}

volux_status volux_ambient_table_build(volux_context *ctx, const volux_ambient_table_desc *d,
                                       volux_ambient_table *out) {
    volux_status st = volux_ambient_table_desc_validate(ctx, d);
    if (st) return st;
    double t0 = now_ms();
    volux_ambient_table t;
    if ((st = table_alloc(ctx, d, 1, &t))) return st;
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
    volux_parallel_for(threads, (int64_t)d->n_sigma * d->n_g, build_column, &job);
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

double volux_ambient_table_eval(const volux_ambient_table *t, double theta, double sigma, double g) {
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
    double lg[2];
    for (int k = 0; k < 2; k++) {
        int ig = i0[2] + k;
        double v00 = t->data[volux_ambient_table_index(d, i0[0], i0[1], ig)];
        double v10 = t->data[volux_ambient_table_index(d, i0[0] + 1, i0[1], ig)];
        double v01 = t->data[volux_ambient_table_index(d, i0[0], i0[1] + 1, ig)];
        double v11 = t->data[volux_ambient_table_index(d, i0[0] + 1, i0[1] + 1, ig)];
        double v = (v00 * (1 - f[0]) + v10 * f[0]) * (1 - f[1]) + (v01 * (1 - f[0]) + v11 * f[0]) * f[1];
        lg[k] = v;
    }
    if (lg[0] > 0.0 && lg[1] > 0.0) return exp(log(lg[0]) * (1 - f[2]) + log(lg[1]) * f[2]);
    return lg[0] * (1 - f[2]) + lg[1] * f[2];
}

static int cmp_float(const void *a, const void *b) {
    float x = *(const float *)a, y = *(const float *)b;
    return x < y ? -1 : x > y;
}

int volux_ambient_table_noise_summary(volux_context *ctx, const volux_ambient_table *t, double floor,
                                      volux_ambient_table_noise *out) {
    memset(out, 0, sizeof *out);
    if (!t->rel_error) return 0;
    size_t n = table_values(&t->desc), m = 0;
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

/* ------------------------------------------------------------------ file */

static uint64_t fnv1a(uint64_t h, const unsigned char *p, size_t n) {
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}
#define FNV_OFFSET 0xcbf29ce484222325ull

static void put_u32(unsigned char *p, uint32_t v) {
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static void put_u64(unsigned char *p, uint64_t v) {
    for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static void put_f64(unsigned char *p, double v) {
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    put_u64(p, u);
}
static uint32_t get_u32(const unsigned char *p) {
    uint32_t v = 0;
    for (int i = 0; i < 4; i++) v |= (uint32_t)p[i] << (8 * i);
    return v;
}
static uint64_t get_u64(const unsigned char *p) {
    uint64_t v = 0;
    for (int i = 0; i < 8; i++) v |= (uint64_t)p[i] << (8 * i);
    return v;
}
static double get_f64(const unsigned char *p) {
    uint64_t u = get_u64(p);
    double v;
    memcpy(&v, &u, sizeof v);
    return v;
}

static void encode_header(const volux_ambient_table *t, unsigned char h[TABLE_HEADER_BYTES]) {
    const volux_ambient_table_desc *d = &t->desc;
    memset(h, 0, TABLE_HEADER_BYTES);
    memcpy(h, TABLE_MAGIC, 8);
    put_u32(h + 8, VOLUX_AMBIENT_TABLE_VERSION);
    put_u32(h + 12, TABLE_HEADER_BYTES);
    put_u32(h + 16, (uint32_t)d->n_theta);
    put_u32(h + 20, (uint32_t)d->n_sigma);
    put_u32(h + 24, (uint32_t)d->n_g);
    put_u32(h + 28, t->rel_error ? TABLE_FLAG_ERRORS : 0u);
    put_f64(h + 32, 0.0);
    put_f64(h + 40, 3.14159265358979323846);
    put_f64(h + 48, 0.0);
    put_f64(h + 56, d->sigma_max);
    put_f64(h + 64, d->g_min);
    put_f64(h + 72, d->g_max);
    put_f64(h + 80, d->albedo);
    put_u64(h + 88, d->paths);
    put_u64(h + 96, d->seed);
    put_u32(h + 104, ESTIMATOR_ID);
    put_f64(h + 120, t->build_ms);
}

/* Writes n floats little-endian, updating the checksum. */
static int write_floats(FILE *f, const float *v, size_t n, uint64_t *h) {
    unsigned char buf[4096];
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, &v[i], 4);
        put_u32(buf + k, u);
        k += 4;
        if (k == sizeof buf || i + 1 == n) {
            *h = fnv1a(*h, buf, k);
            if (fwrite(buf, 1, k, f) != k) return 0;
            k = 0;
        }
    }
    return 1;
}

volux_status volux_ambient_table_save(volux_context *ctx, const volux_ambient_table *t, const char *path) {
    char tmp[4200];
    if (snprintf(tmp, sizeof tmp, "%s.tmp%ld", path, (long)getpid()) >= (int)sizeof tmp)
        return volux_error(ctx, VOLUX_ERR_WRITE, "%s: path too long", path);
    FILE *f = fopen(tmp, "wb");
    if (!f) return volux_error(ctx, VOLUX_ERR_WRITE, "%s: cannot write: %s", path, strerror(errno));
    unsigned char h[TABLE_HEADER_BYTES];
    encode_header(t, h);
    uint64_t sum = fnv1a(FNV_OFFSET, h, sizeof h);
    size_t n = table_values(&t->desc);
    int ok = fwrite(h, 1, sizeof h, f) == sizeof h && write_floats(f, t->data, n, &sum) &&
             (!t->rel_error || write_floats(f, t->rel_error, n, &sum));
    unsigned char tail[8];
    put_u64(tail, sum);
    ok = ok && fwrite(tail, 1, 8, f) == 8;
    ok = (fclose(f) == 0) && ok;
    if (!ok || rename(tmp, path) != 0) {
        int e = errno;
        remove(tmp);
        return volux_error(ctx, VOLUX_ERR_WRITE, "%s: cannot write: %s", path, strerror(e));
    }
    return VOLUX_OK;
}

volux_status volux_ambient_table_load(volux_context *ctx, const char *path, volux_ambient_table *out) {
    FILE *f = fopen(path, "rb");
    if (!f) return volux_error(ctx, VOLUX_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    unsigned char h[TABLE_HEADER_BYTES];
    volux_status st = VOLUX_OK;
    volux_ambient_table t;
    memset(&t, 0, sizeof t);
    if (fread(h, 1, sizeof h, f) != sizeof h || memcmp(h, TABLE_MAGIC, 8) != 0) {
        st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: not an ambient table (bad magic)", path);
        goto done;
    }
    if (get_u32(h + 8) != VOLUX_AMBIENT_TABLE_VERSION || get_u32(h + 12) != TABLE_HEADER_BYTES) {
        st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: unsupported ambient table version %u", path, get_u32(h + 8));
        goto done;
    }
    volux_ambient_table_desc d;
    memset(&d, 0, sizeof d);
    uint32_t dims[3] = {get_u32(h + 16), get_u32(h + 20), get_u32(h + 24)};
    for (int a = 0; a < 3; a++)
        if (dims[a] < 2 || dims[a] > VOLUX_AMBIENT_TABLE_MAX_DIM) {
            st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: table size %u is outside [2, %d]", path, dims[a],
                             VOLUX_AMBIENT_TABLE_MAX_DIM);
            goto done;
        }
    d.n_theta = (int)dims[0], d.n_sigma = (int)dims[1], d.n_g = (int)dims[2];
    uint32_t flags = get_u32(h + 28);
    double th0 = get_f64(h + 32), th1 = get_f64(h + 40), s0 = get_f64(h + 48);
    d.sigma_max = get_f64(h + 56);
    d.g_min = get_f64(h + 64);
    d.g_max = get_f64(h + 72);
    d.albedo = get_f64(h + 80);
    d.paths = get_u64(h + 88);
    d.seed = get_u64(h + 96);
    if ((flags & ~TABLE_FLAG_ERRORS) || th0 != 0.0 || fabs(th1 - 3.14159265358979323846) > 1e-12 || s0 != 0.0 ||
        get_u32(h + 104) != ESTIMATOR_ID) {
        st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: unsupported ambient table layout", path);
        goto done;
    }
    if (volux_ambient_table_desc_validate(ctx, &d)) {
        char why[512];
        snprintf(why, sizeof why, "%s", volux_context_error(ctx));
        st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: invalid header: %s", path, why);
        goto done;
    }
    if ((st = table_alloc(ctx, &d, (flags & TABLE_FLAG_ERRORS) != 0, &t))) goto done;
    t.build_ms = get_f64(h + 120);
    uint64_t sum = fnv1a(FNV_OFFSET, h, sizeof h);
    size_t n = table_values(&d);
    float *arrays[2] = {t.data, t.rel_error};
    for (int k = 0; k < 2 && arrays[k]; k++) {
        unsigned char buf[4096];
        size_t i = 0;
        while (i < n) {
            size_t m = n - i < sizeof buf / 4 ? n - i : sizeof buf / 4;
            if (fread(buf, 4, m, f) != m) {
                st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: truncated ambient table", path);
                goto done;
            }
            sum = fnv1a(sum, buf, 4 * m);
            for (size_t j = 0; j < m; j++) {
                uint32_t u = get_u32(buf + 4 * j);
                memcpy(&arrays[k][i + j], &u, 4);
            }
            i += m;
        }
    }
    unsigned char tail[8];
    if (fread(tail, 1, 8, f) != 8) {
        st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: truncated ambient table (no checksum)", path);
        goto done;
    }
    if (get_u64(tail) != sum) {
        st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: ambient table checksum mismatch (corrupt file)", path);
        goto done;
    }
    if (fgetc(f) != EOF) {
        st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: trailing bytes after the ambient table", path);
        goto done;
    }
    for (size_t i = 0; i < n; i++)
        if (!(t.data[i] >= 0.0f) || !isfinite(t.data[i])) {
            st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: ambient table value %zu is not a finite radiance", path, i);
            goto done;
        }
done:
    fclose(f);
    if (st) {
        volux_ambient_table_free(ctx, &t);
        return st;
    }
    *out = t;
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ cache */

int volux_ambient_table_cache_path(const volux_ambient_table_desc *d, char *buf, size_t size) {
    const char *xdg = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
    char dir[4096];
    if (xdg && *xdg) snprintf(dir, sizeof dir, "%s/volux", xdg);
    else if (home && *home) snprintf(dir, sizeof dir, "%s/.cache/volux", home);
    else return 0;
    int n = snprintf(buf, size, "%s/ambient-v%d-e%u-t%d-s%d-g%d-S%.9g-G%.9g_%.9g-a%.9g-p%llu-r%llu.vxat", dir,
                     VOLUX_AMBIENT_TABLE_VERSION, ESTIMATOR_ID, d->n_theta, d->n_sigma, d->n_g, d->sigma_max,
                     d->g_min, d->g_max, d->albedo, (unsigned long long)d->paths, (unsigned long long)d->seed);
    return n > 0 && (size_t)n < size;
}

/* mkdir -p of the folder part of `path`. */
static int make_parent_dirs(const char *path) {
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s", path) >= (int)sizeof tmp) return 0;
    char *slash = strrchr(tmp, '/');
    if (!slash) return 1;
    *slash = 0;
    for (char *p = tmp + 1; *p; p++) {
        if (*p != '/') continue;
        *p = 0;
        if (mkdir(tmp, 0755) != 0 && errno != EEXIST) return 0;
        *p = '/';
    }
    return mkdir(tmp, 0755) == 0 || errno == EEXIST;
}

static int same_desc(const volux_ambient_table_desc *a, const volux_ambient_table_desc *b) {
    return a->n_theta == b->n_theta && a->n_sigma == b->n_sigma && a->n_g == b->n_g &&
           a->sigma_max == b->sigma_max && a->g_min == b->g_min && a->g_max == b->g_max && a->albedo == b->albedo &&
           a->paths == b->paths && a->seed == b->seed;
}

volux_status volux_ambient_table_get(volux_context *ctx, const volux_ambient_table_desc *d, volux_ambient_table *out,
                                     int *built) {
    volux_status st = volux_ambient_table_desc_validate(ctx, d);
    if (st) return st;
    char path[4400];
    int have_path = volux_ambient_table_cache_path(d, path, sizeof path);
    if (have_path && access(path, R_OK) == 0) {
        volux_ambient_table t;
        if (volux_ambient_table_load(ctx, path, &t) == VOLUX_OK) {
            if (same_desc(&t.desc, d)) {
                if (built) *built = 0;
                *out = t;
                return VOLUX_OK;
            }
            volux_ambient_table_free(ctx, &t);
        }
        volux_context_clear_error(ctx); /* a stale or corrupt cache entry is rebuilt */
    }
    volux_ambient_table t;
    if ((st = volux_ambient_table_build(ctx, d, &t))) return st;
    if (have_path && make_parent_dirs(path)) volux_ambient_table_save(ctx, &t, path);
    volux_context_clear_error(ctx); /* an unwritable cache is not an error */
    if (built) *built = 1;
    *out = t;
    return VOLUX_OK;
}
