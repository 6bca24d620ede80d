/* techniques/dvr/dvr.c — the ray-casting kernel shared by `ea` and `shaded`. */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/vecmath.h"
#include "dvr.h"

/* ------------------------------------------------------------------ caches */

static volux_status read_params(dvr_state *st, const volux_scene *scene) {
    const volux_technique_class *cls = st->rc.cls;
    st->preintegrate = (int)volux_technique_param(scene, cls, "preintegrate");
    st->skip_empty = (int)volux_technique_param(scene, cls, "skip_empty");
    st->t_min = (float)volux_technique_param(scene, cls, "early_termination");
    const char *kernel = volux_technique_param_string(scene, cls, "kernel");
    if (!strcmp(kernel, "auto")) st->kernel = DVR_KERNEL_AUTO;
    else if (!strcmp(kernel, "scalar")) st->kernel = DVR_KERNEL_SCALAR;
    else if (!strcmp(kernel, "simd")) st->kernel = DVR_KERNEL_SIMD;
    else if (!strcmp(kernel, "avx2")) st->kernel = DVR_KERNEL_AVX2;
    else
        return volux_error(st->rc.ctx, VOLUX_ERR_INVALID,
                           "techniques.%s.kernel: expected \"auto\", \"scalar\", \"simd\" or \"avx2\", got \"%s\"",
                           cls->info.name, kernel);
    const char *layout = volux_technique_param_string(scene, cls, "volume_layout");
    if (!strcmp(layout, "bricked")) st->layout = DVR_LAYOUT_BRICKED;
    else if (!strcmp(layout, "corner_words")) st->layout = DVR_LAYOUT_CORNER_WORDS;
    else if (!strcmp(layout, "auto")) st->layout = DVR_LAYOUT_AUTO;
    else
        return volux_error(st->rc.ctx, VOLUX_ERR_INVALID,
                           "techniques.%s.volume_layout: expected \"auto\", \"bricked\" or \"corner_words\", got "
                           "\"%s\"",
                           cls->info.name, layout);
    if (st->shaded) {
        st->grad_ref = volux_raycaster_gradient_ref(&st->rc, volux_technique_param(scene, cls, "gradient_threshold"));
        const char *g = volux_technique_param_string(scene, cls, "gradient");
        if (!strcmp(g, "cell")) st->grad_cell = 1;
        else if (!strcmp(g, "cached")) st->grad_cell = 0;
        else
            return volux_error(st->rc.ctx, VOLUX_ERR_INVALID,
                               "techniques.%s.gradient: expected \"cell\" or \"cached\", got \"%s\"",
                               cls->info.name, g);
    }
    return VOLUX_OK;
}

/* The SIMD kernel's float copy of the pre-integration integrals (layout in
 * dvr.h). P is rounded once from the double table; D is the float
 * difference of the rounded P, so P[i+1] − P[i] − D[i] is exactly 0 in
 * float and a segment straddling one node boundary loses nothing to
 * cancellation. Intervals where σt is 0 keep D = 0 exactly (equal doubles
 * round to equal floats), so empty space stays exactly empty. */
static volux_status build_float_tables(dvr_state *st) {
    const volux_transfer_lut *lut = st->rc.lut;
    size_t bytes = (size_t)lut->n * 8 * sizeof(float);
    if (bytes != st->pre_bytes) {
        if (st->pre_f) volux_free_aligned(st->rc.ctx, st->pre_f, st->pre_bytes);
        st->pre_bytes = 0;
        st->pre_f = volux_alloc_aligned(st->rc.ctx, bytes);
        if (!st->pre_f) return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "out of memory for the pre-integration table");
        st->pre_bytes = bytes;
    }
    for (int i = 0; i < lut->n; i++) {
        float *r = st->pre_f + 8 * (size_t)i;
        r[0] = (float)lut->int_sigma[i];
        for (int c = 0; c < 3; c++) r[1 + c] = (float)lut->int_sigma_c[3 * i + c];
    }
    for (int i = 0; i < lut->n; i++) {
        float *r = st->pre_f + 8 * (size_t)i;
        for (int c = 0; c < 4; c++) r[4 + c] = i + 1 < lut->n ? r[8 + c] - r[c] : 0.0f;
    }
    return VOLUX_OK;
}

/* Value range of every skip cell (DVR_SKIP_CELL³ cells, nodes inclusive,
 * so the trilinear field inside a cell lies in its range): TF-independent,
 * built with the volume. Finer than the 8³ macrocells because in real data
 * most samples of a non-empty macrocell still have zero opacity (bonsai:
 * 2.3 M of 14 M samples contribute), and a 4³ cell is empty much more often. */
