/*
 * techniques/lightvol/propagate.c — coherence-based light propagation (§4,
 * §6) and selective light updates with the cost estimate of §5.
 *
 * A pass sweeps the slices of one propagation group (an axis and a sign)
 * and carries every light of the pass in its own pair of 2-D slice buffers
 * (read = previous slice, write = current slice). Per voxel and light, the
 * light is fetched from the previous slice where the line towards the light
 * crosses it (Ropinski et al. 2010), attenuated over that segment, and the
 * forward-scattered part is gathered from a cone around that point. The
 * lights' values, weighted by their Eq. 5 contribution factors for the
 * group and signed (+1 add, −1 remove), are summed and added to the
 * illumination volume slice by slice.
 *
 * What the buffers hold, so that light is never created where none arrives:
 *   directional: irradiance E along the ray (W/m²), initialised with the
 *                light's E0 (constant projection, Fig. 5 left);
 *   point/spot:  intensity J along the ray (W/sr), initialised with the
 *                projection I·cone(θ) of the light on the first slice
 *                (Fig. 5 middle/right); the voxel receives J / r².
 * Both are constant along a ray in empty space and are only ever multiplied
 * by transmittances ≤ 1 or averaged, so they never exceed the unoccluded
 * value. The per-voxel formula of §4, l_i = (1 − α)·l_{i−1} + α·c, is read
 * as l_i = l_{i−1}·(1 − α + α·f·a·c): the absorbed-or-scattered fraction α
 * is lost except the forward-scattered part f·albedo·colour, taken in its
 * continuous (step-size independent) form
 *     l_i = l_{i−1} · exp(−len·(σt − f·σs)),   σs = albedo·c·σt,
 * with the forward-scattered share gathered from the cone.
 *
 * Built with -fno-math-errno -fno-trapping-math (CMakeLists.txt): the
 * sweeps never look at errno or FP exception flags, and without them the
 * compiler can use sqrt instructions and if-convert lv_exp_neg and the Eq. 5
 * factors, so the row loops vectorise (same operations, same rounding).
 *
 * Slices are parallel within themselves (chunks of rows, one phase of
 * volux_parallel_phases per slice: one parallel region per sweep);
 * every voxel depends only on the complete previous slice, so the result is
 * the same for any thread count.
 */

#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "core/vecmath.h"
#include "lightvol.h"
#include "sweep.h"

/* ------------------------------------------------------------ allocation */

static void free_scratch(lightvol_state *st) {
    if (st->slices) volux_free_aligned(st->ctx, st->slices, st->slices_bytes);
    if (st->med) volux_free_aligned(st->ctx, st->med, st->med_bytes);
    if (st->rows) volux_free_aligned(st->ctx, st->rows, st->rows_bytes);
    if (st->stage) volux_free_aligned(st->ctx, st->stage, st->stage_bytes);
    st->slices = st->med = st->rows = st->stage = NULL;
    st->slices_bytes = st->med_bytes = st->rows_bytes = st->stage_bytes = 0;
    st->slice_cap = 0;
    st->rows_threads = 0;
}

void volux_lightvol_free_buffers(lightvol_state *st) {
    free_scratch(st);
    if (st->vol) volux_free_aligned(st->ctx, st->vol, st->vol_bytes);
    if (st->medium) volux_free_aligned(st->ctx, st->medium, st->medium_bytes);
    st->vol = st->medium = NULL;
    st->vol_bytes = st->medium_bytes = 0;
    if (st->lut_nz) volux_free(st->ctx, st->lut_nz, st->lut_nz_bytes);
    st->lut_nz = NULL;
    st->lut_nz_bytes = 0;
}

size_t volux_lightvol_scratch_bytes(const lightvol_state *st) {
    return st->slices_bytes + st->med_bytes + st->rows_bytes + st->stage_bytes;
}

