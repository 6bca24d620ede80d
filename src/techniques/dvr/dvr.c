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
        if ((s = volux_volume_build_bricks(rc->volume)) || (s = volux_packet_skip_ranges(rc->ctx, rc->volume, &st->pk)))
            return s;
    }
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY | VOLUX_CHANGE_COLOR))
        if ((s = volux_packet_pre_table(rc->ctx, rc->lut, &st->pk))) return s;
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY))
        if ((s = volux_packet_skip_distance(rc->ctx, rc->lut, &st->pk))) return s;
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
    return st->grad.bytes + volux_packet_tables_bytes(&st->pk) + st->corner_bytes;
}

void volux_dvr_release(void *state) {
    dvr_state *st = state;
    volux_context *ctx = st->rc.ctx;
    volux_gradient_cache_free(ctx, &st->grad);
    volux_dvr_corner_words_free(st);
    volux_packet_tables_free(ctx, &st->pk);
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
            /* a pair can take milliseconds (one loop over every light per
             * shaded sample): a cancel is asked for between pairs */
            if (volux_tile_cancelled(tile)) return;
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
