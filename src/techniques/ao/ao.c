/*
 * techniques/ao/ao.c — `ao`: SAT-based volumetric ambient occlusion after
 * Schlegel et al. 2011, the second baseline of Ament et al. 2013 (§5,
 * Table 1, Figs. 1b, 6b, 11a):
 *
 *     L_s(x) = A(x) · (Σ_j p_g(ω_j·ω) E_j(x) + L_amb)
 *
 * A(x) (techniques/scatter/occlusion.h) replaces the shadow transmittance:
 * soft, local, isotropic — no directional shadows. L_amb is the mean
 * radiance of the scene's environment lights plus the `ambient` parameter.
 *
 * Caches and what invalidates them:
 *   SAT, occlusion volume ← volume, extinction, density, radius, shells
 * Lights, phase, colour and camera edits need no cache work (Table 1: "−").
 */
#include <math.h>
#include <string.h>

#include "ao.h"
#include "core/context_internal.h"
#include "sample/phase.h"
#include "techniques/scatter/occlusion.h"

static const volux_param_info ao_params[] = {
    SCATTER_COMMON_PARAMS,
    {"radius", VOLUX_PARAM_NUMBER, 8, 0.5, 128, NULL,
     "occlusion radius R in units of the smallest voxel spacing (the paper uses 14)"},
    {"shells", VOLUX_PARAM_INT, 3, 1, 8, NULL, "nested SAT boxes per voxel (Ament et al.: at least 3)"},
    {"ambient", VOLUX_PARAM_NUMBER, 0, 0, 1e6, NULL,
     "radiance of a white ambient light seen through the occlusion (added to environment lights)"},
    {NULL, 0, 0, 0, 0, NULL, NULL}};

static volux_status ao_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    ao_state *st = state;
    volux_raycaster *rc = &st->b.rc;
    volux_status s;
    scatter_base_update(&st->b, scene, c);
    int rebuild = (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) != 0;
    if (c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        float radius = (float)volux_technique_param(scene, rc->cls, "radius") * rc->min_spacing;
        int shells = (int)volux_technique_param(scene, rc->cls, "shells");
        if (radius != st->radius || shells != st->shells) rebuild = 1;
        st->radius = radius, st->shells = shells;
        st->ambient = (float)volux_technique_param(scene, rc->cls, "ambient");
    }
    if (!rebuild) return VOLUX_OK;
    double sp[3];
    volux_volume_spacing(rc->volume, sp);
    if ((s = scatter_sat_build(rc->ctx, rc->threads, rc->volume, rc->lut, scatter_occlusion_max_box(st->radius, sp),
                               &st->sat)))
        return s;
    st->sat_builds++;
    if ((s = scatter_grid_alloc(rc->ctx, rc->volume, 1.0f, &st->occ, "ao: occlusion volume"))) return s;
    if ((s = scatter_occlusion_build(rc->ctx, rc->threads, &st->sat, st->radius, st->shells, sp, &st->occ))) return s;
    st->occ_builds++;
    return VOLUX_OK;
}

static void ao_release(void *state) {
    ao_state *st = state;
    scatter_sat_free(st->b.rc.ctx, &st->sat);
    scatter_grid_free(st->b.rc.ctx, &st->occ);
}

static size_t ao_memory_bytes(const void *state) {
    const ao_state *st = state;
    return st->sat.bytes + st->occ.bytes;
}

static inline __attribute__((always_inline)) void inscatter(const void *tech, const scatter_sample *smp,
                                                            volux_vec3 *Ls, volux_vec3 *extra) {
    (void)extra;
    const ao_state *st = tech;
    const volux_light_list *ls = &st->b.rc.lights;
    float A = scatter_grid_sample_index(&st->occ, smp->q.x, smp->q.y, smp->q.z);
    volux_vec3 L = v3_add(ls->env_mean, v3(st->ambient, st->ambient, st->ambient));
    for (int i = 0; i < ls->n_direct; i++) {
        volux_vec3 travel;
        volux_vec3 E = volux_light_irradiance(&ls->direct[i], smp->p, &travel);
        L = v3_add(L, v3_scale(E, volux_hg_eval(st->b.rc.g, v3_dot(travel, smp->to_eye))));
    }
    *Ls = v3_scale(L, A);
}

SCATTER_RENDER_TILE(ao_render_tile, ao_state, 0.0f, NULL, inscatter)

const volux_technique_class volux_ao_class = {
    {"ao", "SAT ambient occlusion (Schlegel et al. 2011) lighting single scattering (Ament 2013 baseline)",
     ao_params, 0},
    sizeof(ao_state), 0, 0,
    NULL, ao_update, ao_render_tile, ao_memory_bytes, ao_release,
    NULL, NULL, NULL, /* no refine, pending work or statistics */
    NULL, /* no bricks: its light leaves the camera ray (scattering, shadows) */
    NULL, /* no per-frame budget (volux_technique_set_budget) */
    NULL, /* nothing per pass */
};