static volux_status build_skip_ranges(dvr_state *st) {
    const volux_volume *v = st->rc.volume;
    int *c = st->skip_cells;
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        c[a] = (v->dims[a] - 1 + DVR_SKIP_CELL - 1) / DVR_SKIP_CELL;
        if (c[a] < 1) c[a] = 1;
        n *= (size_t)c[a];
    }
    size_t bytes = 2 * n * sizeof(float);
    if (bytes != st->range_bytes) {
        if (st->skip_range) volux_free(st->rc.ctx, st->skip_range, st->range_bytes);
        st->range_bytes = 0;
        st->skip_range = volux_malloc(st->rc.ctx, bytes);
        if (!st->skip_range) return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "out of memory for the skip cells");
        st->range_bytes = bytes;
    }
    for (size_t i = 0; i < n; i++) st->skip_range[2 * i] = INFINITY, st->skip_range[2 * i + 1] = -INFINITY;
    /* every node updates the (up to 8) cells it bounds */
    for (int k = 0; k < v->dims[2]; k++)
        for (int j = 0; j < v->dims[1]; j++)
            for (int i = 0; i < v->dims[0]; i++) {
                float val = volux_volume_raw_at(v, volux_volume_index(v, i, j, k)) + v->value_offset;
                int idx[3] = {i, j, k}, lo[3], hi[3];
                for (int a = 0; a < 3; a++) {
                    hi[a] = idx[a] / DVR_SKIP_CELL;
                    lo[a] = idx[a] % DVR_SKIP_CELL == 0 && hi[a] > 0 ? hi[a] - 1 : hi[a];
                    if (hi[a] > c[a] - 1) hi[a] = c[a] - 1;
                }
                for (int z = lo[2]; z <= hi[2]; z++)
                    for (int y = lo[1]; y <= hi[1]; y++)
                        for (int x = lo[0]; x <= hi[0]; x++) {
                            size_t cell = ((size_t)z * (size_t)c[1] + (size_t)y) * (size_t)c[0] + (size_t)x;
                            float *r = st->skip_range + 2 * cell;
                            if (val < r[0]) r[0] = val;
                            if (val > r[1]) r[1] = val;
                        }
            }
    return VOLUX_OK;
}

/* Chessboard (L∞) distance, in skip cells, from every skip cell to the
 * nearest cell of the other kind, stored signed: d ≥ 1 for an empty cell
 * (σt = 0 on every table node bracketing its value range, the majorant
 * grid's test; all cells within d − 1 of it are empty too), d ≤ −1 for a
 * non-empty one (−d − 1 rings around it hold no empty cell); capped at 127.
 * Why: one lookup tells the SIMD kernel how far a ray can go before the
 * emptiness can change — a whole cube of empty cells to skip, or a cube of
 * non-empty cells to march without checking again — instead of one cell
 * per lookup. Two raster passes of the 3×3×3 chamfer with unit weights
 * give the exact chessboard distance. Rebuilt when extinction changes. */
