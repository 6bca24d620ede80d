/*
 * techniques/sh/project.c — the per-voxel SH projection of L_mi
 * (Lindemann & Ropinski 2010, §4–4.2) and the scattering pass (Eq. 4).
 *
 * For every node of the coefficient grid (about 1/3 of the volume's
 * resolution, `downsample`) whose neighbourhood holds any opacity, rays
 * leave the node in a Fibonacci-lattice set of directions (stratified in
 * cos θ) over the adaptive region of §4: the hemisphere about the opacity
 * gradient widened by a below-surface angle α ∈ [0, π/2] into the full
 * sphere as the node becomes transparent or loses its gradient; the
 * estimator divides by the pdf 1/(2π(1 + sin α)). Each ray composites the
 * medium front to back (step size growing with distance after Ritschel
 * 2007, sampling a correspondingly coarser level of a pre-classified
 * extinction pyramid, early termination at `ray_opacity`) and yields the
 * transmittance T — and with colour bleeding T + C, C the composited
 * albedo·colour — which weights Y_j(ω) in the projection sum (Eq. 2).
 * Nodes with no opacity near them are skipped and hold the unoccluded
 * visibility.
 *
 * The scattering pass gathers L'_mi(x) = Σ K(|x − x_i|) o_i L_mi(x_i) /
 * Σ K(|x − x_i|) o_i over the neighbourhood N(x) (`neighbourhood` of the
 * largest extent), K the dipole R_d (Jensen et al. 2001) fitted by a sum
 * of Gaussians, so each term is three 1-D passes; o_i is the opacity of
 * the node, so light is gathered from the medium, not from the air.
 *
 * Every node's result is a pure function of the inputs: images do not
 * depend on the thread count.
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "sh.h"

#define SH_MIP_LEVELS 7 /* level 0 is the volume itself */

/* fminf/fmaxf are library calls without -ffinite-math-only */
static inline float minf(float a, float b) { return a < b ? a : b; }
static inline float maxf(float a, float b) { return a > b ? a : b; }
#define SQRT_4PI 3.5449077018110318f

typedef struct mip_level {
    int dims[3];
    float *data; /* comps floats per node: σt (, σt·albedo·c rgb) */
    size_t bytes;
} mip_level;

typedef struct proj_job {
    sh_state *st;
    const sh_projection_params *p;
    const volux_volume *v;
    const volux_transfer_lut *lut;
    float albedo;
    int comps;            /* 1 or 4 */
    int n_levels;
    mip_level level[SH_MIP_LEVELS];
    sh_grid grid;
    int rays, bands, nc, ch;
    float h, hc, tau_max, t_stop, growth, phi_offset;
    float offset;         /* surface_offset (cells) */
    float sp[3];          /* spacing per axis (world) */
    float *cell_sigma;    /* per coefficient cell: > 0 if any σt > 0 */
    int32_t *nonzero;     /* [lut.n + 1] prefix count of LUT entries with σt > 0 */
    int cells[3];
    float box_lo[3], box_hi[3]; /* fine-index box of the non-empty cells: rays end there */
    volux_storage storage;
    float *out;           /* ch·nc per node */
    float *weight;        /* opacity per node (scattering) */
    int done, busy, cancelled;
    int64_t items;
} proj_job;

/* ------------------------------------------------------------------ pyramid */

static inline void classify(const proj_job *j, float s, float out[4]) {
    float rgba[4];
    volux_lut_rgba(j->lut, s, rgba);
    out[0] = rgba[3];
    float a = j->albedo * rgba[3];
    out[1] = a * rgba[0], out[2] = a * rgba[1], out[3] = a * rgba[2];
}

typedef struct mip_job {
    proj_job *j;
    int l;          /* level being built (≥ 1) */
    float *scratch; /* level 1: one classified fine plane per thread */
    size_t plane;   /* floats per scratch plane */
} mip_job;

/* Node (i, j, k) of level l averages 3³ nodes of level l − 1 around
 * (2i, 2j, 2k) with tent weights (1/4, 1/2, 1/4): a low-pass before the
 * 2× decimation. Separable: the three planes are first combined along z
 * (for level 1 from the classified volume, into the thread's scratch). */
