/*
 * techniques/scatter/envdir.h — environment light that keeps its direction
 * in `ao` and `ambient` (issue 28).
 *
 * Before, both saw an environment only as its mean radiance times an
 * isotropic occlusion A(x); A → 0 inside dense material, so a dense surface
 * facing a bright sky rendered black. Here the environment is reduced to K
 * directions d_k (the Fibonacci set and cells of volux_environment_cells,
 * shared with `single` and `lightvol`), each carrying the irradiance E_k of
 * its cell (Σ_k E_k = ∫ L dω), and the technique's transmittance towards
 * each direction, W_k(x), is kept per cache node:
 *
 *  - `ao` (scatter_dirw): W_k itself, one byte per direction and node
 *    (local, over its radius); a sample sums E_k p_g(−d_k·ω) W_k exactly.
 *  - `ambient` (scatter_dirvis): W_k is tube-marched from the box and read
 *    where d_k enters the ambient sphere; a sample would need the table
 *    L̃o(θ_k, ρ, albedo·c) per direction, so W is kept in its first two
 *    spherical-harmonic bands,
 *
 *        V(x, d) ≈ w0(x) + w1(x)·d,   w0 = (1/K) Σ_k W_k,   w1 = (3/K) Σ_k W_k d_k
 *
 *    (the least-squares l ≤ 1 fit over K equal-area cells: an occlusion and
 *    a "bent normal"), and the in-scattered light is linear in (w0, w1):
 *
 *        L_s(x, ω) = w0(x) M0(ω) + w1(x)·M1(ω),
 *        M0(ω) = Σ_k E_k f(d_k, ω),  M1(ω) = Σ_k E_k f(d_k, ω) d_k
 *
 *    with f the table and M tabulated over the direction to the camera ω
 *    on a small octahedral grid (bilinear, with a folded border so it is
 *    continuous over the sphere; ambient.c adds the σ̃t and albedo axes).
 *    A sample reads four grids and the table, whatever K.
 *
 * Edits: the volume work (W_k) depends on the medium and the directions
 * only; a colour, intensity, rotation or map edit of the environment only
 * recomputes E_k (memoised cell integrals) and the M table.
 */
#ifndef VOLUX_SCATTER_ENVDIR_H
#define VOLUX_SCATTER_ENVDIR_H

#include <math.h>

#include "grid.h"
#include "render/lights.h"

#define SCATTER_ENV_MAX_DIRS 64
/* Octahedral grid of the M tables: N×N texels plus a one-texel border. */
#define SCATTER_ENV_OCT 16
#define SCATTER_ENV_OCT_TEXELS ((SCATTER_ENV_OCT + 2) * (SCATTER_ENV_OCT + 2))

typedef struct scatter_env {
    int K;                                 /* directions; 0: no environment light enabled */
    volux_vec3 from[SCATTER_ENV_MAX_DIRS]; /* unit, towards the sky cell                  */
    volux_vec3 E[SCATTER_ENV_MAX_DIRS];    /* irradiance of the cell                      */
    volux_env_cells_cache memo;            /* cell integrals (colour/intensity edits hit it) */
} scatter_env;

/* E_k of the light list's enabled environments over K directions (K = 0,
 * or no environment light: e->K = 0; from[0 .. K) is set in any case). */
void scatter_env_prepare(scatter_env *e, const volux_light_list *ls, int K);

/* V(x, d) ≈ w0 + w1·d at the nodes of four grids over the volume box. */
typedef struct scatter_dirvis {
    scatter_grid c[4]; /* w0, w1.x, w1.y, w1.z */
} scatter_dirvis;

volux_status scatter_dirvis_alloc(volux_context *ctx, const volux_volume *v, float scale, scatter_dirvis *vis);
void scatter_dirvis_free(volux_context *ctx, scatter_dirvis *vis);
size_t scatter_dirvis_bytes(const scatter_dirvis *vis);
/* All four grids to 0. */
void scatter_dirvis_zero(int threads, scatter_dirvis *vis);

/* Transmittance towards unit direction `dir` at world point `node`. */
typedef float (*scatter_dirvis_fn)(const void *user, volux_vec3 node, volux_vec3 dir);
/* Adds direction `dir`'s term of the fit, W·(1/K, 3d/K), at every node
 * (parallel over z slices; the order of the K calls fixes the bits). */
void scatter_dirvis_add(int threads, scatter_dirvis *vis, int K, volux_vec3 dir, scatter_dirvis_fn fn,
                        const void *user);