static volux_status build_skip_distance(dvr_state *st) {
    volux_context *ctx = st->rc.ctx;
    const volux_transfer_lut *lut = st->rc.lut;
    const int nx = st->skip_cells[0], ny = st->skip_cells[1], nz = st->skip_cells[2];
    size_t n = (size_t)nx * (size_t)ny * (size_t)nz, bytes = n + 3;
    if (bytes != st->skip_bytes) {
        if (st->skip_dist) volux_free(ctx, st->skip_dist, st->skip_bytes);
        st->skip_bytes = 0;
        st->skip_dist = volux_malloc(ctx, bytes);
        if (!st->skip_dist) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
        st->skip_bytes = bytes;
    }
    memset(st->skip_dist + n, 0, 3); /* padding read (and discarded) by the 32-bit gathers */
    /* nonzero[i] = number of table nodes below i with σt > 0: a node range
     * [i0, i1] is empty iff nonzero[i1 + 1] == nonzero[i0] (O(1) per cell) */
    size_t nz_bytes = ((size_t)lut->n + 1) * sizeof(int32_t);
    int32_t *nonzero = volux_malloc(ctx, nz_bytes);
    if (!nonzero) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
    nonzero[0] = 0;
    for (int i = 0; i < lut->n; i++) nonzero[i + 1] = nonzero[i] + (lut->sigma_t[i] > 0.0f);
    const int last = lut->n - 1;
    for (size_t c = 0; c < n; c++) {
        /* the majorant grid's bracketing: floor of the low end, ceil of the high */
        float u0 = (st->skip_range[2 * c] - lut->s_min) * lut->inv_ds;
        float u1 = (st->skip_range[2 * c + 1] - lut->s_min) * lut->inv_ds;
        int i0 = (int)floorf(u0), i1 = (int)ceilf(u1);
        if (i0 < 0) i0 = 0;
        if (i0 > last) i0 = last;
        if (i1 > last) i1 = last;
        if (i1 < i0) i1 = i0;
        st->skip_dist[c] = (int8_t)(nonzero[i1 + 1] == nonzero[i0]); /* 1: empty, 0: not (for now) */
    }
    volux_free(ctx, nonzero, nz_bytes);
    /* Chamfer on a grid padded by one cell of CAP (never a source), so the
     * 13 causal neighbours are fixed offsets without bounds tests. */
    enum { CAP = 127 };
    const size_t px = (size_t)nx + 2, py = (size_t)ny + 2, pz = (size_t)nz + 2, pn = px * py * pz;
    size_t tmp_bytes = pn * sizeof(int32_t);
    int32_t *tmp = volux_malloc(ctx, tmp_bytes);
    unsigned char *flag = volux_malloc(ctx, n);
    if (!tmp || !flag) {
        volux_free(ctx, tmp, tmp_bytes);
        volux_free(ctx, flag, n);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
    }
    for (size_t c = 0; c < n; c++) flag[c] = (unsigned char)st->skip_dist[c];
    ptrdiff_t off[13];
    int no = 0;
    for (int dz = -1; dz <= 0; dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++)
                if (!(dz == 0 && (dy > 0 || (dy == 0 && dx >= 0))))
                    off[no++] = ((ptrdiff_t)dz * (ptrdiff_t)py + dy) * (ptrdiff_t)px + dx;
    for (int kind = 0; kind < 2; kind++) { /* 0: empty cells, 1: non-empty cells */
        /* distance from each cell of this kind to the nearest of the other */
        for (size_t i = 0; i < pn; i++) tmp[i] = CAP;
        for (int z = 0; z < nz; z++)
            for (int y = 0; y < ny; y++)
                for (int x = 0; x < nx; x++) {
                    size_t c = ((size_t)z * (size_t)ny + (size_t)y) * (size_t)nx + (size_t)x;
                    tmp[(((size_t)z + 1) * py + (size_t)y + 1) * px + (size_t)x + 1] =
                        (flag[c] != 0) == (kind == 0) ? CAP : 0;
                }
        for (int pass = 0; pass < 2; pass++) {
            const ptrdiff_t dir = pass ? -1 : 1;
            for (int zi = 0; zi < nz; zi++)
                for (int yi = 0; yi < ny; yi++) {
                    int z = pass ? nz - zi : zi + 1, y = pass ? ny - yi : yi + 1;
                    int32_t *row = tmp + ((size_t)z * py + (size_t)y) * px;
                    for (int xi = 0; xi < nx; xi++) {
                        int32_t *t = row + (pass ? nx - xi : xi + 1);
                        int32_t best = *t;
                        if (!best) continue;
                        for (int o = 0; o < 13; o++) {
                            int32_t v = t[dir * off[o]] + 1;
                            if (v < best) best = v;
                        }
                        *t = best;
                    }
                }
        }
        for (int z = 0; z < nz; z++)
            for (int y = 0; y < ny; y++)
                for (int x = 0; x < nx; x++) {
                    size_t c = ((size_t)z * (size_t)ny + (size_t)y) * (size_t)nx + (size_t)x;
                    int32_t d = tmp[(((size_t)z + 1) * py + (size_t)y + 1) * px + (size_t)x + 1];
                    if ((flag[c] != 0) == (kind == 0)) st->skip_dist[c] = (int8_t)(kind == 0 ? d : -d);
                }
    }
    volux_free(ctx, tmp, tmp_bytes);
    volux_free(ctx, flag, n);
    return VOLUX_OK;
}

/* Chooses the kernel from the `kernel` parameter, the CPU and (shaded) the
 * lights: the SIMD shading handles up to DVR_SIMD_MAX_LIGHTS directional
 * lights and the ambient term; point, spot and sphere lights (or more
 * lights) keep the scalar kernel under "auto". */