static void mip_slice(void *user, int64_t k, int thread) {
    mip_job *mj = user;
    proj_job *j = mj->j;
    const int l = mj->l, comps = j->comps;
    mip_level *dst = &j->level[l];
    const mip_level *src = &j->level[l - 1];
    const int *sd = l == 1 ? j->v->dims : src->dims;
    static const float w[3] = {0.25f, 0.5f, 0.25f};
    float *plane = mj->scratch + (size_t)thread * mj->plane;
    memset(plane, 0, sizeof(float) * (size_t)sd[0] * sd[1] * comps);
    for (int dz = -1; dz <= 1; dz++) {
        int z = 2 * (int)k + dz;
        z = z < 0 ? 0 : z >= sd[2] ? sd[2] - 1 : z;
        for (int y = 0; y < sd[1]; y++)
            for (int x = 0; x < sd[0]; x++) {
                float val[4];
                if (l == 1)
                    classify(j, volux_volume_raw_at(j->v, volux_volume_index(j->v, x, y, z)) + j->v->value_offset, val);
                else {
                    const float *p = src->data + comps * (((size_t)z * sd[1] + y) * sd[0] + x);
                    for (int c = 0; c < comps; c++) val[c] = p[c];
                }
                float *o = plane + comps * ((size_t)y * sd[0] + x);
                for (int c = 0; c < comps; c++) o[c] += w[dz + 1] * val[c];
            }
    }
    for (int jj = 0; jj < dst->dims[1]; jj++)
        for (int i = 0; i < dst->dims[0]; i++) {
            float acc[4] = {0, 0, 0, 0};
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int x = 2 * i + dx, y = 2 * jj + dy;
                    x = x < 0 ? 0 : x >= sd[0] ? sd[0] - 1 : x;
                    y = y < 0 ? 0 : y >= sd[1] ? sd[1] - 1 : y;
                    const float *p = plane + comps * ((size_t)y * sd[0] + x);
                    float wt = w[dx + 1] * w[dy + 1];
                    for (int c = 0; c < comps; c++) acc[c] += wt * p[c];
                }
            float *o = dst->data + comps * (((size_t)k * dst->dims[1] + jj) * dst->dims[0] + i);
            for (int c = 0; c < comps; c++) o[c] = acc[c];
        }
}

