/* techniques/dvr/dvr.c — the ray-casting kernel shared by `ea` and `shaded`. */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/rng.h"
#include "core/vecmath.h"
#include "dvr.h"
#include "sample/primary.h"
#include "sample/segment.h"

/* ------------------------------------------------------------------ caches */

static void prepare_lights(dvr_state *st, const volux_scene *scene) {
    st->n_lights = 0;
    volux_vec3 ambient = v3(0, 0, 0);
    int have_env = 0;
    for (int i = 0; i < volux_scene_light_slots(scene); i++) {
        const volux_light_desc *d = volux_scene_light(scene, i);
        if (!d || !d->enabled) continue;
        if (d->type == VOLUX_LIGHT_ENVIRONMENT) {
            /* An environment acts as the ambient term: its mean radiance. */
            have_env = 1;
            if (d->map) {
                double sum[3] = {0, 0, 0}, wsum = 0.0;
                const volux_image *m = d->map;
                for (int y = 0; y < m->height; y++) {
                    double w = sin(M_PI * (y + 0.5) / m->height); /* solid angle of the row */
                    for (int x = 0; x < m->width; x++)
                        for (int c = 0; c < 3; c++)
                            sum[c] += w * fmax(m->rgb[3 * ((size_t)y * (size_t)m->width + (size_t)x) + c], 0.0);
                    wsum += w * m->width;
                }
                ambient = v3_add(ambient, v3_scale(v3_mul(v3((float)(sum[0] / wsum), (float)(sum[1] / wsum),
                                                           (float)(sum[2] / wsum)),
                                                        d->color),
                                                 d->intensity));
            } else {
                ambient = v3_add(ambient, v3_scale(d->color, d->radiance));
            }
            continue;
        }
        if (st->n_lights >= DVR_MAX_LIGHTS) continue;
        dvr_light *l = &st->lights[st->n_lights++];
        memset(l, 0, sizeof *l);
        l->desc = *d;
        switch (d->type) {
        case VOLUX_LIGHT_DIRECTIONAL:
            l->kind = 0;
            l->dir_to = v3_scale(v3_normalize(d->direction), -1.0f);
            l->power = v3_scale(d->color, d->irradiance);
            break;
        case VOLUX_LIGHT_SPHERE:
            /* Irradiance from a sphere of radiance L, radius r at distance
             * d > r facing it: E = L·π·r²/d², i.e. a point of I = L·π·r². */
            l->kind = 1;
            l->pos = d->position;
            l->power = v3_scale(d->color, d->radiance * VOLUX_PI * d->radius * d->radius);
            break;
        default:
            l->kind = 1;
            l->pos = d->position;
            l->power = v3_scale(d->color, d->intensity);
            l->spot = d->type == VOLUX_LIGHT_SPOT;
            l->spot_dir = v3_normalize(d->direction);
            break;
        }
    }
    /* Without an environment the ambient light is white of radiance 1, the
     * convention of VTK/ParaView's `ambient` coefficient. */
    st->ambient = have_env ? ambient : v3(1, 1, 1);
}