static volux_status resolve_kernel(dvr_state *st) {
    const volux_light_list *ls = &st->rc.lights;
    int directional_only = ls->n_direct <= DVR_SIMD_MAX_LIGHTS;
    for (int i = 0; i < ls->n_direct; i++) directional_only &= !ls->direct[i].positional;
    int ok = volux_dvr_simd_available() && (!st->shaded || directional_only);
    if ((st->kernel == DVR_KERNEL_SIMD || st->kernel == DVR_KERNEL_AVX2) && !ok)
        return volux_error(st->rc.ctx, VOLUX_ERR_UNSUPPORTED, "techniques.%s.kernel: \"%s\" needs %s",
                           st->rc.cls->info.name, st->kernel == DVR_KERNEL_AVX2 ? "avx2" : "simd",
                           volux_dvr_simd_available() ? "at most 4 lights, all directional (shaded)"
                                                      : "a CPU with AVX2 and FMA");
    st->use_simd = st->kernel != DVR_KERNEL_SCALAR && ok;
    /* the widest packets the CPU has, unless the 8-lane ones are asked for
     * (same image: the per-CPU benchmarks compare them) */
    st->simd_lanes = st->kernel != DVR_KERNEL_AVX2 && volux_dvr_avx512_available() ? 16 : 8;
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ layout per CPU */

int volux_dvr_cpu_is_intel(void) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_cpu_init();
    return __builtin_cpu_is("intel") != 0;
#else
    return 0;
#endif
}

/* volume_layout "auto": corner words on Intel CPUs at steps of at least
 * DVR_CORNER_WORDS_MIN_STEP voxels, the bricked copy everywhere else.
 * Measured (bonsai 512², 1 thread, AVX-512, docs/BENCHMARKS.md "Volume
 * layout per CPU"): on an Intel Xeon (family 6 model 207) corner words
 * took 0.68× the bricked time at step 4 and 1.71× at step 0.5 (its gathers
 * cost more per element, so one 64-bit element beats four 32-bit ones
 * once the samples are far enough apart that the bricked copy's line
 * sharing is lost); on the AMD Zen 4 they were slower at every step (1.07–
 * 1.33×: cheap gathers, and the 8× copy overflows the L3 the bricked copy
 * fits). The Intel crossover between 0.5 and 4 was not measured; 2 is
 * their geometric middle. Images are the same bits either way. */
int volux_dvr_auto_corner_words(int intel, float step_voxels) {
    return intel && step_voxels >= DVR_CORNER_WORDS_MIN_STEP;
}

static void resolve_layout(dvr_state *st) {
    if (st->layout == DVR_LAYOUT_AUTO) {
        static int intel = -1; /* the CPU does not change within a process */
        if (intel < 0) intel = volux_dvr_cpu_is_intel();
        st->corner_words = volux_dvr_auto_corner_words(intel, st->rc.step / st->rc.min_spacing);
    } else {
        st->corner_words = st->layout == DVR_LAYOUT_CORNER_WORDS;
    }
}

void volux_dvr_init(void *state) {
    dvr_state *st = state;
    st->shaded = st->rc.cls == &volux_shaded_class;
}

volux_status volux_dvr_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    dvr_state *st = state;
    volux_raycaster *rc = &st->rc;
    const uint32_t w = c->what;
    volux_status s;
    if (w & VOLUX_CHANGE_VOLUME) {
        if ((s = volux_volume_build_bricks(rc->volume)) || (s = build_skip_ranges(st))) return s;
    }
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY | VOLUX_CHANGE_COLOR))
        if ((s = build_float_tables(st))) return s;
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY))
        if ((s = build_skip_distance(st))) return s;
    if (w & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        if ((s = read_params(st, scene))) return s;
        /* the gradient cache only for `gradient: "cached"` (4 bytes per node) */
        if (st->shaded && !st->grad_cell && (!st->grad.grad || (w & VOLUX_CHANGE_VOLUME))) {
            if ((s = volux_gradient_cache_build(rc->ctx, rc->volume, &st->grad, "shaded"))) return s;
        } else if (st->grad_cell) {
            volux_gradient_cache_free(rc->ctx, &st->grad);
        }
    }
    /* Without an environment the ambient light is white of radiance 1, the
     * convention of VTK/ParaView's `ambient` coefficient; an environment
     * acts through its mean radiance. */
    if (w & VOLUX_CHANGE_LIGHTS) st->ambient = rc->lights.n_env ? rc->lights.env_mean : v3(1, 1, 1);
    if (w & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_LIGHTS))
        if ((s = resolve_kernel(st))) return s;
    /* the layout follows the step under "auto" (RENDER) */
    if (w & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_LIGHTS | VOLUX_CHANGE_RENDER)) {
        resolve_layout(st);
        if ((s = volux_dvr_corner_words_update(st, (w & VOLUX_CHANGE_VOLUME) != 0))) return s;
    }
    return VOLUX_OK;
}

