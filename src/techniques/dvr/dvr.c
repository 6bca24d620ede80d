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
    if (st->shaded)
        st->grad_ref = volux_raycaster_gradient_ref(&st->rc, volux_technique_param(scene, cls, "gradient_threshold"));
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
        if ((s = volux_volume_build_bricks(rc->volume)) || (s = volux_dvr_skip_ranges(rc->ctx, rc->volume, &st->skip)))
            return s;
        if (st->shaded && (s = volux_gradient_cache_build(rc->ctx, rc->volume, &st->grad, "shaded"))) return s;
    }
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY | VOLUX_CHANGE_COLOR))
        if ((s = build_float_tables(st))) return s;
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY))
        if ((s = volux_dvr_skip_classify(rc->ctx, rc->volume, rc->lut, &st->skip))) return s;
    if (w & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME))
        if ((s = read_params(st, scene))) return s;
    /* Without an environment the ambient light is white of radiance 1, the
     * convention of VTK/ParaView's `ambient` coefficient; an environment
     * acts through its mean radiance. */
    if (w & VOLUX_CHANGE_LIGHTS) st->ambient = rc->lights.n_env ? rc->lights.env_mean : v3(1, 1, 1);
    if (w & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_LIGHTS))
        if ((s = resolve_kernel(st))) return s;
    return VOLUX_OK;
}

size_t volux_dvr_memory_bytes(const void *state) {
    const dvr_state *st = state;
    return st->grad.bytes + st->pre_bytes + 2 * st->skip.bytes + st->skip.range_bytes + st->skip.sub_bytes;
}

void volux_dvr_release(void *state) {
    dvr_state *st = state;
    volux_context *ctx = st->rc.ctx;
    volux_gradient_cache_free(ctx, &st->grad);
    if (st->pre_f) volux_free_aligned(ctx, st->pre_f, st->pre_bytes);
    volux_dvr_skip_free(ctx, &st->skip);
}

/* ------------------------------------------------------------------ kernel */

/* Blinn–Phong with the normal flipped towards the viewer (as VTK's CPU ray
 * caster does), faded by gradient magnitude. c: emission colour in/out. */
static inline void shade(const dvr_state *st, volux_vec3 p_world, volux_vec3 q, volux_vec3 view_dir, float c[3]) {
    volux_vec3 n;
    float m = volux_shading_normal(volux_gradient_cache_sample(&st->grad, st->rc.volume, q), st->grad_ref, view_dir,
                                   &n);
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

static inline __attribute__((always_inline)) float sample_at(const void *tech, const volux_ray *r, float t,
                                                              int variant) {
    const dvr_state *st = tech;
    return volux_volume_sample_bricked(st->rc.volume, r->q0.x + r->dq.x * t, r->q0.y + r->dq.y * t,
                                       r->q0.z + r->dq.z * t, (volux_storage)(variant >> 2));
}

static inline __attribute__((always_inline)) void shade_at(const void *tech, const volux_ray *ray, float t,
                                                            float c[3], int variant) {
    if (variant & DVR_SHADED) shade(tech, v3_madd(ray->o, ray->d, t), v3_madd(ray->q0, ray->dq, t), ray->d, c);
}

static inline __attribute__((always_inline)) volux_vec3 integrate(const void *tech, const volux_ray *ray,
                                                                   float jitter, float *T, uint64_t *samples,
                                                                   int variant) {
    const dvr_state *st = tech;
    const volux_ea_march_desc m = {st->rc.lut, st->skip_empty ? &st->rc.grid : NULL, st->rc.step, st->t_min};
    return volux_ea_march(&m, tech, ray, jitter, T, samples, (variant & DVR_PREINT) != 0, sample_at,
                          (variant & DVR_SHADED) ? shade_at : NULL, variant);
}

static inline __attribute__((always_inline)) void tile_as(const dvr_state *st, const volux_scene *scene,
                                                           const volux_tile *tile, float *rgb,
                                                           volux_tile_stats *stats, int shaded, int preint) {
    switch (st->rc.volume->storage) {
    case VOLUX_STORE_U8:
        volux_raycaster_tile(&st->rc, st, scene, tile, rgb, stats, integrate, DVR_VARIANT(shaded, preint, VOLUX_STORE_U8));
        break;
    case VOLUX_STORE_U16:
        volux_raycaster_tile(&st->rc, st, scene, tile, rgb, stats, integrate,
                             DVR_VARIANT(shaded, preint, VOLUX_STORE_U16));
        break;
    default:
        volux_raycaster_tile(&st->rc, st, scene, tile, rgb, stats, integrate,
                             DVR_VARIANT(shaded, preint, VOLUX_STORE_F32));
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
    switch (st->rc.volume->storage) {
    case VOLUX_STORE_U8:
        volux_raycaster_tile_part(&st->rc, st, scene, tile, background, rgbt, stats, integrate,
                                  DVR_VARIANT(shaded, preint, VOLUX_STORE_U8));
        break;
    case VOLUX_STORE_U16:
        volux_raycaster_tile_part(&st->rc, st, scene, tile, background, rgbt, stats, integrate,
                                  DVR_VARIANT(shaded, preint, VOLUX_STORE_U16));
        break;
    default:
        volux_raycaster_tile_part(&st->rc, st, scene, tile, background, rgbt, stats, integrate,
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