static volux_status read_params(dvr_state *st, const volux_scene *scene) {
    st->preintegrate = (int)volux_technique_param(scene, st->cls, "preintegrate");
    st->skip_empty = (int)volux_technique_param(scene, st->cls, "skip_empty");
    st->t_min = (float)volux_technique_param(scene, st->cls, "early_termination");
    const char *kernel = volux_scene_param_string(scene, st->cls->name, "kernel", "auto");
    if (!strcmp(kernel, "auto")) st->kernel = DVR_KERNEL_AUTO;
    else if (!strcmp(kernel, "scalar")) st->kernel = DVR_KERNEL_SCALAR;
    else if (!strcmp(kernel, "simd")) st->kernel = DVR_KERNEL_SIMD;
    else
        return volux_error(st->ctx, VOLUX_ERR_INVALID,
                           "techniques.%s.kernel: expected \"auto\", \"scalar\" or \"simd\", got \"%s\"",
                           st->cls->name, kernel);
    if (st->shaded) {
        double lo, hi, sp[3];
        volux_volume_range(st->volume, &lo, &hi);
        volux_volume_spacing(st->volume, sp);
        double range = hi > lo ? hi - lo : 1.0;
        st->grad_ref = (float)(volux_technique_param(scene, st->cls, "gradient_threshold") * range /
                               fmin(sp[0], fmin(sp[1], sp[2])));
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
    const volux_transfer_lut *lut = st->lut;
    size_t bytes = (size_t)lut->n * 8 * sizeof(float);
    if (bytes != st->pre_bytes) {
        if (st->pre_f) volux_free_aligned(st->ctx, st->pre_f, st->pre_bytes);
        st->pre_bytes = 0;
        st->pre_f = volux_alloc_aligned(st->ctx, bytes);
        if (!st->pre_f) return volux_error(st->ctx, VOLUX_ERR_NOMEM, "out of memory for the pre-integration table");
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
    const volux_volume *v = st->volume;
    int *c = st->skip_cells;
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        c[a] = (v->dims[a] - 1 + DVR_SKIP_CELL - 1) / DVR_SKIP_CELL;
        if (c[a] < 1) c[a] = 1;
        n *= (size_t)c[a];
    }
    size_t bytes = 2 * n * sizeof(float);
    if (bytes != st->range_bytes) {
        if (st->skip_range) volux_free(st->ctx, st->skip_range, st->range_bytes);
        st->range_bytes = 0;
        st->skip_range = volux_malloc(st->ctx, bytes);
        if (!st->skip_range) return volux_error(st->ctx, VOLUX_ERR_NOMEM, "out of memory for the skip cells");
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
    const volux_transfer_lut *lut = st->lut;
    const int nx = st->skip_cells[0], ny = st->skip_cells[1], nz = st->skip_cells[2];
    size_t n = (size_t)nx * (size_t)ny * (size_t)nz, bytes = n * sizeof(int32_t);
    if (bytes != st->skip_bytes) {
        if (st->skip_dist) volux_free(st->ctx, st->skip_dist, st->skip_bytes);
        st->skip_bytes = 0;
        st->skip_dist = volux_malloc(st->ctx, bytes);
        if (!st->skip_dist) return volux_error(st->ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
        st->skip_bytes = bytes;
    }
    /* nonzero[i] = number of table nodes below i with σt > 0: a node range
     * [i0, i1] is empty iff nonzero[i1 + 1] == nonzero[i0] (O(1) per cell) */
    size_t nz_bytes = ((size_t)lut->n + 1) * sizeof(int32_t);
    int32_t *nonzero = volux_malloc(st->ctx, nz_bytes);
    if (!nonzero) return volux_error(st->ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
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
        st->skip_dist[c] = nonzero[i1 + 1] == nonzero[i0]; /* 1: empty, 0: not (for now) */
    }
    volux_free(st->ctx, nonzero, nz_bytes);
    /* Chamfer on a grid padded by one cell of CAP (never a source), so the
     * 13 causal neighbours are fixed offsets without bounds tests. */
    enum { CAP = 127 };
    const size_t px = (size_t)nx + 2, py = (size_t)ny + 2, pz = (size_t)nz + 2, pn = px * py * pz;
    size_t tmp_bytes = pn * sizeof(int32_t);
    int32_t *tmp = volux_malloc(st->ctx, tmp_bytes);
    unsigned char *flag = volux_malloc(st->ctx, n);
    if (!tmp || !flag) {
        volux_free(st->ctx, tmp, tmp_bytes);
        volux_free(st->ctx, flag, n);
        return volux_error(st->ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
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
                    if ((flag[c] != 0) == (kind == 0)) st->skip_dist[c] = kind == 0 ? d : -d;
                }
    }
    volux_free(st->ctx, tmp, tmp_bytes);
    volux_free(st->ctx, flag, n);
    return VOLUX_OK;
}

/* Chooses the kernel from the `kernel` parameter, the CPU and (shaded) the
 * lights: the SIMD shading handles up to DVR_SIMD_MAX_LIGHTS directional
 * lights and the ambient term; point, spot and sphere lights (or more
 * lights) keep the scalar kernel under "auto". */
static volux_status resolve_kernel(dvr_state *st) {
    int directional_only = st->n_lights <= DVR_SIMD_MAX_LIGHTS;
    for (int i = 0; i < st->n_lights; i++) directional_only &= st->lights[i].kind == 0;
    int ok = volux_dvr_simd_available() && (!st->shaded || directional_only);
    if (st->kernel == DVR_KERNEL_SIMD && !ok)
        return volux_error(st->ctx, VOLUX_ERR_UNSUPPORTED, "techniques.%s.kernel: \"simd\" needs %s",
                           st->cls->name,
                           volux_dvr_simd_available() ? "at most 4 lights, all directional (shaded)"
                                                      : "a CPU with AVX2 and FMA");
    st->use_simd = st->kernel != DVR_KERNEL_SCALAR && ok;
    return VOLUX_OK;
}

volux_status volux_dvr_update(void *state, volux_scene *scene, const volux_change_set *c) {
    dvr_state *st = state;
    volux_status s;
    if (c->what & VOLUX_CHANGE_VOLUME) {
        volux_volume *v = volux_scene_volume(scene);
        volux_volume_retain(v);
        volux_volume_release(st->volume);
        st->volume = v;
        if ((s = volux_volume_build_bricks(v)) || (s = build_skip_ranges(st))) return s;
        if (st->shaded && (s = volux_gradient_cache_build(st->ctx, st->volume, &st->grad, "shaded"))) return s;
    }
    if (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY | VOLUX_CHANGE_COLOR)) {
        st->lut = volux_scene_transfer_lut(scene);
        if (!st->lut) return volux_context_error_status(st->ctx) ? volux_context_error_status(st->ctx) : VOLUX_ERR_INVALID;
        if ((s = build_float_tables(st))) return s;
    }
    if (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY))
        if ((s = volux_majorant_grid_build(st->ctx, st->volume, st->lut, &st->grid)) || (s = build_skip_distance(st)))
            return s;
    if (c->what & (VOLUX_CHANGE_CAMERA | VOLUX_CHANGE_RENDER | VOLUX_CHANGE_VOLUME))
        if ((s = volux_scene_camera(scene, &st->camera))) return s;
    if (c->what & (VOLUX_CHANGE_RENDER | VOLUX_CHANGE_VOLUME)) {
        st->step = volux_scene_step_world(scene);
        st->seed = volux_scene_render(scene)->seed;
    }
    if (c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME))
        if ((s = read_params(st, scene))) return s;
    if (c->what & (VOLUX_CHANGE_COLOR | VOLUX_CHANGE_VOLUME)) st->material = volux_scene_transfer(scene)->material;
    if (st->shaded && (c->what & VOLUX_CHANGE_LIGHTS)) prepare_lights(st, scene);
    if (c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_LIGHTS))
        if ((s = resolve_kernel(st))) return s;
    return VOLUX_OK;
}