size_t volux_dvr_memory_bytes(const void *state) {
    const dvr_state *st = state;
    return st->grad.bytes + st->pre_bytes + st->skip_bytes + st->range_bytes + st->corner_bytes;
}

void volux_dvr_release(void *state) {
    dvr_state *st = state;
    volux_context *ctx = st->rc.ctx;
    volux_gradient_cache_free(ctx, &st->grad);
    volux_dvr_corner_words_free(st);
    if (st->pre_f) volux_free_aligned(ctx, st->pre_f, st->pre_bytes);
    if (st->skip_dist) volux_free(ctx, st->skip_dist, st->skip_bytes);
    if (st->skip_range) volux_free(ctx, st->skip_range, st->range_bytes);
}

/* ------------------------------------------------------------------ kernel */

/* Blinn–Phong with the normal flipped towards the viewer (as VTK's CPU ray
 * caster does), faded by gradient magnitude. c: emission colour in/out. */
static inline void shade(const dvr_state *st, volux_vec3 p_world, volux_vec3 q, volux_vec3 view_dir, float c[3]) {
    volux_vec3 n;
    volux_vec3 g = st->grad_cell ? volux_cell_gradient_bricked(st->rc.volume, q)
                                 : volux_gradient_cache_sample(&st->grad, st->rc.volume, q);
    float m = volux_shading_normal(g, st->grad_ref, view_dir, &n);
    if (m <= 0.0f) return;
    const volux_material *mat = &st->rc.material;
    const volux_light_list *ls = &st->rc.lights;
    volux_vec3 diff = v3_scale(st->ambient, mat->ambient), spec = v3(0, 0, 0);
    for (int i = 0; i < ls->n_direct; i++) {
        const volux_prepared_light *l = &ls->direct[i];
        volux_vec3 L = v3_scale(l->travel, -1.0f), E = l->power;
        if (l->positional) {
            volux_vec3 to = v3_sub(l->pos, p_world);
            float d2 = v3_dot(to, to);
            if (d2 <= 0.0f) continue;
            L = v3_scale(to, 1.0f / sqrtf(d2));
            float f = 1.0f / d2;
            if (l->spot) f *= volux_spot_falloff(l->desc, -v3_dot(L, l->axis));
            E = v3_scale(E, f);
        }
        volux_blinn_phong(mat, n, L, view_dir, E, &diff, &spec);
    }
    float lit[3] = {c[0] * diff.x + spec.x, c[1] * diff.y + spec.y, c[2] * diff.z + spec.z};
    for (int a = 0; a < 3; a++) c[a] += (lit[a] - c[a]) * m;
}

/* The scalar kernel is one loop specialised at compile time by `variant`:
 * bit 0 shaded, bit 1 pre-integrated, bits 2–3 the volume's storage. */
enum { DVR_SHADED = 1, DVR_PREINT = 2 };
#define DVR_VARIANT(shaded, preint, storage) ((shaded) | (preint) << 1 | (int)(storage) << 2)

/* What the scalar sampler needs of the volume, computed once per tile
 * instead of per sample: the highest cell index per axis (dims − 2, as
 * volux_volume_cell clamps) and the brick strides in nodes, so a sample's
 * brick offset is (i>>3)·729 + (j>>3)·sy + (k>>3)·sz plus the offset inside
 * the brick — the same integer as volux_volume_sample_bricked's brick
 * index · 729, and the same trilinear arithmetic, so the same bits. Why:
 * the loop is instruction-bound, and per sample it re-read the volume's
 * dims and brick counts and re-derived the clamps and the brick index (two
 * 64-bit multiplies and three ·9 steps): ≈ 20 of its ≈ 150 instructions. */
typedef struct scalar_ctx {
    const dvr_state *st;
    const unsigned char *bricks;
    int imax[3];
    size_t sy, sz;
    float offset;
} scalar_ctx;

static inline void scalar_ctx_init(scalar_ctx *sc, const dvr_state *st) {
    const volux_volume *v = st->rc.volume;
    sc->st = st;
    sc->bricks = v->bricks;
    for (int a = 0; a < 3; a++) sc->imax[a] = v->dims[a] > 1 ? v->dims[a] - 2 : 0;
    sc->sy = (size_t)v->brick_counts[0] * VOLUX_BRICK_VOXELS;
    sc->sz = (size_t)v->brick_counts[0] * (size_t)v->brick_counts[1] * VOLUX_BRICK_VOXELS;
    sc->offset = v->value_offset;
}