/* (w0, w1) at world point p (trilinear, clamped to the box). */
static inline void scatter_dirvis_sample(const scatter_dirvis *vis, volux_vec3 p, float w[4]) {
    const scatter_grid *g = &vis->c[0];
    int nx = g->dims[0], ny = g->dims[1], nz = g->dims[2];
    float x = (p.x - g->lo.x) * g->inv_h[0], y = (p.y - g->lo.y) * g->inv_h[1], z = (p.z - g->lo.z) * g->inv_h[2];
    float mx = (float)(nx - 1), my = (float)(ny - 1), mz = (float)(nz - 1);
    x = x < 0.0f ? 0.0f : (x > mx ? mx : x);
    y = y < 0.0f ? 0.0f : (y > my ? my : y);
    z = z < 0.0f ? 0.0f : (z > mz ? mz : z);
    int i = (int)x, j = (int)y, k = (int)z;
    if (i > nx - 2) i = nx > 1 ? nx - 2 : 0;
    if (j > ny - 2) j = ny > 1 ? ny - 2 : 0;
    if (k > nz - 2) k = nz > 1 ? nz - 2 : 0;
    float fx = x - (float)i, fy = y - (float)j, fz = z - (float)k;
    size_t sx = nx > 1 ? 1 : 0, sy = ny > 1 ? (size_t)nx : 0, sz = nz > 1 ? (size_t)nx * (size_t)ny : 0;
    size_t o = ((size_t)k * (size_t)ny + (size_t)j) * (size_t)nx + (size_t)i;
    for (int c = 0; c < 4; c++) {
        const float *b = vis->c[c].v + o;
        float c00 = b[0] + (b[sx] - b[0]) * fx, c10 = b[sy] + (b[sy + sx] - b[sy]) * fx;
        float c01 = b[sz] + (b[sz + sx] - b[sz]) * fx, c11 = b[sz + sy] + (b[sz + sy + sx] - b[sz + sy]) * fx;
        float c0 = c00 + (c10 - c00) * fy, c1 = c01 + (c11 - c01) * fy;
        w[c] = c0 + (c1 - c0) * fz;
    }
}

/* V(x, d) from (w0, w1), clamped to [0, 1] (for a single direction: a
 * direct light). */
static inline float scatter_dirvis_eval(const float w[4], volux_vec3 d) {
    float v = w[0] + w[1] * d.x + w[2] * d.y + w[3] * d.z;
    return v < 0.0f ? 0.0f : (v > 1.0f ? 1.0f : v);
}

/* ---------------------------------------------------------------- per-direction table (`ao`) */

/* W_k(x) for every direction k at the nodes of a grid over the volume box,
 * quantised to bytes (W·255; K padded to a multiple of 16 so a sample's
 * trilinear read is whole vectors): no fit, so thin structures (a plate
 * blocks a band of directions, which w0 + w1·d cannot represent) and
 * half-spaces keep their shape. K bytes per node. */
typedef struct scatter_dirw {
    int dims[3];
    volux_vec3 lo;
    float h[3], inv_h[3];
    int K, stride; /* directions; bytes per node (K rounded up to 16) */
    unsigned char *v;
    size_t bytes;
} scatter_dirw;

volux_status scatter_dirw_alloc(volux_context *ctx, const volux_volume *v, float scale, int K, scatter_dirw *g);
void scatter_dirw_free(volux_context *ctx, scatter_dirw *g);
/* (`ao` fills the bytes itself: techniques/ao/ao.c, the directions of a
 * node as SIMD lanes.) */

