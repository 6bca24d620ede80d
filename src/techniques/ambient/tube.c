/* techniques/ambient/tube.c — see tube.h. */
#include <math.h>
#include <string.h>

#include "core/parallel.h"
#include "tube.h"

static volux_vec3 grid_hi(const scatter_grid *g) {
    return v3(g->lo.x + (float)(g->dims[0] - 1) * g->h[0], g->lo.y + (float)(g->dims[1] - 1) * g->h[1],
              g->lo.z + (float)(g->dims[2] - 1) * g->h[2]);
}

/* Distance from x (in the box) along `back` to the box surface. */
static inline float box_exit(volux_vec3 lo, volux_vec3 hi, volux_vec3 x, volux_vec3 back) {
    float t = INFINITY, xv[3] = {x.x, x.y, x.z}, b[3] = {back.x, back.y, back.z};
    float l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
    for (int a = 0; a < 3; a++) {
        float ta = INFINITY;
        if (b[a] > 0.0f) ta = (h[a] - xv[a]) / b[a];
        else if (b[a] < 0.0f) ta = (l[a] - xv[a]) / b[a];
        if (ta < t) t = ta;
    }
    return t > 0.0f ? t : 0.0f;
}

/* Trilinear read that touches only floor(u) and, if u is fractional,
 * floor(u) + 1 per axis: exactly the nodes the sweep order guarantees. */
static inline float sample_strict(const scatter_grid *g, volux_vec3 p) {
    float u[3] = {(p.x - g->lo.x) * g->inv_h[0], (p.y - g->lo.y) * g->inv_h[1], (p.z - g->lo.z) * g->inv_h[2]};
    int i0[3], i1[3];
    float f[3];
    for (int a = 0; a < 3; a++) {
        float m = (float)(g->dims[a] - 1), x = u[a] < 0.0f ? 0.0f : (u[a] > m ? m : u[a]);
        int i = (int)x;
        f[a] = x - (float)i;
        i0[a] = i;
        i1[a] = f[a] > 0.0f && i + 1 < g->dims[a] ? i + 1 : i;
    }
    size_t nx = (size_t)g->dims[0], ny = (size_t)g->dims[1];
#define AT(X, Y, Z) g->v[((size_t)(Z)*ny + (size_t)(Y)) * nx + (size_t)(X)]
    float c00 = AT(i0[0], i0[1], i0[2]) + (AT(i1[0], i0[1], i0[2]) - AT(i0[0], i0[1], i0[2])) * f[0];
    float c10 = AT(i0[0], i1[1], i0[2]) + (AT(i1[0], i1[1], i0[2]) - AT(i0[0], i1[1], i0[2])) * f[0];
    float c01 = AT(i0[0], i0[1], i1[2]) + (AT(i1[0], i0[1], i1[2]) - AT(i0[0], i0[1], i1[2])) * f[0];
    float c11 = AT(i0[0], i1[1], i1[2]) + (AT(i1[0], i1[1], i1[2]) - AT(i0[0], i1[1], i1[2])) * f[0];
#undef AT
    float c0 = c00 + (c10 - c00) * f[1], c1 = c01 + (c11 - c01) * f[1];
    return c0 + (c1 - c0) * f[2];
}

/* Travel direction at x and the distance δ back to the chain start. */
static inline volux_vec3 chain_start(const scatter_light *l, volux_vec3 lo, volux_vec3 hi, volux_vec3 x,
                                     float *delta) {
    volux_vec3 w;
    float dl = INFINITY;
    if (l->positional) {
        volux_vec3 d = v3_sub(x, l->pos);
        dl = v3_length(d);
        if (dl < 1e-20f) {
            *delta = 0.0f;
            return v3(0, 0, 1);
        }
        w = v3_scale(d, 1.0f / dl);
    } else {
        w = l->dir;
    }
    float t = box_exit(lo, hi, x, v3_scale(w, -1.0f));
    *delta = t < dl ? t : dl;
    return w;
}