volux_status volux_lightvol_alloc(lightvol_state *st) {
    const volux_volume *v = st->volume;
    static const char axis_name[3] = {'x', 'y', 'z'};
    int m[3];
    for (int a = 0; a < 3; a++) {
        if (v->dims[a] < 2)
            return volux_error(st->ctx, VOLUX_ERR_INVALID,
                               "lightvol: the volume needs at least 2 nodes along each axis (%c has %d)", axis_name[a],
                               v->dims[a]);
        m[a] = (int)ceil((double)v->dims[a] * (double)st->p.scale[a] - 1e-6);
        if (m[a] < 2) m[a] = 2;
        if (m[a] > v->dims[a]) m[a] = v->dims[a];
    }
    size_t n = (size_t)m[0] * (size_t)m[1] * (size_t)m[2], bytes;
    int ch = st->p.directional ? 6 : 3;
    if (!volux_mul_size(n, (size_t)ch * sizeof(float), &bytes) || bytes > volux_context_max_bytes(st->ctx))
        return volux_error(st->ctx, VOLUX_ERR_LIMIT,
                           "lightvol: a %dx%dx%d illumination volume exceeds the memory cap (lower techniques.lightvol.scale)",
                           m[0], m[1], m[2]);
    volux_lightvol_free_buffers(st);
    st->vol = volux_alloc_aligned(st->ctx, bytes);
    if (!st->vol)
        return volux_error(st->ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for a %dx%dx%d illumination volume",
                           m[0], m[1], m[2]);
    st->vol_bytes = bytes;
    st->ch = ch;
    st->on_grid = 1;
    volux_vec3 lo, hi;
    volux_volume_bounds(v, &lo, &hi);
    st->lo = lo;
    float ext[3] = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
    for (int a = 0; a < 3; a++) {
        st->dims[a] = m[a];
        st->spacing[a] = ext[a] / (float)(m[a] - 1);
        st->data_to_ill[a] = (float)(m[a] - 1) / (float)(v->dims[a] - 1);
        if (m[a] != v->dims[a]) st->on_grid = 0;
    }
    if (!st->on_grid) {
        size_t mb = n * 4 * sizeof(float);
        st->medium = volux_alloc_aligned(st->ctx, mb);
        if (!st->medium) return volux_error(st->ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the medium grid");
        st->medium_bytes = mb;
    }
    size_t a01 = (size_t)m[0] * (size_t)m[1], a02 = (size_t)m[0] * (size_t)m[2], a12 = (size_t)m[1] * (size_t)m[2];
    st->area = a01 > a02 ? a01 : a02;
    if (a12 > st->area) st->area = a12;
    st->valid = 0;
    return VOLUX_OK;
}

/* ---------------------------------------------------------------- medium */

/* σt and σs = albedo·c·σt (rgb) of data node `idx` (DESIGN §2). */
static inline void classify(const lightvol_state *st, size_t idx, float out[4]) {
    const volux_volume *v = st->volume;
    if (st->have_u8) {
        memcpy(out, &st->class_u8[4 * ((const uint8_t *)v->data)[idx]], 4 * sizeof(float));
        return;
    }
    float rgba[4];
    volux_lut_rgba(st->lut, volux_volume_raw_at(v, idx) + v->value_offset, rgba);
    out[0] = rgba[3];
    for (int c = 0; c < 3; c++) out[1 + c] = st->albedo * rgba[c] * rgba[3];
}

typedef struct medium_job {
    lightvol_state *st;
    int *lo[3], *hi[3];  /* per illumination node: data index box (inclusive) */
    int *first, *last;   /* per data x: illumination x nodes whose box holds it */
    float *tmp;
    size_t tmp_stride;
} medium_job;

/* Box mean of σt and σs over the data nodes nearest to each illumination
 * node of slice k: optical depth along an axis is preserved, so thin walls
 * still cast shadows at coarse scales. */
static void medium_slice(void *user, int64_t k64, int thread) {
    medium_job *J = user;
    lightvol_state *st = J->st;
    const volux_volume *v = st->volume;
    int k = (int)k64, m0 = st->dims[0], m1 = st->dims[1], nx = v->dims[0], ny = v->dims[1];
    float *A = J->tmp + (size_t)thread * J->tmp_stride; /* ny × m0 × 4 */
    memset(A, 0, (size_t)ny * (size_t)m0 * 4 * sizeof(float));
    for (int z = J->lo[2][k]; z <= J->hi[2][k]; z++)
        for (int y = 0; y < ny; y++) {
            size_t base = volux_volume_index(v, 0, y, z);
            float *Ay = A + (size_t)y * (size_t)m0 * 4;
            for (int x = 0; x < nx; x++) {
                float c[4];
                classify(st, base + (size_t)x, c);
                for (int i = J->first[x]; i <= J->last[x]; i++)
                    for (int q = 0; q < 4; q++) Ay[4 * i + q] += c[q];
            }
        }
    for (int j = 0; j < m1; j++)
        for (int i = 0; i < m0; i++) {
            float s[4] = {0, 0, 0, 0};
            for (int y = J->lo[1][j]; y <= J->hi[1][j]; y++)
                for (int q = 0; q < 4; q++) s[q] += A[((size_t)y * (size_t)m0 + (size_t)i) * 4 + (size_t)q];
            float cnt = (float)(J->hi[0][i] - J->lo[0][i] + 1) * (float)(J->hi[1][j] - J->lo[1][j] + 1) *
                        (float)(J->hi[2][k] - J->lo[2][k] + 1);
            float *out = st->medium + (((size_t)k * (size_t)m1 + (size_t)j) * (size_t)m0 + (size_t)i) * 4;
            for (int q = 0; q < 4; q++) out[q] = s[q] / cnt;
        }
}

volux_status volux_lightvol_build_medium(lightvol_state *st) {
    const volux_volume *v = st->volume;
    const volux_transfer_lut *lut = st->lut;
    size_t nzb = ((size_t)lut->n + 1) * sizeof(int);
    if (st->lut_nz_bytes != nzb) {
        if (st->lut_nz) volux_free(st->ctx, st->lut_nz, st->lut_nz_bytes);
        st->lut_nz = volux_malloc(st->ctx, nzb);
        st->lut_nz_bytes = st->lut_nz ? nzb : 0;
        if (!st->lut_nz) return volux_error(st->ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the TF range table");
    }
    st->lut_nz[0] = 0;
    for (int i = 0; i < lut->n; i++) st->lut_nz[i + 1] = st->lut_nz[i] + (lut->sigma_t[i] > 0.0f);
    st->have_u8 = v->storage == VOLUX_STORE_U8;
    if (st->have_u8)
        for (int i = 0; i < 256; i++) {
            float rgba[4];
            volux_lut_rgba(st->lut, (float)i + v->value_offset, rgba);
            st->class_u8[4 * i] = rgba[3];
            for (int c = 0; c < 3; c++) st->class_u8[4 * i + 1 + c] = st->albedo * rgba[c] * rgba[3];
        }
    if (st->on_grid) return VOLUX_OK;
    medium_job J;
    memset(&J, 0, sizeof J);
    J.st = st;
    int threads = st->threads > 0 ? st->threads : 1;
    size_t ints = 0;
    for (int a = 0; a < 3; a++) ints += 2 * (size_t)st->dims[a];
    ints += 2 * (size_t)v->dims[0];
    J.tmp_stride = (size_t)v->dims[1] * (size_t)st->dims[0] * 4;
    size_t tmp_bytes = J.tmp_stride * sizeof(float) * (size_t)threads;
    int *ib = volux_malloc(st->ctx, ints * sizeof(int));
    J.tmp = volux_alloc_aligned(st->ctx, tmp_bytes);
    if (!ib || !J.tmp) {
        volux_free(st->ctx, ib, ints * sizeof(int));
        if (J.tmp) volux_free_aligned(st->ctx, J.tmp, tmp_bytes);
        return volux_error(st->ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the medium grid");
    }
    int *p = ib;
    for (int a = 0; a < 3; a++) {
        J.lo[a] = p, p += st->dims[a];
        J.hi[a] = p, p += st->dims[a];
        double step = 1.0 / (double)st->data_to_ill[a], hw = 0.5 * step;
        for (int i = 0; i < st->dims[a]; i++) {
            double c = (double)i * step;
            int lo = (int)ceil(c - hw - 1e-6), hi = (int)floor(c + hw + 1e-6);
            if (lo < 0) lo = 0;
            if (hi > v->dims[a] - 1) hi = v->dims[a] - 1;
            if (hi < lo) hi = lo;
            J.lo[a][i] = lo;
            J.hi[a][i] = hi;
        }
    }
    J.first = p, p += v->dims[0];
    J.last = p;
    for (int x = 0; x < v->dims[0]; x++) {
        J.first[x] = st->dims[0];
        J.last[x] = -1;
    }
    for (int i = 0; i < st->dims[0]; i++)
        for (int x = J.lo[0][i]; x <= J.hi[0][i]; x++) {
            if (i < J.first[x]) J.first[x] = i;
            if (i > J.last[x]) J.last[x] = i;
        }
    volux_parallel_for(threads, st->dims[2], medium_slice, &J);
    volux_free(st->ctx, ib, ints * sizeof(int));
    volux_free_aligned(st->ctx, J.tmp, tmp_bytes);
    return VOLUX_OK;
}

/* ---------------------------------------------------------------- lights */

static inline float spot_factor(const lv_source *s, float cos_angle) {
    /* volux_spot_falloff with the cosines precomputed */
    if (cos_angle >= s->cos_fall) return 1.0f;
    if (cos_angle <= s->cos_cone) return 0.0f;
    float t = (cos_angle - s->cos_cone) / (s->cos_fall - s->cos_cone);
    return t * t * (3.0f - 2.0f * t);
}

/* Value a light sends along the ray through world point p, before 1/r²:
 * directional E0, positional I·cone(θ). */
static inline void ray_value(const lv_source *s, volux_vec3 p, float out[3]) {
    float f = 1.0f;
    if (s->kind == LV_POSITIONAL && s->spot) {
        volux_vec3 d = v3_sub(p, s->pos);
        float r2 = v3_dot(d, d);
        f = spot_factor(s, r2 > 0.0f ? v3_dot(d, s->dir) / sqrtf(r2) : 1.0f);
    }
    out[0] = s->power.x * f;
    out[1] = s->power.y * f;
    out[2] = s->power.z * f;
}

static inline float rmin2(const lightvol_state *st) {
    float h = 0.5f * fminf(st->spacing[0], fminf(st->spacing[1], st->spacing[2]));
    return h * h;
}

void volux_lightvol_unoccluded(const lightvol_state *st, const lv_source *s, volux_vec3 p, float out[3]) {
    ray_value(s, p, out);
    if (s->kind == LV_POSITIONAL) {
        volux_vec3 d = v3_sub(p, s->pos);
        float r2 = fmaxf(v3_dot(d, d), rmin2(st));
        for (int c = 0; c < 3; c++) out[c] /= r2;
    }
}

/* Groups a positional light needs: every group that is one of the two
 * closest faces for the local direction at some point of the box it lights
 * (weights are evaluated per voxel during the sweep). Sampled on a 9³ grid
 * over the box plus, for spots, the cone axis and rim. A group missed by the
 * sampling can only own a thin sliver near a group boundary, where its
 * factor is close to 0 (the factors are continuous). */
static unsigned positional_groups(const lightvol_state *st, const lv_source *s) {
    const volux_volume *v = st->volume;
    volux_vec3 lo, hi;
    volux_volume_bounds(v, &lo, &hi);
    unsigned mask = 0;
    float w[LV_GROUPS];
    const int N = 9;
    for (int k = 0; k < N; k++)
        for (int j = 0; j < N; j++)
            for (int i = 0; i < N; i++) {
                volux_vec3 p = v3(lo.x + (hi.x - lo.x) * (float)i / (float)(N - 1),
                                  lo.y + (hi.y - lo.y) * (float)j / (float)(N - 1),
                                  lo.z + (hi.z - lo.z) * (float)k / (float)(N - 1));
                volux_vec3 d = v3_sub(p, s->pos);
                float r = v3_length(d);
                if (!(r > 1e-6f)) continue;
                d = v3_scale(d, 1.0f / r);
                if (s->spot && spot_factor(s, v3_dot(d, s->dir)) <= 0.0f) continue;
                mask |= lv_face_weights(d, w);
            }
    if (s->spot) {
        volux_vec3 t, b;
        v3_basis(s->dir, &t, &b);
        float ang = acosf(clampf(s->cos_cone, -1.0f, 1.0f)) * 0.999f;
        for (int q = 0; q <= 8; q++) {
            volux_vec3 d = s->dir;
            if (q) {
                float phi = (float)(q - 1) * (VOLUX_PI / 4.0f);
                d = v3_normalize(v3_add(v3_scale(s->dir, cosf(ang)),
                                        v3_add(v3_scale(t, sinf(ang) * cosf(phi)), v3_scale(b, sinf(ang) * sinf(phi)))));
            }
            float t0, t1;
            if (v3_ray_box(s->pos, d, lo, hi, &t0, &t1)) mask |= lv_face_weights(d, w);
        }
    }
    return mask;
}

int volux_lightvol_source(const lightvol_state *st, const volux_light_desc *d, lv_source *s) {
    memset(s, 0, sizeof *s);
    if (!d || !d->enabled) return 0;
    switch (d->type) {
    case VOLUX_LIGHT_DIRECTIONAL:
        s->kind = LV_DIRECTIONAL;
        s->power = v3_scale(d->color, d->irradiance);
        s->dir = v3_normalize(d->direction);
        break;
    case VOLUX_LIGHT_POINT:
    case VOLUX_LIGHT_SPOT:
        s->kind = LV_POSITIONAL;
        s->power = v3_scale(d->color, d->intensity);
        s->pos = d->position;
        if (d->type == VOLUX_LIGHT_SPOT) {
            s->spot = 1;
            s->dir = v3_normalize(d->direction);
            s->cos_cone = cosf(d->cone_angle_deg * VOLUX_PI / 180.0f);
            s->cos_fall = cosf(d->falloff_angle_deg * VOLUX_PI / 180.0f);
        }
        break;
    case VOLUX_LIGHT_SPHERE:
        /* Seen from outside, a sphere of radiance L and radius r sends the
         * intensity of a point: I = L·π·r² (as `shaded` does). */
        s->kind = LV_POSITIONAL;
        s->power = v3_scale(d->color, d->radiance * VOLUX_PI * d->radius * d->radius);
        s->pos = d->position;
        break;
    default: return 0; /* environment: not propagated (docs) */
    }
    if (!(s->power.x > 0.0f || s->power.y > 0.0f || s->power.z > 0.0f)) return 0;
    if (s->kind == LV_DIRECTIONAL) s->groups = lv_face_weights(s->dir, s->weight);
    else s->groups = positional_groups(st, s);
    return s->groups != 0;
}

/* ---------------------------------------------------------------- passes */

typedef struct lv_pass {
    int g, first, n; /* group, range in the index list */
} lv_pass;

/* Plans the passes for `items`: coherent = one pass per non-empty group
 * (split at max_per_pass lights), groups in axis order so same-axis groups
 * are consecutive (§4); sequential = one pass per light and group. Returns
 * the number of passes; fills passes/idx when non-NULL. */
static int plan(const lv_item *items, int n, int coherent, int max_per_pass, lv_pass *passes, int *idx) {
    int np = 0, ni = 0;
    if (coherent) {
        for (int g = 0; g < LV_GROUPS; g++) {
            int in_pass = 0;
            for (int i = 0; i < n; i++) {
                if (!(items[i].src.groups & (1u << g))) continue;
                if (in_pass == 0 || in_pass == max_per_pass) {
                    if (passes) passes[np] = (lv_pass){g, ni, 0};
                    np++;
                    in_pass = 0;
                }
                if (passes) {
                    idx[ni] = i;
                    passes[np - 1].n++;
                }
                ni++;
                in_pass++;
            }
        }
    } else {
        for (int i = 0; i < n; i++)
            for (int g = 0; g < LV_GROUPS; g++) {
                if (!(items[i].src.groups & (1u << g))) continue;
                if (passes) {
                    passes[np] = (lv_pass){g, ni, 1};
                    idx[ni] = i;
                }
                np++;
                ni++;
            }
    }
    return np;
}

/* Estimated work of a plan in units of one pass's per-voxel fixed cost
 * (reading and classifying a slice, writing the volume): each pass costs
 * 1 plus, per light entry, the entry's weight (directional; point, spot,
 * sphere: per-voxel geometry, Eq. 5 factors and gathers). Calibrated on the
 * engine and bonsai at scale 1 (bench/lightvol, docs/techniques/lightvol.md):
 * with the portable kernel a directional entry costs ~0.3 of the fixed part
 * and a positional one ~4; with the AVX2 kernels ~0.2 and ~0.65 without
 * forward scattering, ~0.5 and 1.0–1.5 with it (f = 0.5, 10° cone: four
 * medium planes, the cone's taps; a close spot, sampled more densely along
 * its oblique segments, at the top). Near a tie either choice costs the
 * same, so the weights err towards the entire update. */
typedef struct lv_work_weights {
    double dir, pos;
} lv_work_weights;
static const lv_work_weights LV_WORK_SCALAR = {0.3, 4.0}, LV_WORK_SIMD = {0.2, 0.7},
                             LV_WORK_SIMD_FORWARD = {0.5, 1.4};

static double plan_work(const lv_item *items, int n, int coherent, int max_per_pass, lv_work_weights w) {
    double work = 0.0;
    if (coherent) {
        for (int g = 0; g < LV_GROUPS; g++) {
            int count = 0;
            for (int i = 0; i < n; i++) {
                if (!(items[i].src.groups & (1u << g))) continue;
                count++;
                work += items[i].src.kind == LV_DIRECTIONAL ? w.dir : w.pos;
            }
            work += (double)((count + max_per_pass - 1) / max_per_pass);
        }
    } else {
        for (int i = 0; i < n; i++)
            for (int g = 0; g < LV_GROUPS; g++)
                if (items[i].src.groups & (1u << g))
                    work += 1.0 + (items[i].src.kind == LV_DIRECTIONAL ? w.dir : w.pos);
    }
    return work;
}

/* pass state (lv_sweep, lv_entry, lv_tap) and the SIMD kernels: sweep.h */

static inline lv_tap make_tap(float du, float dv) {
    float fu = floorf(du), fv = floorf(dv);
    lv_tap t;
    t.di = (int)fu;
    t.dj = (int)fv;
    float a = du - fu, b = dv - fv;
    t.w00 = (1.0f - a) * (1.0f - b);
    t.w10 = a * (1.0f - b);
    t.w01 = (1.0f - a) * b;
    t.w11 = a * b;
    return t;
}

static inline void extend(lv_entry *e, lv_tap t) {
    if (t.di < e->di_min) e->di_min = t.di;
    if (t.di > e->di_max) e->di_max = t.di;
    if (t.dj < e->dj_min) e->dj_min = t.dj;
    if (t.dj > e->dj_max) e->dj_max = t.dj;
}

static inline int sub_count(float ou, float ov) {
    float m = fmaxf(fabsf(ou), fabsf(ov));
    return m <= 1.0f ? 1 : (m >= (float)LV_MAX_SUB ? LV_MAX_SUB : (int)ceilf(m));
}

/* World position of slice coordinates (x, y) on plane k. */
static inline volux_vec3 slice_world(const lv_sweep *J, float x, float y, int k) {
    const lightvol_state *st = J->st;
    float p[3];
    p[J->a] = (float)k * st->spacing[J->a];
    p[J->au] = x * st->spacing[J->au];
    p[J->av] = y * st->spacing[J->av];
    return v3(st->lo.x + p[0], st->lo.y + p[1], st->lo.z + p[2]);
}

/* Bilinear fetch of entry e's previous slice at (x, y). A point outside the
 * slice lies outside the volume box: the light there crossed only empty
 * space (the box is convex), so it is the light's unoccluded ray value. */
static inline __attribute__((always_inline)) void fetch(const lv_sweep *J, const lv_entry *e, float x, float y,
                                                       float out[3]) {
    int mu = J->mu, mv = J->mv;
    if (x >= 0.0f && y >= 0.0f && x <= (float)(mu - 1) && y <= (float)(mv - 1)) {
        int i = (int)x, j = (int)y;
        if (i > mu - 2) i = mu - 2;
        if (j > mv - 2) j = mv - 2;
        float ax = x - (float)i, ay = y - (float)j;
        size_t b = (size_t)j * (size_t)mu + (size_t)i;
        for (int c = 0; c < 3; c++) {
            const float *p = e->rd[c] + b;
            float t0 = p[0] + (p[1] - p[0]) * ax, t1 = p[mu] + (p[mu + 1] - p[mu]) * ax;
            out[c] = t0 + (t1 - t0) * ay;
        }
        return;
    }
    ray_value(e->s, slice_world(J, x, y, J->kp), out);
}

/* σt and κ_c = σt − f·σs_c (first np of them) of scalar value s. */
static inline __attribute__((always_inline)) void classify_s(const lv_sweep *J, float s, float m[4]) {
    if (!J->forward) {
        m[0] = volux_lut_sigma(J->lut, s);
        return;
    }
    float rgba[4];
    volux_lut_rgba(J->lut, s, rgba);
    float sg = rgba[3], k = J->fwd * J->albedo * sg;
    m[0] = sg;
    for (int c = 0; c < 3; c++) {
        float kc = sg - k * rgba[c];
        m[1 + c] = kc > 0.0f ? kc : 0.0f;
    }
}

/* Adds wp·M_prev(x, y) + wc·M_cur(x, y) of the first np medium planes to
 * tau[] (one bilinear footprint for all planes and both slices; outside
 * the slice the medium is empty). Post-classified slices: the scalar is
 * interpolated to the point ((1 − t)·prev + t·cur, t = wc/(wp + wc)) and
 * classified there, adding (wp + wc)·M(s). */
static inline __attribute__((always_inline)) void med_accumulate(const lv_sweep *J, float x, float y, float wp,
                                                                 float wc, int np, float tau[4]) {
    const int mu = J->mu, mv = J->mv;
    const size_t area = J->area;
    if (x >= 0.0f && y >= 0.0f && x <= (float)(mu - 1) && y <= (float)(mv - 1)) {
        int i = (int)x, j = (int)y;
        if (i > mu - 2) i = mu - 2;
        if (j > mv - 2) j = mv - 2;
        float ax = x - (float)i, ay = y - (float)j;
        float w00 = (1.0f - ax) * (1.0f - ay), w10 = ax * (1.0f - ay), w01 = (1.0f - ax) * ay, w11 = ax * ay;
        size_t b = (size_t)j * (size_t)mu + (size_t)i;
        if (J->post) {
            const float *P = J->mp + b, *C = J->mc + b;
            float sp = w00 * P[0] + w10 * P[1] + w01 * P[mu] + w11 * P[mu + 1];
            float sc = w00 * C[0] + w10 * C[1] + w01 * C[mu] + w11 * C[mu + 1];
            float l = wp + wc;
            if (!(l > 0.0f)) return;
            float m[4];
            classify_s(J, sp + (sc - sp) * (wc / l), m);
            for (int q = 0; q < np; q++) tau[q] += l * m[q];
            return;
        }
        for (int q = 0; q < np; q++) {
            const float *P = J->mp + (size_t)q * area + b, *C = J->mc + (size_t)q * area + b;
            tau[q] += wp * (w00 * P[0] + w10 * P[1] + w01 * P[mu] + w11 * P[mu + 1]) +
                      wc * (w00 * C[0] + w10 * C[1] + w01 * C[mu] + w11 * C[mu + 1]);
        }
        return;
    }
    (void)area; /* outside the box: empty */
}

/* One row of classify_rows. */
static void classify_one_row(const lv_sweep *J, const lightvol_state *st, const volux_volume *vol, float *restrict sig,
                             float *restrict kr, float *restrict kg, float *restrict kb, size_t base, size_t ustep,
                             float f, int forward, int mu) {
    (void)J;
    {
        if (st->on_grid && st->have_u8) {
            const uint8_t *d = (const uint8_t *)vol->data + base;
            const float *tab = st->class_u8;
            if (ustep > 16) /* x sweeps read one byte per x-row: prefetch ahead */
                for (int u = 0; u < mu && u < 32; u++) __builtin_prefetch(d + (size_t)u * ustep, 0, 1);
            if (!forward && ustep > 16) {
                for (int u = 0; u < mu; u++) {
                    if (u + 32 < mu) __builtin_prefetch(d + (size_t)(u + 32) * ustep, 0, 1);
                    sig[u] = tab[4 * d[(size_t)u * ustep]];
                }
            } else if (!forward) {
                for (int u = 0; u < mu; u++) sig[u] = tab[4 * d[(size_t)u * ustep]];
            } else {
                for (int u = 0; u < mu; u++) {
                    const float *c = tab + 4 * d[(size_t)u * ustep];
                    float s0 = c[0], r = s0 - f * c[1], g = s0 - f * c[2], b = s0 - f * c[3];
                    sig[u] = s0;
                    kr[u] = r > 0.0f ? r : 0.0f;
                    kg[u] = g > 0.0f ? g : 0.0f;
                    kb[u] = b > 0.0f ? b : 0.0f;
                }
            }
            return;
        }
        for (int u = 0; u < mu; u++) {
            float c[4];
            if (st->on_grid) classify(st, base + (size_t)u * ustep, c);
            else memcpy(c, st->medium + (base + (size_t)u * ustep) * 4, sizeof c);
            float r = c[0] - f * c[1], g = c[0] - f * c[2], b = c[0] - f * c[3];
            sig[u] = c[0];
            if (forward) {
                kr[u] = r > 0.0f ? r : 0.0f;
                kg[u] = g > 0.0f ? g : 0.0f;
                kb[u] = b > 0.0f ? b : 0.0f;
            }
        }
    }
}

/* Medium of rows [v0, v1) of slice k into `dst` (4 planes): σt and
 * κ_c = σt − f·σs_c. */
static void classify_rows(const lv_sweep *J, float *dst, int k, int v0, int v1) {
    const lightvol_state *st = J->st;
    const volux_volume *vol = st->volume;
    int mu = J->mu;
    size_t area = J->area;
    const float f = J->fwd;
    const int forward = J->forward;
    /* node (u, v, k) → linear index: base(v) + u·step (data grid when on
     * grid, else the medium grid; both x fastest) */
    const int *dims = st->on_grid ? vol->dims : st->dims;
    size_t stride[3] = {1, (size_t)dims[0], (size_t)dims[0] * (size_t)dims[1]};
    size_t ustep = stride[J->au];
    for (int v = v0; v < v1; v++) {
        size_t off = (size_t)v * (size_t)mu;
        float *restrict sig = dst + off, *restrict kr = dst + area + off, *restrict kg = dst + 2 * area + off,
                        *restrict kb = dst + 3 * area + off;
        size_t base = (size_t)k * stride[J->a] + (size_t)v * stride[J->av];
        float *info = dst + 4 * area + 2 * (size_t)v; /* row min, max */
        if (J->post) {
            /* scalar values (file units); the row's value range */
            const float off_v = vol->value_offset;
            float lo = INFINITY, hi = -INFINITY;
            if (vol->storage == VOLUX_STORE_U8) {
                const uint8_t *d = (const uint8_t *)vol->data + base;
                if (ustep > 16)
                    for (int u = 0; u < mu && u < 32; u++) __builtin_prefetch(d + (size_t)u * ustep, 0, 1);
                for (int u = 0; u < mu; u++) {
                    if (ustep > 16 && u + 32 < mu) __builtin_prefetch(d + (size_t)(u + 32) * ustep, 0, 1);
                    sig[u] = (float)d[(size_t)u * ustep] + off_v;
                }
            } else {
                for (int u = 0; u < mu; u++) sig[u] = volux_volume_raw_at(vol, base + (size_t)u * ustep) + off_v;
            }
            for (int u = 0; u < mu; u++) {
                lo = sig[u] < lo ? sig[u] : lo;
                hi = sig[u] > hi ? sig[u] : hi;
            }
            info[0] = lo;
            info[1] = hi;
            continue;
        }
        classify_one_row(J, st, vol, sig, kr, kg, kb, base, ustep, f, forward, mu);
        float mx = 0.0f;
        for (int u = 0; u < mu; u++) mx = sig[u] > mx ? sig[u] : mx;
        info[0] = 0.0f;
        info[1] = mx;
    }
}

/* Row scratch layout (floats, per thread): acc[6·mu] T[mu] Tc[3·mu]
 * cone[3·mu] cen[3·mu] tau[4·mu], then 16·mu for pos_row. */
#define ROW_FLOATS 36

/* Slices an x sweep stages before writing them to the volume as runs. */
#define LV_DEFER 8

/* 1 if rows [j0, j1] (clamped) of the previous and current slices hold no
 * medium: every transmittance there is exactly 1. */
static inline int rows_empty(const lv_sweep *J, int j0, int j1) {
    if (j0 < 0) j0 = 0;
    if (j1 > J->mv - 1) j1 = J->mv - 1;
    const float *rp = J->mp + 4 * J->area, *rc = J->mc + 4 * J->area;
    float lo = INFINITY, hi = -INFINITY;
    for (int j = j0; j <= j1; j++) { /* (no NaN here: ranges come from comparisons) */
        float l = rp[2 * j] < rc[2 * j] ? rp[2 * j] : rc[2 * j], h = rp[2 * j + 1] > rc[2 * j + 1] ? rp[2 * j + 1] : rc[2 * j + 1];
        lo = l < lo ? l : lo;
        hi = h > hi ? h : hi;
    }
    if (!J->post) return !(hi > 0.0f);
    /* every value interpolated there lies in [lo, hi]: is σt zero on it?
     * (the table is linear between entries: look at the bracketing ones) */
    const volux_transfer_lut *lut = J->lut;
    const int last = lut->n - 1;
    float u0 = (lo - lut->s_min) * lut->inv_ds, u1 = (hi - lut->s_min) * lut->inv_ds;
    int i0 = (int)floorf(u0), i1 = (int)ceilf(u1);
    i0 = i0 < 0 ? 0 : (i0 > last ? last : i0);
    i1 = i1 < 0 ? 0 : (i1 > last ? last : i1);
    return J->st->lut_nz[i1 + 1] - J->st->lut_nz[i0] == 0;
}

static void accumulate(float *restrict a, const float *restrict o, float w, int n) {
    for (int u = 0; u < n; u++) a[u] += w * o[u];
}

/* D += lum(value)·(sign·factor·direction) */
static void accumulate_dir(float *a, size_t m, float *const out[3], volux_vec3 d, int n) {
    float *restrict ax = a, *restrict ay = a + m, *restrict az = a + 2 * m;
    const float *restrict o0 = out[0], *restrict o1 = out[1], *restrict o2 = out[2];
    for (int u = 0; u < n; u++) {
        float lum = 0.2126f * o0[u] + 0.7152f * o1[u] + 0.0722f * o2[u];
        ax[u] += d.x * lum;
        ay[u] += d.y * lum;
        az[u] += d.z * lum;
    }
}

/* Optical depths of row v over directional entry e's segments (σt into
 * tau[0], κ_c into tau[1..3] when forward scattering): midpoint rule over
 * e->nsub points, the medium interpolated between the two slices. */
static void dir_tau(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, float *tau[4]) {
    const int mu = J->mu, np = J->nplanes;
    const size_t area = J->area;
    for (int q = 0; q < np; q++) memset(tau[q], 0, (size_t)mu * sizeof(float));
    for (int i = 0; i < e->nsub && !J->simd; i++) {
        const lv_tap t = e->ts[i];
        const float wp = e->wp[i], wc = e->wc[i];
        if (J->post && u1 > u0) {
            const float l = wp + wc, tf = wc / l;
            const float *P0 = J->mp + (ptrdiff_t)(v + t.dj) * mu + t.di, *P1 = P0 + mu;
            const float *C0 = J->mc + (ptrdiff_t)(v + t.dj) * mu + t.di, *C1 = C0 + mu;
            for (int u = u0; u < u1; u++) {
                float sp = t.w00 * P0[u] + t.w10 * P0[u + 1] + t.w01 * P1[u] + t.w11 * P1[u + 1];
                float sc = t.w00 * C0[u] + t.w10 * C0[u + 1] + t.w01 * C1[u] + t.w11 * C1[u + 1];
                float m[4];
                classify_s(J, sp + (sc - sp) * tf, m);
                for (int q = 0; q < np; q++) tau[q][u] += l * m[q];
            }
        }
        for (int q = 0; q < np && !J->post; q++) {
            float *d = tau[q];
            if (u1 > u0) {
                const float *P0 = J->mp + (size_t)q * area + (ptrdiff_t)(v + t.dj) * mu + t.di, *P1 = P0 + mu;
                const float *C0 = J->mc + (size_t)q * area + (ptrdiff_t)(v + t.dj) * mu + t.di, *C1 = C0 + mu;
                for (int u = u0; u < u1; u++)
                    d[u] += wp * (t.w00 * P0[u] + t.w10 * P0[u + 1] + t.w01 * P1[u] + t.w11 * P1[u + 1]) +
                            wc * (t.w00 * C0[u] + t.w10 * C0[u + 1] + t.w01 * C1[u] + t.w11 * C1[u + 1]);
            }
        }
    }
    /* row ends: per voxel, outside taps see empty medium (the AVX2 kernel
     * does the whole row) */
    for (int i = 0; i < e->nsub && !J->simd; i++)
        for (int u = 0; u < mu; u++) {
            if (u == u0 && u1 > u0) {
                u = u1 - 1;
                continue;
            }
            float tq[4] = {0, 0, 0, 0};
            med_accumulate(J, (float)u + e->su[i], (float)v + e->sv[i], e->wp[i], e->wc[i], np, tq);
            for (int q = 0; q < np; q++) tau[q][u] += tq[q];
        }
    if (J->simd) volux_lightvol_dir_tau_avx2(J, e, v, u0, u1, tau);
}

/* Directional light, row v: values into out[c][0..mu). */
static void dir_row(const lv_sweep *J, const lv_entry *e, int v, float *out[3], float *T, float *Tc[3], float *cone[3],
                    float *cen[3], float *tau[4], const lv_entry **last) {
    int mu = J->mu, mv = J->mv;
    if (e->mode == E_INIT) {
        float pw[3] = {e->s->power.x, e->s->power.y, e->s->power.z};
        for (int c = 0; c < 3; c++)
            for (int u = 0; u < mu; u++) out[c][u] = pw[c];
        return;
    }
    /* Interior: every tap inside the slice, constant weights → vector loops. */
    int u0 = -e->di_min, u1 = mu - 1 - e->di_max; /* u in [u0, u1) */
    int row_ok = v + e->dj_min >= 0 && v + e->dj_max + 1 <= mv - 1;
    if (u0 < 0) u0 = 0;
    if (u1 > mu) u1 = mu;
    if (!row_ok || u1 < u0) u0 = u1 = 0;
    /* No medium anywhere in the row's footprint (sub-sample and cone taps
     * included): the light only moves on. */
    int empty = rows_empty(J, v + e->dj_min - 1, v + e->dj_max + 2);
    /* Transmittances over the segments back to the previous slice; shared
     * by consecutive lights with the same geometry (same direction). */
    const lv_entry *l = *last;
    if (!empty && (!l || l->du != e->du || l->dv != e->dv || l->len != e->len)) {
        dir_tau(J, e, v, u0, u1, tau);
        {
            float *restrict Tr = T;
            const float *restrict t0 = tau[0];
            for (int u = 0; u < mu; u++) Tr[u] = lv_exp_neg(t0[u]);
        }
        if (J->forward)
            for (int c = 0; c < 3; c++) {
                const float *restrict tk = tau[1 + c];
                float *restrict tc = Tc[c];
                for (int u = 0; u < mu; u++) tc[u] = lv_exp_neg(tk[u]);
            }
        *last = e;
    }
    if (u1 > u0) {
        const lv_tap t = e->tc;
        for (int c = 0; c < 3; c++) {
            const float *p0 = e->rd[c] + (ptrdiff_t)(v + t.dj) * mu + t.di, *p1 = p0 + mu;
            float *cc = cen[c];
            for (int u = u0; u < u1; u++)
                cc[u] = t.w00 * p0[u] + t.w10 * p0[u + 1] + t.w01 * p1[u] + t.w11 * p1[u + 1];
        }
        if (J->cone && !empty) {
            for (int c = 0; c < 3; c++) {
                float *cn = cone[c];
                for (int u = u0; u < u1; u++) cn[u] = 0.0f;
                for (int q = 0; q < 4; q++) {
                    const lv_tap t2 = e->tcone[q];
                    const float *p0 = e->rd[c] + (ptrdiff_t)(v + t2.dj) * mu + t2.di, *p1 = p0 + mu;
                    for (int u = u0; u < u1; u++)
                        cn[u] += 0.25f * (t2.w00 * p0[u] + t2.w10 * p0[u + 1] + t2.w01 * p1[u] + t2.w11 * p1[u + 1]);
                }
            }
        }
    }
    /* Edges: generic fetch with outside taps. */
    for (int u = 0; u < mu; u++) {
        if (u == u0 && u1 > u0) {
            u = u1 - 1;
            continue;
        }
        float c3[3];
        fetch(J, e, (float)u + e->du, (float)v + e->dv, c3);
        for (int c = 0; c < 3; c++) cen[c][u] = c3[c];
        if (J->cone && !empty) {
            float s3[3] = {0, 0, 0};
            for (int q = 0; q < 4; q++) {
                fetch(J, e, (float)u + e->cu[q], (float)v + e->cv[q], c3);
                for (int c = 0; c < 3; c++) s3[c] += 0.25f * c3[c];
            }
            for (int c = 0; c < 3; c++) cone[c][u] = s3[c];
        }
    }
    /* Combine: direct part sharp, forward-scattered part from the cone. */
    if (empty) {
        for (int c = 0; c < 3; c++) memcpy(out[c], cen[c], (size_t)mu * sizeof(float));
        return;
    }
    for (int c = 0; c < 3; c++) {
        float *restrict o = out[c];
        const float *restrict cc = cen[c];
        if (!J->forward) {
            for (int u = 0; u < mu; u++) o[u] = T[u] * cc[u];
        } else if (!J->cone) {
            const float *restrict tc = Tc[c];
            for (int u = 0; u < mu; u++) o[u] = tc[u] * cc[u];
        } else {
            const float *restrict tc = Tc[c], *restrict cn = cone[c];
            for (int u = 0; u < mu; u++) o[u] = T[u] * cc[u] + (tc[u] - T[u]) * cn[u];
        }
    }
}

/* What the previous directional entry of a row left in the row scratch. */
typedef struct lv_row_geom {
    const lv_entry *e; /* its geometry (offsets, taps)          */
    int empty;         /* its footprint holds no medium         */
    int have_T;        /* T, Tc hold its transmittances          */
} lv_row_geom;

/* Directional light, row v, with the AVX2 kernels: as dir_row followed by
 * sweep_row's accumulation, the whole row in one fused pass
 * (volux_lightvol_dir_light_avx2/avx512; the row ends by fetch()'s rules
 * per lane); the transmittances and footprint test shared with the
 * previous light of the same geometry. */

static void dir_row_simd(const lv_sweep *J, const lv_entry *e, int v, float *out[3], float *T, float *Tc[3],
                         float *tau[4], lv_row_geom *G, float *acc, int ch, float *S) {
    const int mu = J->mu, mv = J->mv;
    const size_t m = (size_t)mu;
    const int one = e->nch == 1;
    if (e->mode == E_INIT) {
        float pw[3] = {e->s->power.x, e->s->power.y, e->s->power.z};
        for (int c = 0; c < e->nch; c++)
            for (int u = 0; u < mu; u++) out[c][u] = pw[c];
        float *o3[3] = {out[0], out[one ? 0 : 1], out[one ? 0 : 2]};
        for (int c = 0; c < 3; c++) accumulate(acc + (size_t)c * m, o3[c], e->sw * e->gain[c], mu);
        if (ch == 6) {
            volux_vec3 d = e->dsw;
            if (one) d = v3_scale(d, 0.2126f * e->gain[0] + 0.7152f * e->gain[1] + 0.0722f * e->gain[2]);
            if (one) accumulate(acc + 3 * m, out[0], d.x, mu), accumulate(acc + 4 * m, out[0], d.y, mu),
                accumulate(acc + 5 * m, out[0], d.z, mu);
            else accumulate_dir(acc + 3 * m, m, o3, d, mu);
        }
        return;
    }
    int u0 = -e->di_min, u1 = mu - 1 - e->di_max;
    int row_ok = v + e->dj_min >= 0 && v + e->dj_max + 1 <= mv - 1;
    if (u0 < 0) u0 = 0;
    if (u1 > mu) u1 = mu;
    if (!row_ok || u1 < u0) u0 = u1 = 0;
    /* a light with the previous one's geometry shares its footprint test and
     * transmittances */
    const lv_entry *l = G->e;
    const int same = l && l->du == e->du && l->dv == e->dv && l->len == e->len && l->dj_min == e->dj_min &&
                     l->dj_max == e->dj_max && l->di_min == e->di_min && l->di_max == e->di_max;
    int empty = same ? G->empty : rows_empty(J, v + e->dj_min - 1, v + e->dj_max + 2);
    if (!same) G->e = e, G->empty = empty, G->have_T = 0;
    if (!empty && !G->have_T) {
        dir_tau(J, e, v, u0, u1, tau);
        volux_lightvol_exp_avx2(T, tau[0], mu);
        if (J->forward)
            for (int c = 0; c < 3; c++) volux_lightvol_exp_avx2(Tc[c], tau[1 + c], mu);
        G->have_T = 1;
    }
    if (J->avx512) volux_lightvol_dir_light_avx512(J, e, v, u0, u1, T, Tc, empty, out, acc, m, ch, S);
    else volux_lightvol_dir_light_avx2(J, e, v, u0, u1, T, Tc, empty, out, acc, m, ch, S);
}

/* Outside-slice fallback of fetch(), kept out of line. */
static __attribute__((noinline)) void fetch_slow(const lv_sweep *J, const lv_entry *e, float x, float y,
                                                 float out[3]) {
    fetch(J, e, x, y, out);
}

/* Positional light, row v: ray values into out, weighted 1/r² contribution
 * into acc. Per voxel: direction, Eq. 5 factor, and the previous-slice
 * point on the line towards the light (x' = u − (u − l_u)·f: affine in u,
 * and the same row y' for the whole row). */
static void pos_voxels(const lv_sweep *J, const lv_entry *e, int v, int ua, int ub, float *out[3], float *acc, int ch) {
    const lightvol_state *st = J->st;
    const int mu = J->mu, mv = J->mv;
    const int a = J->a, au = J->au, av = J->av, np = J->nplanes, forward = J->forward, cone = J->cone;
    const float sa = st->spacing[a], su = st->spacing[au], sv = st->spacing[av];
    const float la = e->lidx[a], lu = e->lidx[au], lv = e->lidx[av];
    const float da = ((float)J->k - la) * sa, dvw = ((float)v - lv) * sv;
    const float f = e->f, rm2 = J->rmin2, sign = e->sign;
    const float pw[3] = {e->s->power.x, e->s->power.y, e->s->power.z};
    /* previous-slice row and its sub-sample rows are the same for the row */
    const float y = (float)v - ((float)v - lv) * f, ov = y - (float)v;
    float *accs[6];
    for (int c = 0; c < 6; c++) accs[c] = acc + (size_t)c * (size_t)mu;
    for (int u = ua; u < ub; u++) {
        float d[3];
        d[a] = da;
        d[au] = ((float)u - lu) * su;
        d[av] = dvw;
        float r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        float r = sqrtf(r2), ir = 1.0f / r;
        float w[3] = {d[0] * ir, d[1] * ir, d[2] * ir};
        float val[3];
        if (e->mode != E_PROP) {
            float p[3] = {pw[0], pw[1], pw[2]};
            if (e->s->spot) {
                float sf = spot_factor(e->s, w[0] * e->s->dir.x + w[1] * e->s->dir.y + w[2] * e->s->dir.z);
                p[0] *= sf, p[1] *= sf, p[2] *= sf;
            }
            if (e->mode == E_INIT_ATT) {
                /* The light sits less than one slice before this one: the
                 * segment light → voxel stays between the two slices but may
                 * run far sideways; integrate it voxel by voxel (outside the
                 * box the medium is empty). */
                float tau[4] = {0, 0, 0, 0};
                float ou = lu - (float)u, ovl = lv - (float)v;
                /* only the part inside the slice's extent carries medium:
                 * t ∈ [0, t1] (0 at the voxel, 1 at the light) */
                float t1 = 1.0f;
                if (ou > 0.0f) t1 = fminf(t1, ((float)(mu - 1) - (float)u) / ou);
                if (ou < 0.0f) t1 = fminf(t1, -(float)u / ou);
                if (ovl > 0.0f) t1 = fminf(t1, ((float)(mv - 1) - (float)v) / ovl);
                if (ovl < 0.0f) t1 = fminf(t1, -(float)v / ovl);
                float lat = fmaxf(fabsf(ou), fabsf(ovl)) * t1;
                int n = lat <= 1.0f ? 1 : (int)fminf(ceilf(lat), (float)LV_MAX_INIT_SUB);
                float axial = (float)J->s * ((float)J->k - la); /* in (0, 1] */
                for (int i = 0; i < n; i++) {
                    float t = ((float)i + 0.5f) / (float)n * t1;
                    float px = (float)u + ou * t, py = (float)v + ovl * t;
                    float wprev = J->step > 0 ? t * axial : 0.0f; /* weight of slice kp at this point */
                    float wp = wprev * r * t1 / (float)n, wc = (1.0f - t * axial) * r * t1 / (float)n;
                    med_accumulate(J, px, py, wp, wc, np, tau);
                }
                for (int c = 0; c < 3; c++) val[c] = p[c] * lv_exp_neg(tau[forward ? 1 + c : 0]);
            } else {
                for (int c = 0; c < 3; c++) val[c] = p[c];
            }
        } else {
            float ou = ((float)u - lu) * -f, x = (float)u + ou;
            float len = r * f;
            /* optical depth over the segment (midpoint rule, see dir_tau) */
            float tau[4] = {0, 0, 0, 0};
            float m = fabsf(ou) > fabsf(ov) ? fabsf(ou) : fabsf(ov);
            int n = m <= 1.0f ? 1 : (m >= (float)LV_MAX_SUB ? LV_MAX_SUB : (int)ceilf(m));
            float inv_n = 1.0f / (float)n;
            for (int i = 0; i < n; i++) {
                float t = ((float)i + 0.5f) * inv_n, px = (float)u + ou * (1.0f - t), py = (float)v + ov * (1.0f - t);
                med_accumulate(J, px, py, (1.0f - t) * len * inv_n, t * len * inv_n, np, tau);
            }
            float cc[3];
            int inside = x >= 0.0f && y >= 0.0f && x <= (float)(mu - 1) && y <= (float)(mv - 1);
            if (inside) fetch(J, e, x, y, cc);
            else fetch_slow(J, e, x, y, cc);
            float T = lv_exp_neg(tau[0]);
            if (!forward) {
                for (int c = 0; c < 3; c++) val[c] = T * cc[c];
            } else {
                float Tc[3];
                for (int c = 0; c < 3; c++) Tc[c] = lv_exp_neg(tau[1 + c]);
                if (!cone) {
                    for (int c = 0; c < 3; c++) val[c] = Tc[c] * cc[c];
                } else {
                    float rho = len * J->tan_c, ru = rho / su, rv = rho / sv;
                    float s3[3] = {0, 0, 0}, c3[3];
                    const float ox[4] = {ru, -ru, 0.0f, 0.0f}, oy[4] = {0.0f, 0.0f, rv, -rv};
                    int in4 = inside && x - ru >= 0.0f && y - rv >= 0.0f && x + ru <= (float)(mu - 1) &&
                              y + rv <= (float)(mv - 1);
                    for (int q = 0; q < 4; q++) {
                        if (in4) fetch(J, e, x + ox[q], y + oy[q], c3);
                        else fetch_slow(J, e, x + ox[q], y + oy[q], c3);
                        for (int c = 0; c < 3; c++) s3[c] += 0.25f * c3[c];
                    }
                    for (int c = 0; c < 3; c++) val[c] = T * cc[c] + (Tc[c] - T) * s3[c];
                }
            }
        }
        for (int c = 0; c < 3; c++) out[c][u] = val[c];
        /* Eq. 5 factor of this group for the local direction; the group's
         * own component is positive here (the voxel lies ahead of the light) */
        const float mag[3] = {fabsf(w[0]), fabsf(w[1]), fabsf(w[2])};
        float wg = lv_axis_weight(mag, a);
        if (wg <= 0.0f) continue;
        float k = sign * wg / (r2 > rm2 ? r2 : rm2);
        /* (one channel: val[1], val[2] are not propagated; × gain = power) */
        const int one = e->nch == 1;
        float er = val[0] * k * e->gain[0], eg = (one ? val[0] : val[1]) * k * e->gain[1],
              eb = (one ? val[0] : val[2]) * k * e->gain[2];
        accs[0][u] += er;
        accs[1][u] += eg;
        accs[2][u] += eb;
        if (ch == 6) {
            float lum = 0.2126f * er + 0.7152f * eg + 0.0722f * eb;
            accs[3][u] += lum * w[0];
            accs[4][u] += lum * w[1];
            accs[5][u] += lum * w[2];
        }
    }
}

/* Positional light, row v. Propagation rows: the interior (every tap of
 * every voxel inside the slice) in three phases — geometry and Eq. 5
 * factors (vector loops), medium and light gathers without bounds checks,
 * transmittances and accumulation (vector loops); the row ends and the
 * initialisation slices per voxel (pos_voxels). */
static void pos_row(const lv_sweep *J, const lv_entry *e, int v, float *out[3], float *acc, int ch, float *scr) {
    const lightvol_state *st = J->st;
    const int mu = J->mu, mv = J->mv;
    if (e->mode == E_SKIP) {
        for (int c = 0; c < 3; c++) memset(out[c], 0, (size_t)mu * sizeof(float));
        return;
    }
    if (e->mode != E_PROP || mu < 8) {
        pos_voxels(J, e, v, 0, mu, out, acc, ch);
        return;
    }
    const size_t m = (size_t)mu, area = J->area;
    const int a = J->a, au = J->au, av = J->av, np = J->nplanes, forward = J->forward, cone = J->cone;
    const float su = st->spacing[au], sv = st->spacing[av];
    const float la = e->lidx[a], lu = e->lidx[au], lv = e->lidx[av];
    const float da = ((float)J->k - la) * st->spacing[a], dvw = ((float)v - lv) * sv;
    const float f = e->f, rm2 = J->rmin2, sign = e->sign, tan_c = J->tan_c;
    const float y = (float)v - ((float)v - lv) * f, ov = y - (float)v;
    /* scratch: X LEN K WA WU WV TAU[4] CEN[3] CON[3] = 16·mu floats; the
     * AVX2 kernels use the first 10 with a stride rounded up to 8 */
    const int simd = J->simd;
    const size_t ms = simd ? (m + 7) & ~(size_t)7 : m;
    float *restrict X = scr, *restrict LEN = X + ms, *restrict K = LEN + ms, *restrict WA = K + ms,
                    *restrict WU = WA + ms, *restrict WV = WU + ms, *TAU = WV + ms, *CEN = TAU + 4 * m, *CON = CEN + 3 * m;
    lv_pos_row R = {.v = v, .ms = ms, .X = X, .LEN = LEN, .K = K, .WA = WA, .WU = WU, .WV = WV, .TAU = TAU, .y = y};
    /* Phase 1: geometry, factor of this group, 1/r² (vector loops) */
    const float da2 = da * da, dv2 = dvw * dvw, ada = fabsf(da), adv = fabsf(dvw);
    if (simd) volux_lightvol_pos_geometry_avx2(J, e, &R);
    for (int u = 0; u < mu && !simd; u++) {
        float du = ((float)u - lu) * su, du2 = du * du;
        /* r² summed in x, y, z order like pos_voxels, so the factors of the
         * groups of a voxel match theirs exactly */
        float r2 = a == 0 ? (da2 + du2) + dv2 : a == 1 ? (du2 + da2) + dv2 : (du2 + dv2) + da2;
        float r = sqrtf(r2), ir = 1.0f / r;
        float mag[3];
        mag[a] = ada * ir;
        mag[au] = fabsf(du) * ir;
        mag[av] = adv * ir;
        float wg = lv_axis_weight(mag, a);
        K[u] = sign * wg / (r2 > rm2 ? r2 : rm2);
        WA[u] = da * ir;
        WU[u] = du * ir;
        WV[u] = dvw * ir;
        X[u] = (float)u - ((float)u - lu) * f;
        LEN[u] = r * f;
    }
    /* interior: X is increasing in u; cone radii are largest at a row end */
    float rho_max = cone ? fmaxf(LEN[0], LEN[mu - 1]) * tan_c : 0.0f;
    float ru_max = rho_max / su, rv_max = rho_max / sv;
    int u0 = 0, u1 = 0;
    if (y - rv_max >= 0.0f && y + rv_max <= (float)(mv - 1)) {
        u0 = 0;
        while (u0 < mu && X[u0] - ru_max < 0.0f) u0++;
        u1 = mu;
        while (u1 > u0 && X[u1 - 1] + ru_max > (float)(mu - 1)) u1--;
    }
    if (u1 > u0) {
        /* Phase 2: gathers. Rows of the previous slice are row constants. */
        float m0 = fabsf(X[0]), m1 = fabsf(X[mu - 1] - (float)(mu - 1));
        float lat = fmaxf(fmaxf(m0, m1), fabsf(ov));
        int n = lat <= 1.0f ? 1 : (lat >= (float)LV_MAX_SUB ? LV_MAX_SUB : (int)ceilf(lat));
        float inv_n = 1.0f / (float)n;
        int jrow[LV_MAX_SUB];
        float ay[LV_MAX_SUB], tt[LV_MAX_SUB];
        for (int i = 0; i < n; i++) {
            tt[i] = ((float)i + 0.5f) * inv_n;
            float py = (float)v + ov * (1.0f - tt[i]);
            int j = (int)py;
            if (j > mv - 2) j = mv - 2;
            jrow[i] = j;
            ay[i] = py - (float)j;
        }
        int jc = (int)y;
        if (jc > mv - 2) jc = mv - 2;
        float ayc = y - (float)jc;
        /* rows between v and y (and the cone's) without medium: T = 1 */
        int jlo = (int)floorf(fminf((float)v, y - rv_max)) - 1, jhi = (int)ceilf(fmaxf((float)v, y + rv_max)) + 1;
        int empty = rows_empty(J, jlo, jhi);
        for (int q = 0; q < np; q++) memset(TAU + (size_t)q * ms + u0, 0, (size_t)(u1 - u0) * sizeof(float));
        if (simd) {
            R.u0 = u0, R.u1 = u1, R.n = n, R.inv_n = inv_n, R.jc = jc, R.ayc = ayc, R.empty = empty;
            for (int i = 0; i < n; i++) R.tt[i] = tt[i], R.ay[i] = ay[i], R.jrow[i] = jrow[i];
            if (!empty) volux_lightvol_pos_tau_avx2(J, &R);
            volux_lightvol_pos_light_avx2(J, e, &R, out, acc, m, ch);
            goto ends;
        }
        for (int i = 0; i < n && !empty; i++) {
            const float t = tt[i], om = 1.0f - t, ayi = ay[i];
            const size_t rb = (size_t)jrow[i] * m;
            for (int u = u0; u < u1; u++) {
                float px = (float)u + (X[u] - (float)u) * om;
                int ix = (int)px;
                if (ix > mu - 2) ix = mu - 2;
                float ax = px - (float)ix;
                float w00 = (1.0f - ax) * (1.0f - ayi), w10 = ax * (1.0f - ayi), w01 = (1.0f - ax) * ayi, w11 = ax * ayi;
                float wp = om * LEN[u] * inv_n, wc = t * LEN[u] * inv_n;
                size_t b = rb + (size_t)ix;
                if (J->post) {
                    const float *P = J->mp + b, *C = J->mc + b;
                    float sp = w00 * P[0] + w10 * P[1] + w01 * P[mu] + w11 * P[mu + 1];
                    float sc = w00 * C[0] + w10 * C[1] + w01 * C[mu] + w11 * C[mu + 1];
                    float mm[4];
                    classify_s(J, sp + (sc - sp) * t, mm);
                    for (int q = 0; q < np; q++) TAU[(size_t)q * m + (size_t)u] += (wp + wc) * mm[q];
                    continue;
                }
                for (int q = 0; q < np; q++) {
                    const float *P = J->mp + (size_t)q * area + b, *C = J->mc + (size_t)q * area + b;
                    TAU[(size_t)q * m + (size_t)u] += wp * (w00 * P[0] + w10 * P[1] + w01 * P[mu] + w11 * P[mu + 1]) +
                                                      wc * (w00 * C[0] + w10 * C[1] + w01 * C[mu] + w11 * C[mu + 1]);
                }
            }
        }
        const float *R0 = e->rd[0], *R1 = e->rd[1], *R2 = e->rd[2];
        for (int u = u0; u < u1; u++) {
            float px = X[u];
            int ix = (int)px;
            if (ix > mu - 2) ix = mu - 2;
            float ax = px - (float)ix;
            size_t b = (size_t)jc * m + (size_t)ix;
            float w00 = (1.0f - ax) * (1.0f - ayc), w10 = ax * (1.0f - ayc), w01 = (1.0f - ax) * ayc, w11 = ax * ayc;
            CEN[u] = w00 * R0[b] + w10 * R0[b + 1] + w01 * R0[b + m] + w11 * R0[b + m + 1];
            CEN[m + (size_t)u] = w00 * R1[b] + w10 * R1[b + 1] + w01 * R1[b + m] + w11 * R1[b + m + 1];
            CEN[2 * m + (size_t)u] = w00 * R2[b] + w10 * R2[b + 1] + w01 * R2[b + m] + w11 * R2[b + m + 1];
        }
        if (cone && !empty)
            for (int u = u0; u < u1; u++) {
                float rho = LEN[u] * tan_c, ru = rho / su, rv = rho / sv;
                const float ox[4] = {ru, -ru, 0.0f, 0.0f}, oy[4] = {0.0f, 0.0f, rv, -rv};
                float s3[3] = {0, 0, 0};
                for (int q = 0; q < 4; q++) {
                    float c3[3];
                    fetch(J, e, X[u] + ox[q], y + oy[q], c3);
                    for (int c = 0; c < 3; c++) s3[c] += 0.25f * c3[c];
                }
                for (int c = 0; c < 3; c++) CON[(size_t)c * m + (size_t)u] = s3[c];
            }
        /* Phase 3: transmittances, values, accumulation (vector loops) */
        float *restrict o0 = out[0], *restrict o1 = out[1], *restrict o2 = out[2];
        const float *restrict t0 = TAU;
        for (int u = u0; u < u1; u++) {
            float T = lv_exp_neg(t0[u]);
            float v0 = T * CEN[u], v1 = T * CEN[m + (size_t)u], v2 = T * CEN[2 * m + (size_t)u];
            if (forward && !empty) {
                float T0 = lv_exp_neg(TAU[m + (size_t)u]), T1 = lv_exp_neg(TAU[2 * m + (size_t)u]),
                      T2 = lv_exp_neg(TAU[3 * m + (size_t)u]);
                if (cone) {
                    v0 += (T0 - T) * CON[u];
                    v1 += (T1 - T) * CON[m + (size_t)u];
                    v2 += (T2 - T) * CON[2 * m + (size_t)u];
                } else {
                    v0 = T0 * CEN[u];
                    v1 = T1 * CEN[m + (size_t)u];
                    v2 = T2 * CEN[2 * m + (size_t)u];
                }
            }
            o0[u] = v0, o1[u] = v1, o2[u] = v2;
        }
        float *restrict a0 = acc, *restrict a1 = acc + m, *restrict a2 = acc + 2 * m;
        for (int u = u0; u < u1; u++) {
            float k = K[u];
            a0[u] += o0[u] * k;
            a1[u] += o1[u] * k;
            a2[u] += o2[u] * k;
        }
        if (ch == 6) {
            float *restrict ad[3] = {acc + 3 * m, acc + 4 * m, acc + 5 * m};
            float *restrict dx = ad[a], *restrict dy = ad[au], *restrict dz = ad[av];
            for (int u = u0; u < u1; u++) {
                float k = K[u];
                float lum = (0.2126f * o0[u] + 0.7152f * o1[u] + 0.0722f * o2[u]) * k;
                dx[u] += lum * WA[u];
                dy[u] += lum * WU[u];
                dz[u] += lum * WV[u];
            }
        }
    }
ends:
    if (u0 > 0) pos_voxels(J, e, v, 0, u0, out, acc, ch);
    if (u1 < mu) pos_voxels(J, e, v, u1 > u0 ? u1 : u0, mu, out, acc, ch);
}

/* Writes the last nb staged slices of row v into the volume: for each u a
 * contiguous run of nb voxels along x (the sweep axis). */
static void flush_row(const lv_sweep *J, int v, int nb) {
    const lightvol_state *st = J->st;
    const int mu = J->mu, ch = st->ch;
    const size_t m = (size_t)mu;
    const size_t plane = (size_t)J->mu * (size_t)J->mv;
    /* u outer so that the nb voxels of one x-run are written together */
    const size_t su = J->vs[J->au] * (size_t)ch;
    const int k_lo = J->s > 0 ? J->step - (nb - 1) : J->ma - 1 - J->step; /* lowest x of the runs */
    const float *run0 = st->vol + ((size_t)k_lo * J->vs[J->a] + (size_t)v * J->vs[J->av]) * (size_t)ch;
    const size_t run_bytes = (size_t)nb * (size_t)ch * sizeof(float);
    for (int u = 0; u < mu; u++) {
        /* the runs are a whole x-row apart: prefetch a few ahead */
        if (u + 6 < mu)
            for (size_t off = 0; off < run_bytes; off += 64)
                __builtin_prefetch((const char *)(run0 + (size_t)(u + 6) * su) + off, 1, 3);
        for (int b = 0; b < nb; b++) {
            int step = J->step - (nb - 1 - b);
            int k = J->s > 0 ? step : J->ma - 1 - step;
            const float *src = st->stage + ((size_t)b * plane + (size_t)v * m + (size_t)u) * (size_t)ch;
            float *p = st->vol + ((size_t)k * J->vs[J->a] + (size_t)v * J->vs[J->av]) * (size_t)ch + (size_t)u * su;
            if (J->overwrite)
                for (int c = 0; c < ch; c++) p[c] = src[c];
            else
                for (int c = 0; c < ch; c++) p[c] += src[c];
        }
    }
}

/* D += ω·S over a row (a run of same-direction lights, see sweep_row). */
static void flush_run(float *d, size_t m, const float *restrict S, volux_vec3 w, int n) {
    float *restrict dx = d, *restrict dy = d + m, *restrict dz = d + 2 * m;
    for (int u = 0; u < n; u++) {
        dx[u] += w.x * S[u];
        dy[u] += w.y * S[u];
        dz[u] += w.z * S[u];
    }
}

static void sweep_row(const lv_sweep *J, int v, int thread) {
    lightvol_state *st = J->st;
    int mu = J->mu, ch = st->ch;
    size_t m = (size_t)mu;
    float *sc = st->rows + (size_t)thread * st->row_stride;
    float *acc = sc, *T = acc + 6 * m;
    float *Tc[3] = {T + m, T + 2 * m, T + 3 * m};
    float *cone[3] = {T + 4 * m, T + 5 * m, T + 6 * m};
    float *cen[3] = {T + 7 * m, T + 8 * m, T + 9 * m};
    float *tau[4] = {T + 10 * m, T + 11 * m, T + 12 * m, T + 13 * m};
    memset(acc, 0, (size_t)ch * m * sizeof(float));
    const lv_entry *last = NULL;
    size_t off = (size_t)v * m;
    int run = 0; /* a run of same-direction lights is open (SIMD, ch = 6) */
    lv_row_geom G = {NULL, 0, 0};
    for (int i = 0; i < J->ne; i++) {
        const lv_entry *e = &J->e[i];
        float *out[3] = {e->wr[0] + off, e->wr[1] + off, e->wr[2] + off};
        if (e->s->kind == LV_POSITIONAL) {
            pos_row(J, e, v, out, acc, ch, T + 14 * m);
            continue;
        }
        if (J->simd) {
            /* Consecutive lights with one direction: D += ω·Σ sw·lum(E_l)
             * once for the run (lum is linear), not per light; the run's sum
             * lives in the row scratch that the portable path uses for cen. */
            float *S = NULL;
            if (ch == 6) {
                const lv_entry *nx = i + 1 < J->ne ? &J->e[i + 1] : NULL;
                int same_next = nx && nx->s->kind == LV_DIRECTIONAL && nx->s->dir.x == e->s->dir.x &&
                                nx->s->dir.y == e->s->dir.y && nx->s->dir.z == e->s->dir.z;
                if (!run && same_next) memset(cen[0], 0, m * sizeof(float)), run = 1;
                S = run ? cen[0] : NULL;
                dir_row_simd(J, e, v, out, T, Tc, tau, &G, acc, ch, S);
                if (run && !same_next) {
                    flush_run(acc + 3 * m, m, cen[0], e->s->dir, mu);
                    run = 0;
                }
                continue;
            }
            dir_row_simd(J, e, v, out, T, Tc, tau, &G, acc, ch, S);
            continue;
        }
        dir_row(J, e, v, out, T, Tc, cone, cen, tau, &last);
        for (int c = 0; c < 3; c++) accumulate(acc + (size_t)c * m, out[c], e->sw, mu);
        if (ch == 6) accumulate_dir(acc + 3 * m, m, out, e->dsw, mu);
    }
    /* Add (or, first pass of a full rebuild, store) into the volume. */
    size_t base = (size_t)J->k * J->vs[J->a] + (size_t)v * J->vs[J->av], su = J->vs[J->au];
    float *restrict vol = st->vol + base * (size_t)ch;
    const size_t stride = su * (size_t)ch;
    if (J->defer) {
        /* x sweep: park the row in the staging slab (slice-major, AoS) and
         * flush runs of `defer` voxels along x every `defer` slices */
        int b = J->step % J->defer;
        float *restrict dst = st->stage + ((size_t)b * (size_t)J->mu * (size_t)J->mv + (size_t)v * m) * (size_t)ch;
        for (int u = 0; u < mu; u++)
            for (int c = 0; c < ch; c++) dst[(size_t)u * (size_t)ch + (size_t)c] = acc[(size_t)c * m + (size_t)u];
        if (b == J->defer - 1 || J->step == J->ma - 1) flush_row(J, v, b + 1);
        return;
    }
    if (ch == 6) {
        const float *restrict q0 = acc, *restrict q1 = acc + m, *restrict q2 = acc + 2 * m, *restrict q3 = acc + 3 * m,
                              *restrict q4 = acc + 4 * m, *restrict q5 = acc + 5 * m;
        if (J->overwrite) {
            for (int u = 0; u < mu; u++) {
                float *p = vol + (size_t)u * stride;
                p[0] = q0[u], p[1] = q1[u], p[2] = q2[u], p[3] = q3[u], p[4] = q4[u], p[5] = q5[u];
            }
        } else {
            for (int u = 0; u < mu; u++) {
                float *p = vol + (size_t)u * stride;
                p[0] += q0[u], p[1] += q1[u], p[2] += q2[u], p[3] += q3[u], p[4] += q4[u], p[5] += q5[u];
            }
        }
    } else {
        const float *restrict q0 = acc, *restrict q1 = acc + m, *restrict q2 = acc + 2 * m;
        if (J->overwrite) {
            for (int u = 0; u < mu; u++) {
                float *p = vol + (size_t)u * stride;
                p[0] = q0[u], p[1] = q1[u], p[2] = q2[u];
            }
        } else {
            for (int u = 0; u < mu; u++) {
                float *p = vol + (size_t)u * stride;
                p[0] += q0[u], p[1] += q1[u], p[2] += q2[u];
            }
        }
    }
}

/* One work item of a slice step: a chunk of rows of the current slice's
 * sweep, or a chunk of rows of the next slice's classification (the
 * pipeline keeps one fork/join per slice). */
static void step_item(void *user, int64_t item, int thread) {
    const lv_sweep *J = user;
    int i = (int)item, rpi = J->rows_per_item;
    if (i < J->sweep_items) {
        int v0 = i * rpi, v1 = v0 + rpi < J->mv ? v0 + rpi : J->mv;
        for (int v = v0; v < v1; v++) sweep_row(J, v, thread);
    } else {
        i -= J->sweep_items;
        int v0 = i * rpi, v1 = v0 + rpi < J->mv ? v0 + rpi : J->mv;
        classify_rows(J, J->mn, J->kn, v0, v1);
    }
}

/* A medium slice buffer: σt, κr, κg, κb planes (or the scalar in plane 0
 * when post-classified), then per row a (min, max) pair — of the scalar, or
 * 0 and the largest σt — so rows with an empty footprint skip the
 * transmittance work. */
static size_t med_stride(const lightvol_state *st) {
    int mmax = st->dims[0] > st->dims[1] ? st->dims[0] : st->dims[1];
    if (st->dims[2] > mmax) mmax = st->dims[2];
    return 4 * st->area + 2 * (size_t)mmax;
}

static volux_status ensure_scratch(lightvol_state *st, int entries) {
    volux_context *ctx = st->ctx;
    size_t need;
    if (!st->stage) {
        /* x slices are (y, z) planes */
        need = (size_t)LV_DEFER * (size_t)st->dims[1] * (size_t)st->dims[2] * (size_t)st->ch * sizeof(float);
        st->stage = volux_alloc_aligned(ctx, need);
        if (!st->stage) return volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the x-sweep staging");
        st->stage_bytes = need;
    }
    if (entries > st->slice_cap) {
        if (!volux_mul_size(st->area, (size_t)entries * 6 * sizeof(float), &need))
            return volux_error(ctx, VOLUX_ERR_LIMIT, "lightvol: slice buffers too large");
        if (st->slices) volux_free_aligned(ctx, st->slices, st->slices_bytes);
        st->slices = volux_alloc_aligned(ctx, need);
        st->slices_bytes = st->slices ? need : 0;
        st->slice_cap = st->slices ? entries : 0;
        if (!st->slices) return volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for %d slice buffers", entries);
    }
    if (!st->med) {
        need = 3 * med_stride(st) * sizeof(float); /* 3 slices × (4 planes + row ranges) */
        st->med = volux_alloc_aligned(ctx, need);
        if (!st->med) return volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for slice buffers");
        st->med_bytes = need;
    }
    int mmax = st->dims[0] > st->dims[1] ? st->dims[0] : st->dims[1];
    if (st->dims[2] > mmax) mmax = st->dims[2];
    int threads = st->threads > 0 ? st->threads : 1;
    /* + pad: threads never share a cache line, and the AVX2 kernels' last
     * steps may read 8 floats past an array */
    size_t stride = (size_t)ROW_FLOATS * (size_t)mmax + 64;
    if (!st->rows || st->rows_threads < threads || st->row_stride != stride) {
        if (st->rows) volux_free_aligned(ctx, st->rows, st->rows_bytes);
        need = stride * (size_t)threads * sizeof(float);
        st->rows = volux_alloc_aligned(ctx, need);
        st->rows_bytes = st->rows ? need : 0;
        if (!st->rows) return volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for row scratch");
        st->rows_threads = threads;
        st->row_stride = stride;
    }
    return VOLUX_OK;
}

/* Fills e->nst/sj/si/swc/swk (see lv_entry) from the centre and cone taps. */
static void build_stencil(lv_entry *e) {
    int c0 = e->tc.di, c1 = c0, r0 = e->tc.dj, r1 = r0;
    for (int q = 0; q < 4; q++) {
        const lv_tap *t = &e->tcone[q];
        c0 = t->di < c0 ? t->di : c0, c1 = t->di > c1 ? t->di : c1;
        r0 = t->dj < r0 ? t->dj : r0, r1 = t->dj > r1 ? t->dj : r1;
    }
    e->nst = 0;
    if (c1 - c0 > 1 || r1 - r0 > 1) return; /* footprint wider than 3×3 */
    float wk[3][3] = {{0}};
    for (int q = 0; q < 4; q++) {
        const lv_tap *t = &e->tcone[q];
        int j = t->dj - r0, i = t->di - c0;
        wk[j][i] += 0.25f * t->w00, wk[j][i + 1] += 0.25f * t->w10;
        wk[j + 1][i] += 0.25f * t->w01, wk[j + 1][i + 1] += 0.25f * t->w11;
    }
    const float wc[4] = {e->tc.w00, e->tc.w10, e->tc.w01, e->tc.w11};
    int used[3][3] = {{0}}, n = 0;
    for (int k = 0; k < 4; k++) { /* the centre's nodes first */
        int j = e->tc.dj - r0 + k / 2, i = e->tc.di - c0 + k % 2;
        e->sj[n] = r0 + j, e->si[n] = c0 + i, e->swc[n] = wc[k], e->swk[n] = wk[j][i];
        used[j][i] = 1;
        n++;
    }
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 3; i++)
            if (!used[j][i] && wk[j][i] != 0.0f) e->sj[n] = r0 + j, e->si[n] = c0 + i, e->swk[n] = wk[j][i], n++;
    e->nst = n;
}

/* One propagation pass: group g, the given lights. */
/* Each light's slice buffers: what step k wrote is what step k + 1 reads. */
static void swap_slice_buffers(lv_entry *E, int n) {
    for (int i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            float *t = E[i].rd[c];
            E[i].rd[c] = E[i].wr[c];
            E[i].wr[c] = t;
        }
}

/* Serial part of sweep phase p (volux_parallel_phases; returns the phase's
 * item count for step_item). Phase 0 classifies the first slice's medium;
 * phase p ≥ 1 propagates slice step p − 1 and classifies the next slice
 * together — the propagation reads only the previous and current slices'
 * media. The media rotate through three buffers. */
static int64_t sweep_phase(void *user, int phase) {
    lv_sweep *J = user;
    if (phase == 0) {
        J->mn = J->med[0];
        J->kn = J->s > 0 ? 0 : J->ma - 1;
        J->sweep_items = 0;
        J->class_items = J->chunks;
        return J->chunks;
    }
    int step = phase - 1;
    if (step > 0) swap_slice_buffers(J->e, J->ne);
    J->step = step;
    J->k = J->s > 0 ? step : J->ma - 1 - step;
    J->kp = J->k - J->s;
    J->mc = J->med[step % 3];
    J->mp = J->med[(step + 2) % 3];
    J->mn = J->med[(step + 1) % 3];
    J->kn = step + 1 < J->ma ? J->k + J->s : -1;
    for (int i = 0; i < J->ne; i++) {
        lv_entry *e = &J->e[i];
        if (e->s->kind == LV_DIRECTIONAL) {
            e->mode = step == 0 ? E_INIT : E_PROP;
        } else {
            /* slices ahead of the light along the sweep only (§7.3: a
             * light inside the volume needs the opposite groups too) */
            float dist = (float)J->s * ((float)J->k - e->lidx[J->a]);
            if (dist <= 0.0f) e->mode = E_SKIP;
            else if (dist <= 1.0f) e->mode = E_INIT_ATT;
            else if (step == 0) e->mode = E_INIT; /* projection onto the first slice (§6, Fig. 5) */
            else e->mode = E_PROP, e->f = 1.0f / dist;
        }
    }
    J->sweep_items = J->chunks;
    J->class_items = J->kn >= 0 ? J->chunks : 0;
    return J->sweep_items + J->class_items;
}

static void sweep(lightvol_state *st, int g, const lv_item *items, const int *idx, int n, int overwrite, lv_entry *E) {
    lv_sweep J;
    memset(&J, 0, sizeof J);
    J.st = st;
    J.g = g;
    J.a = g / 2;
    J.s = (g & 1) ? -1 : 1;
    J.au = J.a == 0 ? 1 : 0;
    J.av = J.a == 2 ? 1 : 2;
    J.mu = st->dims[J.au];
    J.mv = st->dims[J.av];
    J.ma = st->dims[J.a];
    J.vs[0] = 1;
    J.vs[1] = (size_t)st->dims[0];
    J.vs[2] = (size_t)st->dims[0] * (size_t)st->dims[1];
    J.area = st->area;
    J.overwrite = overwrite;
    J.fwd = st->p.forward;
    J.forward = st->p.forward > 0.0f;
    J.cone = J.forward && st->p.cone_deg > 0.0f;
    J.tan_c = tanf(st->p.cone_deg * VOLUX_PI / 180.0f) * 0.70710678f; /* disc of radius ρ ↔ 4 taps at ρ/√2 */
    J.rmin2 = rmin2(st);
    J.nplanes = J.forward ? 4 : 1;
    J.post = st->on_grid;
    J.lut = st->lut;
    J.albedo = st->albedo;
    /* the AVX2 row-end steps read 9-column windows */
    J.simd = st->use_simd && J.mu >= 9;
    J.avx512 = J.simd && st->use_avx512;
    J.ne = n;
    /* x sweeps write the volume a whole x-row apart per voxel; staging
     * `LV_DEFER` slices turns that into runs along x (same values) */
    J.defer = J.a == 0 ? LV_DEFER : 0;
    J.e = E;
    size_t plane = st->area;
    for (int i = 0; i < n; i++) {
        lv_entry *e = &E[i];
        memset(e, 0, sizeof *e);
        const lv_item *it = &items[idx[i]];
        e->s = &it->src;
        e->sign = it->sign;
        e->nch = 3;
        e->gain[0] = e->gain[1] = e->gain[2] = 1.0f;
        if (J.simd && !J.forward) {
            e->nch = 1;
            e->norm = it->src;
            e->norm.power = v3(1.0f, 1.0f, 1.0f);
            e->s = &e->norm;
            e->gain[0] = it->src.power.x, e->gain[1] = it->src.power.y, e->gain[2] = it->src.power.z;
        }
        float *b = st->slices + (size_t)i * 6 * plane;
        for (int c = 0; c < 3; c++) {
            e->rd[c] = b + (size_t)c * plane;
            e->wr[c] = b + (size_t)(3 + c) * plane;
        }
        if (e->s->kind == LV_DIRECTIONAL) {
            float w[3] = {e->s->dir.x, e->s->dir.y, e->s->dir.z};
            e->sw = e->sign * e->s->weight[g];
            e->dsw = v3_scale(e->s->dir, e->sw);
            /* Back along the light to the previous slice: one slice spacing
             * along the axis (Ropinski et al. 2010). */
            float t = st->spacing[J.a] / fabsf(w[J.a]);
            float lim = 4.0f * (float)(J.mu + J.mv);
            e->du = clampf(-w[J.au] * t / st->spacing[J.au], -lim, lim);
            e->dv = clampf(-w[J.av] * t / st->spacing[J.av], -lim, lim);
            e->len = t;
            e->tc = make_tap(e->du, e->dv);
            e->di_min = e->di_max = e->tc.di;
            e->dj_min = e->dj_max = e->tc.dj;
            if (J.cone) {
                float rho = t * J.tan_c, ru = rho / st->spacing[J.au], rv = rho / st->spacing[J.av];
                const float ox[4] = {ru, -ru, 0.0f, 0.0f}, oy[4] = {0.0f, 0.0f, rv, -rv};
                for (int q = 0; q < 4; q++) {
                    e->cu[q] = clampf(e->du + ox[q], -lim, lim);
                    e->cv[q] = clampf(e->dv + oy[q], -lim, lim);
                    e->tcone[q] = make_tap(e->cu[q], e->cv[q]);
                    extend(e, e->tcone[q]);
                }
            }
            if (J.cone) build_stencil(e);
            e->nsub = sub_count(e->du, e->dv);
            for (int q = 0; q < e->nsub; q++) {
                float tq = ((float)q + 0.5f) / (float)e->nsub;
                e->su[q] = e->du * (1.0f - tq);
                e->sv[q] = e->dv * (1.0f - tq);
                e->wp[q] = (1.0f - tq) * t / (float)e->nsub;
                e->wc[q] = tq * t / (float)e->nsub;
                e->ts[q] = make_tap(e->su[q], e->sv[q]);
                extend(e, e->ts[q]);
            }
        } else {
            volux_vec3 q = v3_sub(e->s->pos, st->lo);
            e->lidx[0] = q.x / st->spacing[0];
            e->lidx[1] = q.y / st->spacing[1];
            e->lidx[2] = q.z / st->spacing[2];
        }
    }
    /* Work split: chunks of rows worth ~4k voxel·lights each; small slices
     * run on one thread (fork/join would cost more than the work). */
    const size_t sb = med_stride(st);
    int threads = st->threads > 0 ? st->threads : 1;
    size_t work = (size_t)J.mu * (size_t)J.mv * (size_t)(n + 1);
    if (work < 16384) threads = 1;
    size_t row_work = (size_t)J.mu * (size_t)(n + 1);
    J.rows_per_item = (int)((4096 + row_work - 1) / row_work);
    if (J.rows_per_item < 1) J.rows_per_item = 1;
    if (threads > 1 && J.rows_per_item * 4 * threads > J.mv) {
        J.rows_per_item = J.mv / (4 * threads);
        if (J.rows_per_item < 1) J.rows_per_item = 1;
    }
    J.chunks = (J.mv + J.rows_per_item - 1) / J.rows_per_item;
    J.med[0] = st->med;
    J.med[1] = st->med + sb;
    J.med[2] = st->med + 2 * sb;
    /* one parallel region for the whole sweep: a fork/join per slice left the
     * second thread waiting to be woken (or spinning) at every slice */
    volux_parallel_phases(threads, J.ma + 1, sweep_phase, step_item, &J);
    swap_slice_buffers(E, n);
}

/* Runs the planned passes for items; full = the volume is rebuilt from zero. */
static volux_status run(lightvol_state *st, const lv_item *items, int n, int full) {
    volux_context *ctx = st->ctx;
    int coherent = st->p.coherent, maxp = st->p.max_per_pass;
    int np = plan(items, n, coherent, maxp, NULL, NULL);
    st->stats.passes = np;
    st->stats.entries = 0;
    if (np == 0) {
        if (full) memset(st->vol, 0, st->vol_bytes);
        return VOLUX_OK;
    }
    size_t pbytes = (size_t)np * sizeof(lv_pass), ibytes = (size_t)n * LV_GROUPS * sizeof(int);
    lv_pass *passes = volux_malloc(ctx, pbytes);
    int *idx = volux_malloc(ctx, ibytes);
    lv_entry *E = NULL;
    size_t ebytes = 0;
    volux_status s = VOLUX_OK;
    if (!passes || !idx) {
        s = volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the pass plan");
        goto done;
    }
    plan(items, n, coherent, maxp, passes, idx);
    int most = 0;
    for (int i = 0; i < np; i++)
        if (passes[i].n > most) most = passes[i].n;
    if ((s = ensure_scratch(st, most))) goto done;
    ebytes = (size_t)most * sizeof(lv_entry);
    if (!(E = volux_malloc(ctx, ebytes))) {
        s = volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the pass entries");
        goto done;
    }
    for (int i = 0; i < np; i++) {
        sweep(st, passes[i].g, items, idx + passes[i].first, passes[i].n, full && i == 0, E);
        st->stats.entries += passes[i].n;
        if (volux_progress(ctx, "lightvol", (double)(i + 1) / (double)np)) {
            s = volux_error(ctx, VOLUX_ERR_CANCELLED, "lightvol: propagation cancelled");
            goto done;
        }
    }
done:
    volux_free(ctx, E, ebytes);
    volux_free(ctx, passes, pbytes);
    volux_free(ctx, idx, ibytes);
    return s;
}

/* --------------------------------------------------------- light updates */

volux_status volux_lightvol_update_lights(lightvol_state *st, const volux_scene *scene, const volux_change_set *c,
                                          int force_full, const char *reason) {
    volux_context *ctx = st->ctx;
    size_t ibytes = (size_t)VOLUX_MAX_LIGHTS * 3 * sizeof(lv_item), nbytes = (size_t)VOLUX_MAX_LIGHTS * sizeof(lv_applied);
    lv_item *items = volux_malloc(ctx, ibytes);
    lv_applied *next = volux_malloc(ctx, nbytes);
    volux_status s = VOLUX_OK;
    if (!items || !next) {
        s = volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the light update");
        goto done;
    }
    if (!st->valid) force_full = 1, reason = reason ? reason : "illumination volume invalid";
    /* New state of every slot; the changed ones become remove/add items. */
    int n = 0, changed = 0, before = 0, after = 0;
    for (int slot = 0; slot < VOLUX_MAX_LIGHTS; slot++) {
        lv_applied *o = &st->applied[slot], *w = &next[slot];
        if (force_full || volux_change_light(c, slot)) {
            memset(w, 0, sizeof *w);
            const volux_light_desc *d = volux_scene_light(scene, slot);
            w->active = volux_lightvol_source(st, d, &w->src);
            if (d) {
                w->desc = *d;
                w->desc.map = NULL;
            }
        } else {
            *w = *o;
        }
        before += o->active;
        after += w->active;
        if (o->active == w->active && (!o->active || memcmp(&o->src, &w->src, sizeof o->src) == 0)) continue;
        changed++;
        if (o->active) items[n++] = (lv_item){o->src, -1.0f, slot};
        if (w->active) items[n++] = (lv_item){w->src, +1.0f, slot};
    }
    int total = before > after ? before : after;
    st->stats.changed = changed;
    st->stats.total = total;
    if (!force_full && changed == 0) {
        st->stats.last = LV_UPDATE_NONE;
        st->stats.reason = "no light changed";
        st->stats.passes = st->stats.entries = 0;
        goto done;
    }
    /* The full setup, for the cost estimate and a rebuild. */
    int nf = 0;
    lv_item *full_items = items + 2 * VOLUX_MAX_LIGHTS; /* after ≤ 2 items per slot */
    for (int slot = 0; slot < VOLUX_MAX_LIGHTS; slot++)
        if (next[slot].active) full_items[nf++] = (lv_item){next[slot].src, +1.0f, slot};
    int selective = 0;
    if (!force_full) {
        /* §5: rule 1 — at most half of the lights changed; rule 2 — fewer
         * propagation passes than an entire update (ties go to rule 1,
         * since add and remove usually share their passes). */
        int ps = plan(items, n, st->p.coherent, st->p.max_per_pass, NULL, NULL);
        int pf = plan(full_items, nf, st->p.coherent, st->p.max_per_pass, NULL, NULL);
        const lv_work_weights ww = !st->use_simd ? LV_WORK_SCALAR : st->p.forward > 0.0f ? LV_WORK_SIMD_FORWARD : LV_WORK_SIMD;
        double ws = plan_work(items, n, st->p.coherent, st->p.max_per_pass, ww);
        double wf = plan_work(full_items, nf, st->p.coherent, st->p.max_per_pass, ww);
        st->stats.passes_selective = ps;
        st->stats.passes_full = pf;
        st->stats.work_selective = ws;
        st->stats.work_full = wf;
        int rule1 = 2 * changed <= total;
        switch (st->p.cost_rule) {
        case LV_RULE_WORK:
            /* rule 2 with passes weighted by what they carry (ties: rule 1) */
            selective = ws < wf || (ws == wf && rule1), reason = "cost rule: estimated work";
            break;
        case LV_RULE_LIGHTS: selective = rule1, reason = "cost rule: changed lights"; break;
        case LV_RULE_SELECTIVE: selective = 1, reason = "cost rule: always selective"; break;
        case LV_RULE_FULL: selective = 0, reason = "cost rule: always full"; break;
        default: selective = ps < pf || (ps == pf && rule1), reason = "cost rule: propagation passes"; break;
        }
        if (selective && st->p.rebaseline > 0 && st->stats.selective_since_full >= st->p.rebaseline)
            selective = 0, reason = "re-baseline after selective updates";
    }
    if (selective) {
        s = run(st, items, n, 0);
    } else {
        s = run(st, full_items, nf, 1);
    }
    if (s) {
        st->valid = 0;
        goto done;
    }
    memcpy(st->applied, next, nbytes);
    st->valid = 1;
    st->stats.last = selective ? LV_UPDATE_SELECTIVE : LV_UPDATE_FULL;
    st->stats.reason = reason ? reason : "full rebuild";
    if (selective) {
        st->stats.selective_since_full++;
        st->stats.selective_updates++;
    } else {
        st->stats.selective_since_full = 0;
        st->stats.full_rebuilds++;
    }
done:
    volux_free(ctx, items, ibytes);
    volux_free(ctx, next, nbytes);
    return s;
}