static inline __attribute__((always_inline)) float sample_at(const void *tech, const volux_ray *r, float t,
                                                              int variant) {
    const scalar_ctx *sc = tech;
    const float x = r->q0.x + r->dq.x * t, y = r->q0.y + r->dq.y * t, z = r->q0.z + r->dq.z * t;
    int i = (int)x, j = (int)y, k = (int)z;
    i = i > sc->imax[0] ? sc->imax[0] : i < 0 ? 0 : i;
    j = j > sc->imax[1] ? sc->imax[1] : j < 0 ? 0 : j;
    k = k > sc->imax[2] ? sc->imax[2] : k < 0 ? 0 : k;
    const float fx = x - (float)i, fy = y - (float)j, fz = z - (float)k;
    enum { SY = VOLUX_BRICK_NODES, SZ = VOLUX_BRICK_NODES * VOLUX_BRICK_NODES };
    const size_t b = (size_t)(i >> 3) * VOLUX_BRICK_VOXELS + (size_t)(j >> 3) * sc->sy + (size_t)(k >> 3) * sc->sz +
                     (size_t)((i & 7) + SY * (j & 7) + SZ * (k & 7));
    float n[8];
#define VOLUX_FETCH_(T)                                                                                           \
    do {                                                                                                          \
        const T *p = (const T *)(const void *)sc->bricks + b;                                                     \
        n[0] = p[0], n[1] = p[1], n[2] = p[SY], n[3] = p[SY + 1];                                                 \
        n[4] = p[SZ], n[5] = p[SZ + 1], n[6] = p[SZ + SY], n[7] = p[SZ + SY + 1];                                 \
    } while (0)
    const volux_storage storage = (volux_storage)(variant >> 2);
    if (storage == VOLUX_STORE_U8) VOLUX_FETCH_(uint8_t);
    else if (storage == VOLUX_STORE_U16) VOLUX_FETCH_(uint16_t);
    else VOLUX_FETCH_(float);
#undef VOLUX_FETCH_
    return volux_lerp3(n, fx, fy, fz) + sc->offset;
}

static inline __attribute__((always_inline)) void shade_at(const void *tech, const volux_ray *ray, float t,
                                                            float c[3], int variant) {
    const scalar_ctx *sc = tech;
    if (variant & DVR_SHADED) shade(sc->st, v3_madd(ray->o, ray->d, t), v3_madd(ray->q0, ray->dq, t), ray->d, c);
}

static inline __attribute__((always_inline)) volux_vec3 integrate(const void *tech, const volux_ray *ray,
                                                                   float jitter, float *T, uint64_t *samples,
                                                                   int variant) {
    const dvr_state *st = ((const scalar_ctx *)tech)->st;
    const volux_ea_march_desc m = {st->rc.lut, st->skip_empty ? &st->rc.grid : NULL, st->rc.step, st->t_min};
    return volux_ea_march(&m, tech, ray, jitter, T, samples, (variant & DVR_PREINT) != 0, sample_at,
                          (variant & DVR_SHADED) ? shade_at : NULL, variant);
}

/* ---- two rays per loop iteration (the scalar tile loop) ----
 * One ray's march is the operations of volux_ea_march, per ray and in the
 * same order, so every pixel has the same bits; two rays advance in one
 * loop so that the out-of-order core has two independent sample chains
 * (position → brick → 8 loads → trilinear → table → τ) side by side. */
typedef struct ray_march {
    volux_ray ray;
    volux_segments seg;
    volux_march_iter it;
    volux_preint pi;
    float T, C[3];
    int live;
} ray_march;

static inline __attribute__((always_inline)) void ray_march_init(ray_march *r, const volux_ea_march_desc *m,
                                                                  float jitter) {
    r->T = 1.0f;
    r->C[0] = r->C[1] = r->C[2] = 0.0f;
    r->live = 1;
    volux_segments_init(&r->seg, &r->it, m->grid, &r->ray, m->step, jitter);
    r->pi = (volux_preint){0.0f, 0.0, {0.0, 0.0, 0.0}};
}

/* The body of volux_ea_march's loop for segment (a, b]; returns 0 when
 * the ray terminates early. */