/* W_k at world point p (trilinear, clamped to the box) into W[0 .. stride). */
static inline void scatter_dirw_sample(const scatter_dirw *g, volux_vec3 p, float *W) {
    int nx = g->dims[0], ny = g->dims[1], nz = g->dims[2];
    float x = (p.x - g->lo.x) * g->inv_h[0], y = (p.y - g->lo.y) * g->inv_h[1], z = (p.z - g->lo.z) * g->inv_h[2];
    float mx = (float)(nx - 1), my = (float)(ny - 1), mz = (float)(nz - 1);
    x = x < 0.0f ? 0.0f : (x > mx ? mx : x);
    y = y < 0.0f ? 0.0f : (y > my ? my : y);
    z = z < 0.0f ? 0.0f : (z > mz ? mz : z);
    int i = (int)x, j = (int)y, k = (int)z;
    if (i > nx - 2) i = nx > 1 ? nx - 2 : 0;
    if (j > ny - 2) j = ny > 1 ? ny - 2 : 0;
    if (k > nz - 2) k = nz > 1 ? nz - 2 : 0;
    float fx = x - (float)i, fy = y - (float)j, fz = z - (float)k;
    size_t S = (size_t)g->stride;
    size_t sx = nx > 1 ? S : 0, sy = ny > 1 ? (size_t)nx * S : 0, sz = nz > 1 ? (size_t)nx * (size_t)ny * S : 0;
    const unsigned char *b = g->v + (((size_t)k * (size_t)ny + (size_t)j) * (size_t)nx + (size_t)i) * S;
    const float s = 1.0f / 255.0f;
    const float w[8] = {(1 - fx) * (1 - fy) * (1 - fz) * s, fx * (1 - fy) * (1 - fz) * s, (1 - fx) * fy * (1 - fz) * s,
                        fx * fy * (1 - fz) * s,       (1 - fx) * (1 - fy) * fz * s, fx * (1 - fy) * fz * s,
                        (1 - fx) * fy * fz * s,       fx * fy * fz * s};
    const unsigned char *c[8] = {b, b + sx, b + sy, b + sy + sx, b + sz, b + sz + sx, b + sz + sy, b + sz + sy + sx};
    for (size_t q = 0; q < S; q++)
        W[q] = w[0] * c[0][q] + w[1] * c[1][q] + w[2] * c[2][q] + w[3] * c[3][q] + w[4] * c[4][q] + w[5] * c[5][q] +
               w[6] * c[6][q] + w[7] * c[7][q];
}

/* ---------------------------------------------------------------- octahedral M tables */

/* Direction of point (a, b) of the octahedral square [−1, 1]² (not equal
 * area: cheap both ways). Points outside the square are folded back onto
 * it first (an edge is its own mirror: (1 + e, b) is (1 − e, −b)), so a
 * border texel holds the value of its neighbour across the fold. */
static inline volux_vec3 scatter_oct_dir(float a, float b) {
    for (int pass = 0; pass < 2; pass++) {
        if (a > 1.0f) a = 2.0f - a, b = -b;
        else if (a < -1.0f) a = -2.0f - a, b = -b;
        if (b > 1.0f) b = 2.0f - b, a = -a;
        else if (b < -1.0f) b = -2.0f - b, a = -a;
    }
    float z = 1.0f - fabsf(a) - fabsf(b), x = a, y = b;
    if (z < 0.0f) {
        x = copysignf(1.0f - fabsf(b), a);
        y = copysignf(1.0f - fabsf(a), b);
    }
    return v3_normalize(v3(x, y, z));
}

/* World direction of table texel (i, j) ∈ [0, N + 2)² (texel centres; the
 * first and last row/column are the folded border). */
static inline volux_vec3 scatter_oct_texel_dir(int i, int j) {
    const float s = 2.0f / (float)SCATTER_ENV_OCT;
    return scatter_oct_dir(-1.0f + ((float)i - 0.5f) * s, -1.0f + ((float)j - 0.5f) * s);
}

/* The four texels around direction d (unit) and their bilinear weights. */
static inline void scatter_oct_lookup(volux_vec3 d, int idx[4], float wt[4]) {
    float n = fabsf(d.x) + fabsf(d.y) + fabsf(d.z);
    float a = d.x / n, b = d.y / n;
    if (d.z < 0.0f) {
        float ta = copysignf(1.0f - fabsf(b), a), tb = copysignf(1.0f - fabsf(a), b);
        a = ta, b = tb;
    }
    const float half = 0.5f * (float)SCATTER_ENV_OCT;
    float u = (a + 1.0f) * half + 0.5f, v = (b + 1.0f) * half + 0.5f; /* texel-centre units, border = 0 */
    int i = (int)u, j = (int)v;
    if (i > SCATTER_ENV_OCT) i = SCATTER_ENV_OCT;
    if (j > SCATTER_ENV_OCT) j = SCATTER_ENV_OCT;
    if (i < 0) i = 0;
    if (j < 0) j = 0;
    float fu = u - (float)i, fv = v - (float)j;
    fu = fu < 0.0f ? 0.0f : (fu > 1.0f ? 1.0f : fu);
    fv = fv < 0.0f ? 0.0f : (fv > 1.0f ? 1.0f : fv);
    const int W = SCATTER_ENV_OCT + 2;
    idx[0] = j * W + i, idx[1] = idx[0] + 1, idx[2] = idx[0] + W, idx[3] = idx[2] + 1;
    wt[0] = (1.0f - fu) * (1.0f - fv), wt[1] = fu * (1.0f - fv), wt[2] = (1.0f - fu) * fv, wt[3] = fu * fv;
}

#endif