float tube_step(const tube_input *in, const scatter_grid *V, const scatter_light *l) {
    float hmax = fmaxf(V->h[0], fmaxf(V->h[1], V->h[2]));
    float s = 2.0f * in->radius, smin;
    if (l->positional) {
        smin = 2.0f * 1.7320508f * hmax * 1.0001f;
    } else {
        float w[3] = {fabsf(l->dir.x), fabsf(l->dir.y), fabsf(l->dir.z)}, best = 0.0f;
        for (int a = 0; a < 3; a++)
            if (w[a] * V->inv_h[a] > best) best = w[a] * V->inv_h[a];
        smin = 1.0001f / best;
    }
    return s > smin ? s : smin;
}

typedef struct sweep {
    const tube_input *in;
    const scatter_light *l;
    scatter_grid *V;
    volux_vec3 lo, hi;
    float s, inv_r;
    /* directional: slice index along axis a, rows along b2, runs along b1 */
    int a, b1, b2, slice;
    /* point: shell ranges */
    int olo[3], ohi[3], ilo[3], ihi[3];
    /* directional fast path (ρ grid aligned with V): constant corner offsets
     * and weights of the two reads, and the box-exit reciprocals */
    int fast;
    ptrdiff_t off_v[8], off_r[8];
    float w_v[8], w_r[8];
    float exit_inv[3], exit_bound[3];
    int exit_use[3];
} sweep;

static inline void node(const sweep *sw, int i, int j, int k) {
    const tube_input *in = sw->in;
    scatter_grid *V = sw->V;
    volux_vec3 x = scatter_grid_node(V, i, j, k);
    float delta, v;
    volux_vec3 w = chain_start(sw->l, sw->lo, sw->hi, x, &delta);
    if (delta <= sw->s * 1.0001f) {
        /* Eq. 17 between the chain start (D = 0) and the first node a full
         * step on (D = κ of a sphere of radius s/2): D = (δ/s)·κ. Linear
         * in δ, so a homogeneous medium gives D exactly linear along every
         * chain and the sweep's interpolation exact. */
        float rho = scatter_grid_sample(in->rho, v3_madd(x, w, -0.5f * delta));
        v = delta / sw->s * tube_kappa(in, rho * 0.5f * sw->s * sw->inv_r);
    } else {
        /* Eq. 16 (as D = −ln V): the front from s back, through the
         * sphere between. */
        float half = 0.5f * sw->s, dy = delta - sw->s, back;
        float rho = scatter_grid_sample(in->rho, v3_madd(x, w, -half));
        volux_vec3 y = v3_madd(x, w, -sw->s);
        if (dy <= sw->s) {
            /* y is within the first step: evaluate it exactly rather than
             * interpolate the kink at the chain start (a cone around a
             * point light inside the volume). */
            float rho_y = scatter_grid_sample(in->rho, v3_madd(y, w, -0.5f * dy));
            back = dy / sw->s * tube_kappa(in, rho_y * half * sw->inv_r);
        } else {
            back = sample_strict(V, y);
        }
        v = back + tube_kappa(in, rho * half * sw->inv_r);
    }
    V->v[((size_t)k * (size_t)V->dims[1] + (size_t)j) * (size_t)V->dims[0] + (size_t)i] = v;
}

/* Directional light, node deep enough that y = x − sω lies more than one
 * step inside the box: both reads have node-independent corner offsets and
 * weights (the offset −sω is the same for every node). */