static volux_status build_pyramid(proj_job *j) {
    volux_context *ctx = j->st->rc.ctx;
    j->n_levels = 1;
    const int *d = j->v->dims;
    const int threads = j->st->rc.threads > 0 ? j->st->rc.threads : 1;
    size_t plane = (size_t)d[0] * d[1] * (size_t)j->comps, sbytes = plane * (size_t)threads * sizeof(float);
    float *scratch = volux_malloc(ctx, sbytes);
    if (!scratch) return volux_error(ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the extinction pyramid");
    for (int l = 1; l < SH_MIP_LEVELS; l++) {
        const int *prev = l == 1 ? d : j->level[l - 1].dims;
        mip_level *m = &j->level[l];
        size_t n = (size_t)j->comps;
        for (int a = 0; a < 3; a++) {
            m->dims[a] = (prev[a] - 1) / 2 + 1;
            n *= (size_t)m->dims[a];
        }
        if (m->dims[0] < 2 && m->dims[1] < 2 && m->dims[2] < 2) break;
        m->bytes = n * sizeof(float);
        if (!(m->data = volux_alloc_aligned(ctx, m->bytes))) {
            volux_free(ctx, scratch, sbytes);
            return volux_error(ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the extinction pyramid");
        }
        mip_job mj = {j, l, scratch, plane};
        volux_parallel_for(threads, m->dims[2], mip_slice, &mj);
        j->n_levels = l + 1;
    }
    volux_free(ctx, scratch, sbytes);
    return VOLUX_OK;
}

static void free_pyramid(proj_job *j) {
    for (int l = 1; l < SH_MIP_LEVELS; l++)
        if (j->level[l].data) volux_free_aligned(j->st->rc.ctx, j->level[l].data, j->level[l].bytes);
}

/* Trilinear lookup of level l ≥ 1 at fine index q. */
static inline void sample_level(const proj_job *j, int l, float qx, float qy, float qz, float out[4]) {
    const mip_level *m = &j->level[l];
    const float inv = 1.0f / (float)(1 << l);
    float x = qx * inv, y = qy * inv, z = qz * inv;
    int i = (int)x, k = (int)y, kk = (int)z;
    i = i > m->dims[0] - 2 ? (m->dims[0] > 1 ? m->dims[0] - 2 : 0) : i < 0 ? 0 : i;
    k = k > m->dims[1] - 2 ? (m->dims[1] > 1 ? m->dims[1] - 2 : 0) : k < 0 ? 0 : k;
    kk = kk > m->dims[2] - 2 ? (m->dims[2] > 1 ? m->dims[2] - 2 : 0) : kk < 0 ? 0 : kk;
    float fx = minf(maxf(x - i, 0.0f), 1.0f), fy = minf(maxf(y - k, 0.0f), 1.0f),
          fz = minf(maxf(z - kk, 0.0f), 1.0f);
    const size_t sx = m->dims[0] > 1 ? (size_t)j->comps : 0, sy = m->dims[1] > 1 ? (size_t)j->comps * m->dims[0] : 0,
                 sz = m->dims[2] > 1 ? (size_t)j->comps * m->dims[0] * m->dims[1] : 0;
    const float *p = m->data + (size_t)j->comps * (((size_t)kk * m->dims[1] + k) * m->dims[0] + i);
    for (int c = 0; c < j->comps; c++) {
        float n[8] = {p[c], p[sx + c], p[sy + c], p[sx + sy + c], p[sz + c], p[sx + sz + c], p[sy + sz + c],
                      p[sx + sy + sz + c]};
        out[c] = volux_lerp3(n, fx, fy, fz);
    }
}

/* ------------------------------------------------------------------ rays */

/* Marches from fine index q0 along world direction w; returns T and (with
 * bleeding) the composited colour C. Past the box of non-empty cells
 * nothing attenuates, so the ray ends there. */
static inline __attribute__((always_inline)) float march(const proj_job *j, volux_vec3 q0, volux_vec3 w, float C[3]) {
    const volux_volume *v = j->v;
    volux_vec3 dq = v3(w.x / j->sp[0], w.y / j->sp[1], w.z / j->sp[2]);
    float t_exit = INFINITY;
    const float qa[3] = {q0.x, q0.y, q0.z}, da[3] = {dq.x, dq.y, dq.z};
    for (int a = 0; a < 3; a++) {
        if (da[a] > 1e-12f) t_exit = minf(t_exit, (j->box_hi[a] - qa[a]) / da[a]);
        else if (da[a] < -1e-12f) t_exit = minf(t_exit, (j->box_lo[a] - qa[a]) / da[a]);
    }
    float t = 0.0f, s = j->h, tau = 0.0f, T = 1.0f, next = 2.0f * j->h;
    int l = 0;
    C[0] = C[1] = C[2] = 0.0f;
    while (t < t_exit) {
        float len = minf(s, t_exit - t), m = t + 0.5f * len, val[4] = {0, 0, 0, 0};
        float qx = q0.x + dq.x * m, qy = q0.y + dq.y * m, qz = q0.z + dq.z * m;
        if (l == 0) {
            float sv = volux_volume_sample_bricked(v, qx, qy, qz, j->storage);
            if (j->comps == 1) val[0] = volux_lut_sigma(j->lut, sv);
            else classify(j, sv, val);
        } else
            sample_level(j, l, qx, qy, qz, val);
        if (j->comps == 1) {
            tau += val[0] * len;
            /* the transmittance left (≈ 1 − ray_opacity), as the bleeding
             * branch returns: stopping must not darken (issue 28) */
            if (tau > j->tau_max) return expf(-tau);
        } else if (val[0] > 0.0f) {
            float a = 1.0f - expf(-val[0] * len), wgt = T * a / val[0];
            C[0] += wgt * val[1], C[1] += wgt * val[2], C[2] += wgt * val[3];
            T *= 1.0f - a;
            if (T < j->t_stop) return T;
        }
        t += len;
        s *= j->growth;
        while (s >= next && l + 1 < j->n_levels) l++, next *= 2.0f;
    }
    return j->comps == 1 ? expf(-tau) : T;
}

/* σt at fine index q; 0 outside the volume's box (the medium ends there:
 * a cut through dense material is a surface, as in sh.c's sigma_q). */
static inline float sigma_at(const proj_job *j, float x, float y, float z) {
    const int *d = j->v->dims;
    if (!(x >= 0.0f && y >= 0.0f && z >= 0.0f && x <= (float)(d[0] - 1) && y <= (float)(d[1] - 1) &&
          z <= (float)(d[2] - 1)))
        return 0.0f;
    return volux_lut_sigma(j->lut, volux_volume_sample_index(j->v, x, y, z));
}

static int node_active(const proj_job *j, int i, int k, int kk) {
    for (int dz = -1; dz <= 0; dz++)
        for (int dy = -1; dy <= 0; dy++)
            for (int dx = -1; dx <= 0; dx++) {
                int x = i + dx, y = k + dy, z = kk + dz;
                if (x < 0 || y < 0 || z < 0 || x >= j->cells[0] || y >= j->cells[1] || z >= j->cells[2]) continue;
                if (j->cell_sigma[((size_t)z * j->cells[1] + y) * j->cells[0] + x] > 0.0f) return 1;
            }
    return 0;
}

/* Returns the number of rays cast (0 for a skipped node). */
static int project_node(const proj_job *j, int i, int k, int kk, float *out, float *weight) {
    const int nc = j->nc, ch = j->ch, r = j->grid.ratio;
    const int *d = j->v->dims;
    memset(out, 0, sizeof(float) * (size_t)(ch * nc));
    *weight = 0.0f;
    if (!node_active(j, i, k, kk)) {
        for (int c = 0; c < ch; c++) out[c * nc] = SQRT_4PI; /* unoccluded: f = 1 */
        return 0;
    }
    volux_vec3 q = v3(minf((float)(i * r), (float)(d[0] - 1)), minf((float)(k * r), (float)(d[1] - 1)),
                      minf((float)(kk * r), (float)(d[2] - 1)));
    volux_vec3 q0 = q; /* where the rays start */
    /* Opacity of one coefficient voxel and its gradient (§4: τ and |∇τ|). */
    float o = 1.0f - expf(-sigma_at(j, q.x, q.y, q.z) * j->hc);
    float g[3], gs2 = 0.0f, smax = 0.0f;
    const float qa[3] = {q.x, q.y, q.z};
    for (int a = 0; a < 3; a++) {
        float lo[3] = {qa[0], qa[1], qa[2]}, hi[3] = {qa[0], qa[1], qa[2]};
        lo[a] -= 1.0f, hi[a] += 1.0f;
        float sl = sigma_at(j, lo[0], lo[1], lo[2]), sh = sigma_at(j, hi[0], hi[1], hi[2]);
        float ol = 1.0f - expf(-sl * j->hc);
        float oh = 1.0f - expf(-sh * j->hc);
        g[a] = (oh - ol) / (2.0f * j->sp[a]);
        float gs = (sh - sl) / (2.0f * j->sp[a]);
        gs2 += gs * gs;
        smax = maxf(smax, maxf(sl, sh));
    }
    /* surfaceness for issue 28's offsets, as the shading sample has it
     * (sh.c, near_surface): the jump of σt·h_c across one cell */
    const float oh = 1.0f - expf(-smax * j->h);
    const float wsurf = j->offset > 0.0f ? minf(sqrtf(gs2) * j->hc * j->hc, 1.0f) * oh * oh : 0.0f;
    volux_vec3 grad = v3(g[0], g[1], g[2]);
    float gl = v3_length(grad);
    volux_vec3 n = v3(0, 0, 1);
    float surface = 0.0f;
    if (gl > 0.0f) {
        n = v3_scale(grad, -1.0f / gl); /* towards lower opacity: out of the material */
        surface = minf(gl * j->hc, 1.0f);
    }
    /* Issue 28: on a surface the node's rays start on its empty side — up
     * to surface_offset·h_c outward along the gradient, where the medium
     * ends (per-voxel opacity below 1 %). Started inside, they measured the
     * node's depth in the material, which the coarse grid cannot resolve:
     * nodes a third of a cell apart read 0 and 1 and a trilinear lookup
     * drew the grid's planes as contour rings. The shading sample adds the
     * depth back from the fine volume (sh.c, near_surface). */
    if (wsurf > 1e-3f && gl > 0.0f) {
        float cap = j->offset * j->hc * wsurf, h = j->h;
        volux_vec3 dn = v3(n.x / j->sp[0], n.y / j->sp[1], n.z / j->sp[2]);
        for (float t = h; t <= cap + 1e-4f * h; t += h) {
            if (sigma_at(j, q.x + dn.x * (t - h), q.y + dn.y * (t - h), q.z + dn.z * (t - h)) * h < 0.01f) break;
            volux_vec3 e = v3(q.x + dn.x * t, q.y + dn.y * t, q.z + dn.z * t);
            if (e.x < 0.0f || e.y < 0.0f || e.z < 0.0f || e.x > (float)(d[0] - 1) || e.y > (float)(d[1] - 1) ||
                e.z > (float)(d[2] - 1))
                break;
            q0 = e;
        }
    }
    /* Below-surface angle α: 0 on an opaque surface, π/2 (full sphere) when
     * transparent or without a gradient. */
    float alpha = 0.5f * VOLUX_PI * (1.0f - o * surface), sa = sinf(alpha);
    volux_vec3 t, b;
    v3_basis(n, &t, &b);
    const int N = j->rays;
    const float wgt = 2.0f * VOLUX_PI * (1.0f + sa) / (float)N; /* 1/(N·pdf) */
    float y[SH_MAX_COEFFS];
    for (int s = 0; s < N; s++) {
        float u = 1.0f - (1.0f + sa) * ((float)s + 0.5f) / (float)N;
        float ph = (float)s * 0.6180339887f + j->phi_offset;
        ph = 2.0f * VOLUX_PI * (ph - floorf(ph));
        float sr = sqrtf(maxf(0.0f, 1.0f - u * u));
        volux_vec3 w = v3_add(v3_scale(n, u), v3_add(v3_scale(t, sr * cosf(ph)), v3_scale(b, sr * sinf(ph))));
        float C[3], T = march(j, q0, w, C);
        sh_eval(j->bands, w, y);
        if (ch == 1) {
            float f = wgt * T;
            for (int c = 0; c < nc; c++) out[c] += f * y[c];
        } else
            for (int c = 0; c < 3; c++) {
                float f = wgt * (T + C[c]);
                for (int m = 0; m < nc; m++) out[c * nc + m] += f * y[m];
            }
    }
    /* Issue 28: the region the rays leave out (the cap about −n beyond the
     * below-surface ring) holds V = wsurf instead of 0 on a surface: the
     * shading sample's half-space term K_D takes the material below the
     * surface from the fine volume (K = 1 − w there), so the grid keeps
     * only the smooth far field, not a hemisphere step whose 4-band
     * projection rings past the terminator. Cap integral of Y_lm about −n
     * by Funk–Hecke: 2π ∫_{sin α}^1 P_l(t) dt · Y_lm(−n). */
    if (wsurf > 1e-3f && gl > 0.0f && sa < 1.0f) {
        const float a1 = sa, a2 = a1 * a1, a3 = a2 * a1, a4 = a2 * a2;
        const float cl[SH_MAX_BANDS] = {1.0f - a1, 0.5f * (1.0f - a2), 0.5f * (a1 - a3),
                                        0.5f * (-0.25f - 1.25f * a4 + 1.5f * a2)};
        sh_eval(j->bands, v3_scale(n, -1.0f), y);
        for (int l = 0; l < j->bands; l++)
            for (int m = l * l; m < (l + 1) * (l + 1); m++) {
                float f = wsurf * 2.0f * VOLUX_PI * cl[l] * y[m];
                for (int c = 0; c < ch; c++) out[c * nc + m] += f;
            }
    }
    *weight = o;
    return N;
}

static void project_row(void *user, int64_t item, int thread) {
    (void)thread;
    proj_job *j = user;
    if (__atomic_load_n(&j->cancelled, __ATOMIC_RELAXED)) return;
    const sh_grid *g = &j->grid;
    int k = (int)(item % g->dims[1]), kk = (int)(item / g->dims[1]);
    const size_t stride = (size_t)j->ch * j->nc;
    uint64_t rays = 0;
    for (int i = 0; i < g->dims[0]; i++) {
        size_t at = ((size_t)kk * g->dims[1] + k) * g->dims[0] + i;
        rays += (uint64_t)project_node(j, i, k, kk, j->out + at * stride, j->weight + at);
    }
    __atomic_add_fetch(&j->st->rays_cast, rays, __ATOMIC_RELAXED);
    int done = __atomic_add_fetch(&j->done, 1, __ATOMIC_RELAXED);
    volux_context *ctx = j->st->rc.ctx;
    if (ctx->progress && !__atomic_exchange_n(&j->busy, 1, __ATOMIC_ACQUIRE)) {
        double f = (double)done / (double)j->items;
        if (volux_progress(ctx, "sh projection", f < 1.0 ? f : 0.999))
            __atomic_store_n(&j->cancelled, 1, __ATOMIC_RELAXED);
        __atomic_store_n(&j->busy, 0, __ATOMIC_RELEASE);
    }
}

/* Max σt per coefficient cell (fine nodes [c·r, (c+1)·r] inclusive). */
static void cell_slice(void *user, int64_t z, int thread) {
    (void)thread;
    proj_job *j = user;
    const int r = j->grid.ratio, *d = j->v->dims;
    for (int y = 0; y < j->cells[1]; y++)
        for (int x = 0; x < j->cells[0]; x++) {
            float lo = INFINITY, hi = -INFINITY;
            for (int kk = (int)z * r; kk <= (int)(z + 1) * r && kk < d[2]; kk++)
                for (int k = y * r; k <= (y + 1) * r && k < d[1]; k++)
                    for (int i = x * r; i <= (x + 1) * r && i < d[0]; i++) {
                        float s = volux_volume_raw_at(j->v, volux_volume_index(j->v, i, k, kk));
                        lo = minf(lo, s), hi = maxf(hi, s);
                    }
            /* σt > 0 anywhere on the LUT nodes bracketing [lo, hi] (the
             * majorant grid's test), from the prefix count of non-zero
             * entries: O(1) per cell */
            float v = 0.0f;
            if (lo <= hi) {
                const volux_transfer_lut *lut = j->lut;
                float off = j->v->value_offset;
                int i0 = (int)floorf((lo + off - lut->s_min) * lut->inv_ds), i1 = (int)ceilf((hi + off - lut->s_min) * lut->inv_ds);
                i0 = i0 < 0 ? 0 : i0 > lut->n - 1 ? lut->n - 1 : i0;
                i1 = i1 < i0 ? i0 : i1 > lut->n - 1 ? lut->n - 1 : i1;
                v = (float)(j->nonzero[i1 + 1] - j->nonzero[i0]);
            }
            j->cell_sigma[((size_t)z * j->cells[1] + y) * j->cells[0] + x] = v;
        }
}

/* ------------------------------------------------------------------ scattering (Eq. 4) */

typedef struct blur_job {
    const sh_grid *g;
    int axis, C, radius;
    const float *kern; /* radius + 1 taps */
    const float *in;
    float *out;
} blur_job;

static void blur_line(void *user, int64_t line, int thread) {
    (void)thread;
    const blur_job *b = user;
    const int *d = b->g->dims, a = b->axis, C = b->C, R = b->radius;
    int o1 = a == 0 ? 1 : 0, o2 = a == 2 ? 1 : 2; /* the other two axes */
    int c1 = (int)(line % d[o1]), c2 = (int)(line / d[o1]);
    size_t st[3] = {1, (size_t)d[0], (size_t)d[0] * d[1]};
    size_t base = (size_t)c1 * st[o1] + (size_t)c2 * st[o2], step = st[a] * (size_t)C;
    const float *in = b->in + base * C;
    float *out = b->out + base * C;
    float acc[64];
    for (int i = 0; i < d[a]; i++) {
        for (int c = 0; c < C; c++) acc[c] = b->kern[0] * in[(size_t)i * step + c];
        for (int t = 1; t <= R; t++) {
            float w = b->kern[t];
            if (i - t >= 0) {
                const float *p = in + (size_t)(i - t) * step;
                for (int c = 0; c < C; c++) acc[c] += w * p[c];
            }
            if (i + t < d[a]) {
                const float *p = in + (size_t)(i + t) * step;
                for (int c = 0; c < C; c++) acc[c] += w * p[c];
            }
        }
        for (int c = 0; c < C; c++) out[(size_t)i * step + c] = acc[c];
    }
}

/* L'_mi of Eq. 4 (normalised, see the file comment) from `in` (ch × nc per
 * node) into `out` (3 × nc per node). */
static volux_status scatter(sh_state *st, const sh_projection_params *p, const sh_grid *g, const float gsp[3],
                            const float *in, int ch, int nc, const float *weight, float *out) {
    volux_context *ctx = st->rc.ctx;
    const sh_dipole_material *mat = sh_dipole_at(p->scatter_preset);
    volux_vec3 lo, hi;
    volux_volume_bounds(st->rc.volume, &lo, &hi);
    float extent = maxf(hi.x - lo.x, maxf(hi.y - lo.y, hi.z - lo.z));
    double radius = p->neighbourhood * extent, smin = 0.5 * fmin(gsp[0], fmin(gsp[1], gsp[2]));
    if (radius < 2.0 * smin) radius = 2.0 * smin;
    sh_gauss_fit fit;
    sh_dipole_fit(mat, p->scatter_scale, radius, smin, 0.5 * smin, fmax(radius / 2.0, smin * 1.01), &fit);
    const int C = nc + 1;
    size_t nodes = g->nodes, buf = nodes * (size_t)C * sizeof(float), den_bytes = nodes * 3 * sizeof(float);
    float *A = volux_alloc_aligned(ctx, buf), *B = volux_alloc_aligned(ctx, buf), *den = volux_alloc_aligned(ctx, den_bytes);
    int taps_max = 0;
    for (int a = 0; a < 3; a++) {
        int r = (int)ceilf((float)radius / gsp[a]);
        if (r > g->dims[a] - 1) r = g->dims[a] - 1;
        if (r > taps_max) taps_max = r;
    }
    size_t kb = 3 * (size_t)(taps_max + 1) * sizeof(float);
    float *kern = volux_malloc(ctx, kb);
    volux_status s = VOLUX_OK;
    if (!A || !B || !den || !kern) {
        s = volux_error(ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the scattering pass");
        goto done;
    }
    memset(out, 0, nodes * 3 * (size_t)nc * sizeof(float));
    for (int c = 0; c < ch; c++)
        for (int k = 0; k < SH_DIPOLE_GAUSSIANS; k++) {
            float wk[3];
            int any = 0;
            for (int o = 0; o < 3; o++) {
                wk[o] = (ch == 1 || o == c) ? (float)fit.w[o][k] : 0.0f;
                any |= wk[o] > 0.0f;
            }
            if (!any) continue;
            /* weighted input: o_i·L_mi, o_i */
            for (size_t n = 0; n < nodes; n++) {
                const float *src = in + n * (size_t)ch * nc + (size_t)c * nc;
                float *dst = A + n * C;
                for (int m = 0; m < nc; m++) dst[m] = weight[n] * src[m];
                dst[nc] = weight[n];
            }
            float *src = A, *dst = B;
            for (int a = 0; a < 3; a++) {
                int r = (int)ceilf((float)radius / gsp[a]);
                if (r > g->dims[a] - 1) r = g->dims[a] - 1;
                float *kr = kern + a * (taps_max + 1);
                for (int t = 0; t <= r; t++) {
                    double x = t * gsp[a];
                    kr[t] = x <= radius ? (float)exp(-x * x / (2.0 * fit.s[k] * fit.s[k])) : 0.0f;
                }
                blur_job bj = {g, a, C, r, kr, src, dst};
                int o1 = a == 0 ? 1 : 0, o2 = a == 2 ? 1 : 2;
                volux_parallel_for(st->rc.threads, (int64_t)g->dims[o1] * g->dims[o2], blur_line, &bj);
                float *t = src;
                src = dst, dst = t;
            }
            for (size_t n = 0; n < nodes; n++) {
                const float *bl = src + n * C;
                for (int o = 0; o < 3; o++) {
                    if (wk[o] <= 0.0f) continue;
                    float *dst3 = out + n * 3 * (size_t)nc + (size_t)o * nc;
                    for (int m = 0; m < nc; m++) dst3[m] += wk[o] * bl[m];
                    den[n * 3 + o] += wk[o] * bl[nc];
                }
            }
        }
    /* normalise; where nothing was gathered keep L_mi */
    for (size_t n = 0; n < nodes; n++)
        for (int o = 0; o < 3; o++) {
            float dn = den[n * 3 + o], *dst3 = out + n * 3 * (size_t)nc + (size_t)o * nc;
            const float *src = in + n * (size_t)ch * nc + (size_t)(ch == 1 ? 0 : o) * nc;
            if (dn > 1e-20f)
                for (int m = 0; m < nc; m++) dst3[m] /= dn;
            else
                for (int m = 0; m < nc; m++) dst3[m] = src[m];
        }
done:
    if (A) volux_free_aligned(ctx, A, buf);
    if (B) volux_free_aligned(ctx, B, buf);
    if (den) volux_free_aligned(ctx, den, den_bytes);
    volux_free(ctx, kern, kb);
    return s;
}

/* ------------------------------------------------------------------ the pass */

static void layout_for(const sh_projection_params *p, sh_layout *lay) {
    memset(lay, 0, sizeof *lay);
    int rgb = p->bleeding || p->scattering;
    lay->channels = rgb ? 3 : 1;
    lay->ycc = rgb && p->chroma_bands > 0;
    for (int c = 0; c < lay->channels; c++) {
        int b = lay->ycc && c > 0 ? (p->chroma_bands < p->bands ? p->chroma_bands : p->bands) : p->bands;
        lay->bands[c] = b;
        lay->offset[c] = lay->stride;
        lay->stride += b * b;
    }
}

volux_status sh_project(sh_state *st, const sh_projection_params *p, int ratio, int rays, sh_grid *grid,
                        sh_layout *lay, float **out, size_t *out_bytes) {
    volux_context *ctx = st->rc.ctx;
    const volux_volume *v = st->rc.volume;
    proj_job j;
    memset(&j, 0, sizeof j);
    j.st = st;
    j.p = p;
    j.v = v;
    j.lut = st->rc.lut;
    j.albedo = st->rc.albedo;
    j.comps = p->bleeding ? 4 : 1;
    j.storage = v->storage;
    j.rays = rays;
    j.bands = p->bands;
    j.nc = p->bands * p->bands;
    j.ch = p->bleeding ? 3 : 1;
    j.h = st->rc.min_spacing;
    j.hc = (float)ratio * j.h;
    j.tau_max = -logf(1.0f - p->ray_opacity);
    j.t_stop = 1.0f - p->ray_opacity;
    j.growth = p->step_growth;
    j.offset = p->surface_offset;
    /* one fixed offset of the lattice (not the render seed: a seed edit
     * must not change the cached projection) */
    volux_rng rng = volux_rng_make(0x5348, 0, 1, 0);
    j.phi_offset = volux_rng_float(&rng);
    double sp[3];
    volux_volume_spacing(v, sp);
    for (int a = 0; a < 3; a++) j.sp[a] = (float)sp[a];
    sh_grid g;
    g.ratio = ratio;
    g.nodes = 1;
    for (int a = 0; a < 3; a++) {
        g.dims[a] = (v->dims[a] - 1 + ratio - 1) / ratio + 1;
        j.cells[a] = g.dims[a] > 1 ? g.dims[a] - 1 : 1;
        g.nodes *= (size_t)g.dims[a];
    }
    j.grid = g;
    j.items = (int64_t)g.dims[1] * g.dims[2];
    sh_layout L;
    layout_for(p, &L);
    const size_t proj_stride = (size_t)j.ch * j.nc;
    size_t proj_bytes = g.nodes * proj_stride * sizeof(float), w_bytes = g.nodes * sizeof(float);
    size_t cell_bytes = (size_t)j.cells[0] * j.cells[1] * j.cells[2] * sizeof(float);
    size_t final_bytes = g.nodes * (size_t)L.stride * sizeof(float);
    float *scat = NULL, *final = NULL;
    size_t nz_bytes = 0;
    size_t scat_bytes = p->scattering ? g.nodes * 3 * (size_t)j.nc * sizeof(float) : 0;
    volux_status s = VOLUX_OK;
    j.out = volux_alloc_aligned(ctx, proj_bytes);
    j.weight = volux_alloc_aligned(ctx, w_bytes);
    j.cell_sigma = volux_alloc_aligned(ctx, cell_bytes);
    if (!j.out || !j.weight || !j.cell_sigma) {
        s = volux_error(ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the coefficient volume (%zu nodes)", g.nodes);
        goto done;
    }
    if ((s = build_pyramid(&j))) goto done;
    nz_bytes = ((size_t)j.lut->n + 1) * sizeof(int32_t);
    if (!(j.nonzero = volux_malloc(ctx, nz_bytes))) {
        s = volux_error(ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the coefficient grid's occupancy");
        goto done;
    }
    j.nonzero[0] = 0;
    for (int i = 0; i < j.lut->n; i++) j.nonzero[i + 1] = j.nonzero[i] + (j.lut->sigma_t[i] > 0.0f);
    volux_parallel_for(st->rc.threads, j.cells[2], cell_slice, &j);
    int lo[3] = {j.cells[0], j.cells[1], j.cells[2]}, hi[3] = {-1, -1, -1};
    for (int z = 0; z < j.cells[2]; z++)
        for (int y = 0; y < j.cells[1]; y++)
            for (int x = 0; x < j.cells[0]; x++)
                if (j.cell_sigma[((size_t)z * j.cells[1] + y) * j.cells[0] + x] > 0.0f) {
                    const int c[3] = {x, y, z};
                    for (int a = 0; a < 3; a++) {
                        if (c[a] < lo[a]) lo[a] = c[a];
                        if (c[a] > hi[a]) hi[a] = c[a];
                    }
                }
    for (int a = 0; a < 3; a++) {
        j.box_lo[a] = hi[a] < 0 ? 0.0f : (float)(lo[a] * ratio);
        j.box_hi[a] = hi[a] < 0 ? 0.0f : minf((float)((hi[a] + 1) * ratio), (float)(v->dims[a] - 1));
    }
    volux_parallel_for(st->rc.threads, j.items, project_row, &j);
    if (j.cancelled) {
        s = volux_error(ctx, VOLUX_ERR_CANCELLED, "sh: projection cancelled");
        goto done;
    }
    volux_progress(ctx, "sh projection", 1.0);
    const float *rgb = j.out; /* ch × nc per node */
    int rgb_ch = j.ch;
    if (p->scattering) {
        if (!(scat = volux_alloc_aligned(ctx, scat_bytes))) {
            s = volux_error(ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the scattered coefficients");
            goto done;
        }
        float gsp[3] = {j.sp[0] * ratio, j.sp[1] * ratio, j.sp[2] * ratio};
        if ((s = scatter(st, p, &g, gsp, j.out, j.ch, j.nc, j.weight, scat))) goto done;
        rgb = scat;
        rgb_ch = 3;
    }
    /* Pack into the stored layout (Y/Cb/Cr keeps fewer chroma bands, §5). */
    if (!(final = volux_alloc_aligned(ctx, final_bytes))) {
        s = volux_error(ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the coefficient volume (%zu nodes)", g.nodes);
        goto done;
    }
    for (size_t n = 0; n < g.nodes; n++) {
        const float *src = rgb + n * (size_t)rgb_ch * j.nc;
        float *dst = final + n * (size_t)L.stride;
        for (int c = 0; c < L.channels; c++) {
            int nb = L.bands[c] * L.bands[c];
            for (int m = 0; m < nb; m++) {
                float val;
                if (!L.ycc) val = src[(size_t)(rgb_ch == 1 ? 0 : c) * j.nc + m];
                else {
                    float R = src[m], G = src[j.nc + m], B = src[2 * j.nc + m];
                    float Y = 0.2126f * R + 0.7152f * G + 0.0722f * B;
                    val = c == 0 ? Y : c == 1 ? (B - Y) / 1.8556f : (R - Y) / 1.5748f;
                }
                dst[L.offset[c] + m] = val;
            }
        }
    }
    *grid = g;
    *lay = L;
    *out = final;
    *out_bytes = final_bytes;
    final = NULL;
done:
    free_pyramid(&j);
    if (j.out) volux_free_aligned(ctx, j.out, proj_bytes);
    if (j.weight) volux_free_aligned(ctx, j.weight, w_bytes);
    if (j.cell_sigma) volux_free_aligned(ctx, j.cell_sigma, cell_bytes);
    volux_free(ctx, j.nonzero, nz_bytes);
    if (scat) volux_free_aligned(ctx, scat, scat_bytes);
    if (final) volux_free_aligned(ctx, final, final_bytes);
    return s;
}