static inline __attribute__((always_inline)) int ray_march_step(const volux_ea_march_desc *m, const void *tech,
                                                                 ray_march *r, float a, float b, int gap,
                                                                 uint64_t *count, int variant) {
    const volux_transfer_lut *lut = m->lut;
    const int preint = (variant & DVR_PREINT) != 0;
    if (preint && gap) {
        volux_preint_front(lut, sample_at(tech, &r->ray, a, variant), &r->pi);
        ++*count;
    }
    float s = sample_at(tech, &r->ray, b, variant), c[3];
    float tau = preint ? volux_preint_segment(lut, &r->pi, s, b - a, c) : volux_point_segment(lut, s, b - a, c);
    ++*count;
    if (tau <= 0.0f) return 1;
    if (variant & DVR_SHADED) shade_at(tech, &r->ray, b, c, variant);
    float alpha = 1.0f - expf(-tau);
    float w = r->T * alpha;
    r->C[0] += w * c[0];
    r->C[1] += w * c[1];
    r->C[2] += w * c[2];
    r->T -= w;
    return !(r->T < m->t_min);
}

static inline __attribute__((always_inline)) void march_pair(const volux_ea_march_desc *m, const void *tech,
                                                             ray_march r[2], uint64_t *count, int variant) {
    for (;;) {
        float a0 = 0.0f, b0 = 0.0f, a1 = 0.0f, b1 = 0.0f; /* (set when h0 / h1) */
        int g0 = 0, g1 = 0;
        const int h0 = volux_segments_next(&r[0].seg, &a0, &b0, &g0);
        const int h1 = volux_segments_next(&r[1].seg, &a1, &b1, &g1);
        if (!(h0 && h1)) {
            /* one ray (or none) left: finish it alone */
            ray_march *last = h0 ? &r[0] : h1 ? &r[1] : NULL;
            if (!last) return;
            float a = h0 ? a0 : a1, b = h0 ? b0 : b1;
            int gap = h0 ? g0 : g1;
            if (!ray_march_step(m, tech, last, a, b, gap, count, variant)) return;
            while (volux_segments_next(&last->seg, &a, &b, &gap))
                if (!ray_march_step(m, tech, last, a, b, gap, count, variant)) return;
            return;
        }
        const int k0 = ray_march_step(m, tech, &r[0], a0, b0, g0, count, variant);
        const int k1 = ray_march_step(m, tech, &r[1], a1, b1, g1, count, variant);
        if (!k0 || !k1) {
            ray_march *last = k0 ? &r[0] : k1 ? &r[1] : NULL;
            if (!last) return;
            float a, b;
            int gap;
            while (volux_segments_next(&last->seg, &a, &b, &gap))
                if (!ray_march_step(m, tech, last, a, b, gap, count, variant)) return;
            return;
        }
    }
}

/* volux_raycaster_tile with the rays that hit the volume marched in pairs. */
static inline __attribute__((always_inline)) void tile_pairs(const dvr_state *st, const void *tech,
                                                             const volux_scene *scene, const volux_tile *tile,
                                                             float *rgb, volux_tile_stats *stats, int variant) {
    const volux_raycaster *rc = &st->rc;
    const volux_ea_march_desc m = {rc->lut, st->skip_empty ? &rc->grid : NULL, rc->step, st->t_min};
    uint64_t count = 0;
    ray_march r[2];
    volux_vec3 bg[2];
    float *out[2];
    int n = 0;
    for (int y = 0; y < tile->h; y++)
        for (int x = 0; x < tile->w; x++) {
            volux_primary pr = volux_primary_ray(&rc->camera, rc->seed, tile->x0 + x, tile->y0 + y, tile->sample_index);
            volux_vec3 e = volux_scene_escape_radiance(scene, pr.d);
            float *o = &rgb[3 * (y * tile->w + x)];
            if (!volux_ray_clip(rc->volume, pr.o, pr.d, &r[n].ray)) {
                o[0] = e.x, o[1] = e.y, o[2] = e.z;
                continue;
            }
            ray_march_init(&r[n], &m, pr.jitter);
            bg[n] = e;
            out[n] = o;
            if (++n < 2) continue;
            march_pair(&m, tech, r, &count, variant);
            for (int q = 0; q < 2; q++) {
                out[q][0] = r[q].C[0] + r[q].T * bg[q].x;
                out[q][1] = r[q].C[1] + r[q].T * bg[q].y;
                out[q][2] = r[q].C[2] + r[q].T * bg[q].z;
            }
            n = 0;
        }
    if (n) { /* an odd ray out */
        float a, b;
        int gap;
        while (volux_segments_next(&r[0].seg, &a, &b, &gap))
            if (!ray_march_step(&m, tech, &r[0], a, b, gap, &count, variant)) break;
        out[0][0] = r[0].C[0] + r[0].T * bg[0].x;
        out[0][1] = r[0].C[1] + r[0].T * bg[0].y;
        out[0][2] = r[0].C[2] + r[0].T * bg[0].z;
    }
    stats->samples += count;
}