static inline int node_fast(const sweep *sw, int i, int j, int k) {
    scatter_grid *V = sw->V;
    volux_vec3 x = scatter_grid_node(V, i, j, k);
    float xv[3] = {x.x, x.y, x.z}, delta = INFINITY;
    for (int a = 0; a < 3; a++)
        if (sw->exit_use[a]) {
            float t = (sw->exit_bound[a] - xv[a]) * sw->exit_inv[a];
            if (t < delta) delta = t;
        }
    if (!(delta > 2.0f * sw->s * 1.0001f + 2.0f * (V->h[0] + V->h[1] + V->h[2]))) return 0;
    size_t n = ((size_t)k * (size_t)V->dims[1] + (size_t)j) * (size_t)V->dims[0] + (size_t)i;
    const float *D = V->v + n, *R = sw->in->rho->v + n;
    float back = 0.0f, rho = 0.0f;
    for (int c = 0; c < 8; c++) {
        back += sw->w_v[c] * D[sw->off_v[c]];
        rho += sw->w_r[c] * R[sw->off_r[c]];
    }
    V->v[n] = back + tube_kappa(sw->in, rho * 0.5f * sw->s * sw->inv_r);
    return 1;
}

static void slice_row(void *user, int64_t r, int thread) {
    (void)thread;
    const sweep *sw = user;
    int idx[3];
    idx[sw->a] = sw->slice;
    idx[sw->b2] = (int)r;
    for (int c = 0; c < sw->V->dims[sw->b1]; c++) {
        idx[sw->b1] = c;
        if (!sw->fast || !node_fast(sw, idx[0], idx[1], idx[2])) node(sw, idx[0], idx[1], idx[2]);
    }
}

/* Corner offsets/weights of a trilinear read displaced by `d` (world) from
 * any node of grid g; a zero fraction reads one corner only (never the node
 * beyond, which may be in the slice being written). */
static void displaced_corners(const scatter_grid *g, volux_vec3 d, ptrdiff_t off[8], float w[8]) {
    float u[3] = {d.x * g->inv_h[0], d.y * g->inv_h[1], d.z * g->inv_h[2]}, f[3];
    ptrdiff_t base[3], step[3] = {1, g->dims[0], (ptrdiff_t)g->dims[0] * g->dims[1]};
    for (int a = 0; a < 3; a++) {
        float fl = floorf(u[a]);
        base[a] = (ptrdiff_t)fl;
        f[a] = u[a] - fl;
    }
    for (int c = 0; c < 8; c++) {
        ptrdiff_t o = 0;
        float wc = 1.0f;
        for (int a = 0; a < 3; a++) {
            int hi = (c >> a) & 1;
            wc *= hi ? f[a] : 1.0f - f[a];
            o += (base[a] + (hi && f[a] > 0.0f ? 1 : 0)) * step[a];
        }
        off[c] = o;
        w[c] = wc;
    }
}

static void shell_plane(void *user, int64_t item, int thread) {
    (void)thread;
    const sweep *sw = user;
    int z = sw->olo[2] + (int)item;
    int zin = z >= sw->ilo[2] && z <= sw->ihi[2];
    for (int y = sw->olo[1]; y <= sw->ohi[1]; y++) {
        int yin = y >= sw->ilo[1] && y <= sw->ihi[1];
        if (zin && yin && sw->ilo[0] <= sw->ihi[0]) {
            for (int x = sw->olo[0]; x < sw->ilo[0]; x++) node(sw, x, y, z);
            for (int x = sw->ihi[0] + 1; x <= sw->ohi[0]; x++) node(sw, x, y, z);
        } else {
            for (int x = sw->olo[0]; x <= sw->ohi[0]; x++) node(sw, x, y, z);
        }
    }
}