volux_status volux_dvr_create(volux_context *ctx, volux_scene *scene, const volux_technique_class *cls, int shaded,
                              void **out) {
    dvr_state *st = volux_calloc(ctx, 1, sizeof *st);
    if (!st) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for technique state");
    st->ctx = ctx;
    st->cls = cls;
    st->shaded = shaded;
    volux_change_set all = volux_change_all();
    volux_status s = volux_dvr_update(st, scene, &all);
    if (s) {
        volux_dvr_destroy(st);
        return s;
    }
    *out = st;
    return VOLUX_OK;
}

size_t volux_dvr_memory_bytes(const void *state) {
    const dvr_state *st = state;
    return sizeof *st + st->grid.bytes + st->grad.bytes + st->pre_bytes + st->skip_bytes + st->range_bytes;
}

void volux_dvr_destroy(void *state) {
    dvr_state *st = state;
    if (!st) return;
    volux_majorant_grid_free(st->ctx, &st->grid);
    volux_gradient_cache_free(st->ctx, &st->grad);
    if (st->pre_f) volux_free_aligned(st->ctx, st->pre_f, st->pre_bytes);
    if (st->skip_dist) volux_free(st->ctx, st->skip_dist, st->skip_bytes);
    if (st->skip_range) volux_free(st->ctx, st->skip_range, st->range_bytes);
    volux_volume_release(st->volume);
    volux_free(st->ctx, st, sizeof *st);
}

/* ------------------------------------------------------------------ kernel */

/* Blinn–Phong with the normal flipped towards the viewer (as VTK's CPU ray
 * caster does), faded by gradient magnitude. c: emission colour in/out. */
static inline void shade(const dvr_state *st, volux_vec3 p_world, volux_vec3 q, volux_vec3 view_dir, float c[3]) {
    volux_vec3 n;
    float m = volux_shading_normal(volux_gradient_cache_sample(&st->grad, st->volume, q), st->grad_ref, view_dir, &n);
    if (m <= 0.0f) return;
    const volux_material *mat = &st->material;
    volux_vec3 diff = v3_scale(st->ambient, mat->ambient), spec = v3(0, 0, 0);
    for (int i = 0; i < st->n_lights; i++) {
        const dvr_light *l = &st->lights[i];
        volux_vec3 L = l->dir_to, E = l->power;
        if (l->kind) {
            volux_vec3 to = v3_sub(l->pos, p_world);
            float d2 = v3_dot(to, to);
            if (d2 <= 0.0f) continue;
            L = v3_scale(to, 1.0f / sqrtf(d2));
            float f = 1.0f / d2;
            if (l->spot) f *= volux_spot_falloff(&l->desc, -v3_dot(L, l->spot_dir));
            E = v3_scale(E, f);
        }
        volux_blinn_phong(mat, n, L, view_dir, E, &diff, &spec);
    }
    float lit[3] = {c[0] * diff.x + spec.x, c[1] * diff.y + spec.y, c[2] * diff.z + spec.z};
    for (int a = 0; a < 3; a++) c[a] += (lit[a] - c[a]) * m;
}