static inline __attribute__((always_inline)) void tile_as(const dvr_state *st, const volux_scene *scene,
                                                           const volux_tile *tile, float *rgb,
                                                           volux_tile_stats *stats, int shaded, int preint) {
    scalar_ctx sc;
    scalar_ctx_init(&sc, st);
    switch (st->rc.volume->storage) {
    case VOLUX_STORE_U8:
        tile_pairs(st, &sc, scene, tile, rgb, stats, DVR_VARIANT(shaded, preint, VOLUX_STORE_U8));
        break;
    case VOLUX_STORE_U16:
        tile_pairs(st, &sc, scene, tile, rgb, stats, DVR_VARIANT(shaded, preint, VOLUX_STORE_U16));
        break;
    default:
        tile_pairs(st, &sc, scene, tile, rgb, stats, DVR_VARIANT(shaded, preint, VOLUX_STORE_F32));
        break;
    }
}

/* The scalar kernel twice: for x86-64-v3 (AVX2, BMI, FMA: VEX encodings,
 * roundss for floorf; C11 keeps fp-contract off, so no multiply-add is
 * fused and the image has the same bits) and the baseline, picked once at
 * load time (ifunc). Measured on Zen 4: 43–44 → 46 M samples/CPU-s for the
 * whole loop compiled that way (docs/BENCHMARKS.md, session 4). */
#if defined(__x86_64__) && defined(__GNUC__) && defined(__ELF__)
#define VOLUX_SCALAR_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define VOLUX_SCALAR_CLONES
#endif

VOLUX_SCALAR_CLONES static void scalar_tile(const dvr_state *st, const volux_scene *scene, const volux_tile *tile,
                                            float *rgb, volux_tile_stats *stats) {
    if (st->shaded && st->preintegrate) tile_as(st, scene, tile, rgb, stats, 1, 1);
    else if (st->shaded) tile_as(st, scene, tile, rgb, stats, 1, 0);
    else if (st->preintegrate) tile_as(st, scene, tile, rgb, stats, 0, 1);
    else tile_as(st, scene, tile, rgb, stats, 0, 0);
}

void volux_dvr_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                           volux_tile_stats *stats) {
    const dvr_state *st = state;
    if (st->use_simd && st->simd_lanes == 16) volux_dvr_render_tile_avx512(st, scene, tile, rgb, stats);
    else if (st->use_simd) volux_dvr_render_tile_avx2(st, scene, tile, rgb, stats);
    else scalar_tile(st, scene, tile, rgb, stats);
}

static inline __attribute__((always_inline)) void part_as(const dvr_state *st, const volux_scene *scene,
                                                           const volux_tile *tile, int background, float *rgbt,
                                                           volux_tile_stats *stats, int shaded, int preint) {
    scalar_ctx sc;
    scalar_ctx_init(&sc, st);
    switch (st->rc.volume->storage) {
    case VOLUX_STORE_U8:
        volux_raycaster_tile_part(&st->rc, &sc, scene, tile, background, rgbt, stats, integrate,
                                  DVR_VARIANT(shaded, preint, VOLUX_STORE_U8));
        break;
    case VOLUX_STORE_U16:
        volux_raycaster_tile_part(&st->rc, &sc, scene, tile, background, rgbt, stats, integrate,
                                  DVR_VARIANT(shaded, preint, VOLUX_STORE_U16));
        break;
    default:
        volux_raycaster_tile_part(&st->rc, &sc, scene, tile, background, rgbt, stats, integrate,
                                  DVR_VARIANT(shaded, preint, VOLUX_STORE_F32));
        break;
    }
}

void volux_dvr_render_tile_part(const void *state, const volux_scene *scene, const volux_tile *tile, int background,
                                float *rgbt, volux_tile_stats *stats) {
    const dvr_state *st = state;
    if (st->shaded && st->preintegrate) part_as(st, scene, tile, background, rgbt, stats, 1, 1);
    else if (st->shaded) part_as(st, scene, tile, background, rgbt, stats, 1, 0);
    else if (st->preintegrate) part_as(st, scene, tile, background, rgbt, stats, 0, 1);
    else part_as(st, scene, tile, background, rgbt, stats, 0, 0);
}
