/* techniques/pathtrace/pathtrace.c — the `pathtrace` class: parameters,
 * state, and the mapping from edits to (little) work. The estimator is in
 * integrator.c. */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/vecmath.h"
#include "pathtrace.h"

static const volux_param_info pt_params[] = {
    {"rr_depth", VOLUX_PARAM_INT, 5, 0, 100000, NULL,
     "scattering events before Russian roulette on the path throughput starts (unbiased at any value; "
     "lower is faster and noisier)"},
    {"classification", VOLUX_PARAM_STRING, 0, 0, 0, "post",
     "\"post\": sigma_t = TF(trilinear value), DESIGN's definition; \"pre\": TF at the nodes, then sigma_t and "
     "colour interpolated trilinearly, as renderers given a sigma_t grid see it (Mitsuba gridvolume)"},
    {"majorant", VOLUX_PARAM_STRING, 0, 0, 0, "grid",
     "\"grid\": local majorants from the 8^3 macrocells (fast); \"global\": one majorant for the whole box "
     "(for before/after benchmarks; same expected image)"},
    {NULL, 0, 0, 0, 0, NULL, NULL}};

static volux_status read_params(pt_state *st, const volux_scene *scene) {
    const volux_technique_class *cls = &volux_pathtrace_class;
    st->rr_depth = (int)volux_technique_param(scene, cls, "rr_depth");
    const char *cl = volux_scene_param_string(scene, cls->name, "classification", "post");
    if (!strcmp(cl, "post")) st->pre = 0;
    else if (!strcmp(cl, "pre")) st->pre = 1;
    else
        return volux_error(st->ctx, VOLUX_ERR_INVALID,
                           "techniques.pathtrace.classification: expected \"post\" or \"pre\", got \"%s\"", cl);
    const char *mj = volux_scene_param_string(scene, cls->name, "majorant", "grid");
    if (!strcmp(mj, "grid")) st->global_majorant = 0;
    else if (!strcmp(mj, "global")) st->global_majorant = 1;
    else
        return volux_error(st->ctx, VOLUX_ERR_INVALID,
                           "techniques.pathtrace.majorant: expected \"grid\" or \"global\", got \"%s\"", mj);
    return VOLUX_OK;
}

/* Rebuilds the light list (cheap) and the environment tables of the slots
 * that changed (possibly expensive: a pass over the map). */
static volux_status prepare_lights(pt_state *st, const volux_scene *scene, const volux_change_set *c) {
    for (int i = 0; i < VOLUX_MAX_LIGHTS; i++) {
        if (!volux_change_light(c, i)) continue;
        const volux_light_desc *d = volux_scene_light(scene, i);
        if (d && d->type == VOLUX_LIGHT_ENVIRONMENT) {
            volux_status s = volux_envmap_sampler_build(st->ctx, d, &st->env[i]);
            if (s) return s;
        } else {
            volux_envmap_sampler_free(st->ctx, &st->env[i]);
        }
    }
    st->n_lights = st->n_area = st->n_sphere = st->n_env = 0;
    for (int i = 0; i < volux_scene_light_slots(scene); i++) {
        const volux_light_desc *d = volux_scene_light(scene, i);
        if (!d || !d->enabled) continue;
        pt_light *l = &st->lights[st->n_lights++];
        memset(l, 0, sizeof *l);
        l->type = d->type;
        l->slot = i;
        l->desc = d;
        switch (d->type) {
        case VOLUX_LIGHT_DIRECTIONAL:
            l->dir_to = v3_scale(v3_normalize(d->direction), -1.0f);
            l->le = v3_scale(d->color, d->irradiance);
            break;
        case VOLUX_LIGHT_POINT:
        case VOLUX_LIGHT_SPOT:
            l->pos = d->position;
            l->axis = v3_normalize(d->direction);
            l->le = v3_scale(d->color, d->intensity);
            break;
        case VOLUX_LIGHT_SPHERE:
            l->pos = d->position;
            l->radius = d->radius;
            l->le = v3_scale(d->color, d->radiance);
            st->n_area++;
            st->n_sphere++;
            break;
        case VOLUX_LIGHT_ENVIRONMENT:
            l->env = &st->env[i];
            st->n_area++;
            st->n_env++;
            break;
        }
    }
    return VOLUX_OK;
}

static volux_status pt_update(void *state, volux_scene *scene, const volux_change_set *c) {
    pt_state *st = state;
    volux_status s;
    if (c->what & VOLUX_CHANGE_VOLUME) {
        volux_volume *v = volux_scene_volume(scene);
        volux_volume_retain(v);
        volux_volume_release(st->volume);
        st->volume = v;
    }
    /* The scene bakes its LUT lazily; bake it now, never during a render. */
    if (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY | VOLUX_CHANGE_COLOR)) {
        st->lut = volux_scene_transfer_lut(scene);
        if (!st->lut) {
            volux_status e = volux_context_error_status(st->ctx);
            return e ? e : volux_error(st->ctx, VOLUX_ERR_INVALID, "pathtrace: the scene's transfer function");
        }
    }
    if (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY))
        if ((s = volux_majorant_grid_build(st->ctx, st->volume, st->lut, &st->grid))) return s;
    if (c->what & (VOLUX_CHANGE_COLOR | VOLUX_CHANGE_PHASE)) {
        const volux_transfer_desc *tf = volux_scene_transfer(scene);
        st->albedo = tf->albedo;
        st->g = tf->anisotropy;
    }
    if (c->what & (VOLUX_CHANGE_CAMERA | VOLUX_CHANGE_RENDER | VOLUX_CHANGE_VOLUME))
        if ((s = volux_scene_camera(scene, &st->camera))) return s;
    if (c->what & VOLUX_CHANGE_RENDER) {
        const volux_render_settings *rs = volux_scene_render(scene);
        st->seed = rs->seed;
        st->max_depth = rs->max_depth;
    }
    if (c->what & VOLUX_CHANGE_PARAMS)
        if ((s = read_params(st, scene))) return s;
    if (c->what & VOLUX_CHANGE_LIGHTS)
        if ((s = prepare_lights(st, scene, c))) return s;
    return VOLUX_OK;
}

static void pt_destroy(void *state) {
    pt_state *st = state;
    if (!st) return;
    volux_majorant_grid_free(st->ctx, &st->grid);
    for (int i = 0; i < VOLUX_MAX_LIGHTS; i++) volux_envmap_sampler_free(st->ctx, &st->env[i]);
    volux_volume_release(st->volume);
    volux_free(st->ctx, st, sizeof *st);
}

static volux_status pt_create(volux_context *ctx, volux_scene *scene, void **out) {
    pt_state *st = volux_calloc(ctx, 1, sizeof *st);
    if (!st) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for pathtrace state");
    st->ctx = ctx;
    volux_change_set all = volux_change_all();
    volux_status s = pt_update(st, scene, &all);
    if (s) {
        pt_destroy(st);
        return s;
    }
    *out = st;
    return VOLUX_OK;
}

static size_t pt_memory_bytes(const void *state) {
    const pt_state *st = state;
    size_t n = sizeof *st + st->grid.bytes;
    for (int i = 0; i < VOLUX_MAX_LIGHTS; i++) n += volux_envmap_sampler_bytes(&st->env[i]);
    return n;
}

const volux_technique_class volux_pathtrace_class = {
    "pathtrace",
    "unbiased reference volumetric path tracer (delta/ratio tracking on macrocell majorants, NEE + MIS)",
    pt_params,
    1,
    pt_create,
    pt_update,
    volux_pathtrace_render_tile,
    pt_memory_bytes,
    pt_destroy,
};