void tube_march(const tube_input *in, const scatter_light *l, scatter_grid *V) {
    sweep sw;
    memset(&sw, 0, sizeof sw);
    sw.in = in, sw.l = l, sw.V = V;
    sw.lo = V->lo, sw.hi = grid_hi(V);
    sw.s = tube_step(in, V, l);
    sw.inv_r = in->radius > 0.0f ? 1.0f / in->radius : 0.0f;
    if (!l->positional) {
        float w[3] = {l->dir.x, l->dir.y, l->dir.z}, best = -1.0f;
        for (int a = 0; a < 3; a++)
            if (fabsf(w[a]) * V->inv_h[a] > best) best = fabsf(w[a]) * V->inv_h[a], sw.a = a;
        sw.b1 = sw.a == 0 ? 1 : 0;
        sw.b2 = sw.a == 2 ? 1 : 2;
        const scatter_grid *R = in->rho;
        sw.fast = R->dims[0] == V->dims[0] && R->dims[1] == V->dims[1] && R->dims[2] == V->dims[2] &&
                  R->lo.x == V->lo.x && R->lo.y == V->lo.y && R->lo.z == V->lo.z;
        if (sw.fast) {
            displaced_corners(V, v3_scale(l->dir, -sw.s), sw.off_v, sw.w_v);
            displaced_corners(R, v3_scale(l->dir, -0.5f * sw.s), sw.off_r, sw.w_r);
            float lo[3] = {sw.lo.x, sw.lo.y, sw.lo.z}, hi[3] = {sw.hi.x, sw.hi.y, sw.hi.z};
            for (int a = 0; a < 3; a++) {
                /* walking back along −ω towards the light */
                sw.exit_use[a] = w[a] != 0.0f;
                sw.exit_inv[a] = w[a] != 0.0f ? -1.0f / w[a] : 0.0f;
                sw.exit_bound[a] = w[a] < 0.0f ? hi[a] : lo[a];
            }
        }
        int n = V->dims[sw.a];
        for (int t = 0; t < n; t++) {
            sw.slice = w[sw.a] >= 0.0f ? t : n - 1 - t;
            volux_parallel_for(in->threads, V->dims[sw.b2], slice_row, &sw);
        }
        return;
    }
    float P[3] = {(l->pos.x - V->lo.x) * V->inv_h[0], (l->pos.y - V->lo.y) * V->inv_h[1],
                  (l->pos.z - V->lo.z) * V->inv_h[2]};
    float dmax = 0.0f;
    for (int a = 0; a < 3; a++) {
        float d = fmaxf(fabsf(P[a]), fabsf((float)(V->dims[a] - 1) - P[a]));
        if (d > dmax) dmax = d;
    }
    int K = (int)floorf(dmax);
    for (int k = 0; k <= K; k++) {
        int empty = 0;
        for (int a = 0; a < 3; a++) {
            int m = V->dims[a] - 1;
            int lo = (int)floorf(P[a] - (float)k - 1.0f) + 1, hi = (int)ceilf(P[a] + (float)k + 1.0f) - 1;
            int ilo = (int)floorf(P[a] - (float)k) + 1, ihi = (int)ceilf(P[a] + (float)k) - 1;
            sw.olo[a] = lo < 0 ? 0 : lo;
            sw.ohi[a] = hi > m ? m : hi;
            sw.ilo[a] = ilo < 0 ? 0 : ilo;
            sw.ihi[a] = ihi > m ? m : ihi;
            if (sw.olo[a] > sw.ohi[a]) empty = 1;
        }
        /* An inner range clipped to nothing on one axis means no node of
         * the plane row lies inside the inner box. */
        if (empty) continue;
        volux_parallel_for(in->threads, sw.ohi[2] - sw.olo[2] + 1, shell_plane, &sw);
    }
}

float tube_chain(const tube_input *in, const scatter_light *l, const scatter_grid *V, volux_vec3 x) {
    volux_vec3 lo = V->lo, hi = grid_hi(V);
    float s = tube_step(in, V, l), inv_r = in->radius > 0.0f ? 1.0f / in->radius : 0.0f, delta;
    volux_vec3 w = chain_start(l, lo, hi, x, &delta);
    float sum = 0.0f;
    while (delta > s * 1.0001f) {
        float rho = scatter_grid_sample(in->rho, v3_madd(x, w, -0.5f * s));
        sum += tube_kappa(in, rho * 0.5f * s * inv_r);
        x = v3_madd(x, w, -s);
        delta -= s;
    }
    float rho = scatter_grid_sample(in->rho, v3_madd(x, w, -0.5f * delta));
    return expf(-(sum + delta / s * tube_kappa(in, rho * 0.5f * s * inv_r)));
}