static inline __attribute__((always_inline)) float sample_at(const volux_volume *v, const volux_ray *r, float t,
                                                              volux_storage storage) {
    return volux_volume_sample_bricked(v, r->q0.x + r->dq.x * t, r->q0.y + r->dq.y * t, r->q0.z + r->dq.z * t,
                                       storage);
}

/* Integrates one ray over the segments of sample/segment.h (fixed
 * positions: skipping empty intervals never changes which segments are
 * integrated). */
static inline __attribute__((always_inline)) volux_vec3
march(const dvr_state *st, const volux_ray *ray, float jitter, float *T_out, uint64_t *samples, int shaded, int preint,
      volux_storage storage) {
    const volux_volume *v = st->volume;
    const volux_transfer_lut *lut = st->lut;
    float T = 1.0f, C[3] = {0, 0, 0};
    uint64_t count = 0;
    volux_segments seg;
    volux_march_iter it;
    volux_segments_init(&seg, &it, st->skip_empty ? &st->grid : NULL, ray, st->step, jitter);
    volux_preint pi = {0.0f, 0.0, {0.0, 0.0, 0.0}};
    float a, b;
    int gap;
    while (volux_segments_next(&seg, &a, &b, &gap)) {
        if (preint && gap) {
            volux_preint_front(lut, sample_at(v, ray, a, storage), &pi);
            count++;
        }
        float s = sample_at(v, ray, b, storage), c[3];
        float tau = preint ? volux_preint_segment(lut, &pi, s, b - a, c) : volux_point_segment(lut, s, b - a, c);
        count++;
        if (tau <= 0.0f) continue;
        if (shaded) {
            volux_vec3 p = v3_madd(ray->o, ray->d, b);
            volux_vec3 q = v3_madd(ray->q0, ray->dq, b);
            shade(st, p, q, ray->d, c);
        }
        float alpha = 1.0f - expf(-tau);
        float w = T * alpha;
        C[0] += w * c[0];
        C[1] += w * c[1];
        C[2] += w * c[2];
        T -= w;
        if (T < st->t_min) break;
    }
    *samples += count;
    *T_out = T;
    return v3(C[0], C[1], C[2]);
}

static inline __attribute__((always_inline)) void render_tile_impl(const dvr_state *st, const volux_scene *scene,
                                                                   const volux_tile *tile, float *rgb,
                                                                   volux_tile_stats *stats, int shaded, int preint,
                                                                   volux_storage storage) {
    const volux_camera *cam = &st->camera;
    uint64_t samples = 0;
    for (int y = 0; y < tile->h; y++)
        for (int x = 0; x < tile->w; x++) {
            volux_primary pr = volux_primary_ray(cam, st->seed, tile->x0 + x, tile->y0 + y, tile->sample_index);
            volux_ray ray;
            volux_vec3 bg = volux_scene_escape_radiance(scene, pr.d);
            float *out = &rgb[3 * (y * tile->w + x)];
            if (!volux_ray_clip(st->volume, pr.o, pr.d, &ray)) {
                out[0] = bg.x, out[1] = bg.y, out[2] = bg.z;
                continue;
            }
            float T;
            volux_vec3 c = march(st, &ray, pr.jitter, &T, &samples, shaded, preint, storage);
            out[0] = c.x + T * bg.x;
            out[1] = c.y + T * bg.y;
            out[2] = c.z + T * bg.z;
        }
    stats->samples += samples;
}

/* One kernel, specialised at compile time by (shaded, preintegrate,
 * storage): the flags are constants inside each instance. */
#define DVR_STORAGE_SWITCH(SH, PRE)                                                                               \
    switch (st->volume->storage) {                                                                              \
    case VOLUX_STORE_U8: render_tile_impl(st, scene, tile, rgb, stats, SH, PRE, VOLUX_STORE_U8); break;        \
    case VOLUX_STORE_U16: render_tile_impl(st, scene, tile, rgb, stats, SH, PRE, VOLUX_STORE_U16); break;      \
    default: render_tile_impl(st, scene, tile, rgb, stats, SH, PRE, VOLUX_STORE_F32); break;                   \
    }

void volux_dvr_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                           volux_tile_stats *stats) {
    const dvr_state *st = state;
    if (st->use_simd) {
        volux_dvr_render_tile_avx2(st, scene, tile, rgb, stats);
        return;
    }
    if (st->shaded) {
        if (st->preintegrate) DVR_STORAGE_SWITCH(1, 1)
        else DVR_STORAGE_SWITCH(1, 0)
    } else {
        if (st->preintegrate) DVR_STORAGE_SWITCH(0, 1)
        else DVR_STORAGE_SWITCH(0, 0)
    }
}
