/* techniques/pathtrace/pathtrace.c — the `pathtrace` class: parameters,
 * state, and the mapping from edits to (little) work. The estimator is in
 * integrator.c. */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/vecmath.h"
#include "pathtrace.h"
#include "sample/sampler.h"

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
    {"sampler", VOLUX_PARAM_STRING, 0, 0, 0, "sobol",
     "\"sobol\": pixel position and the draws of the first 8 path events from padded Owen-scrambled Sobol pairs "
     "(Burley 2020; less noise at equal spp); \"independent\": independent random numbers throughout"},
    {NULL, 0, 0, 0, 0, NULL, NULL}};

static volux_status read_params(pt_state *st, const volux_scene *scene) {
    const volux_technique_class *cls = &volux_pathtrace_class;
    st->rr_depth = (int)volux_technique_param(scene, cls, "rr_depth");
    const char *cl = volux_technique_param_string(scene, cls, "classification");
    if (!strcmp(cl, "post")) st->pre = 0;
    else if (!strcmp(cl, "pre")) st->pre = 1;
    else
        return volux_error(st->rc.ctx, VOLUX_ERR_INVALID,
                           "techniques.pathtrace.classification: expected \"post\" or \"pre\", got \"%s\"", cl);
    const char *mj = volux_technique_param_string(scene, cls, "majorant");
    if (!strcmp(mj, "grid")) st->global_majorant = 0;
    else if (!strcmp(mj, "global")) st->global_majorant = 1;
    else
        return volux_error(st->rc.ctx, VOLUX_ERR_INVALID,
                           "techniques.pathtrace.majorant: expected \"grid\" or \"global\", got \"%s\"", mj);
    const char *sm = volux_technique_param_string(scene, cls, "sampler");
    if ((st->sampler = volux_sampler_parse(sm)) < 0)
        return volux_error(st->rc.ctx, VOLUX_ERR_INVALID,
                           "techniques.pathtrace.sampler: expected \"sobol\" or \"independent\", got \"%s\"", sm);
    return VOLUX_OK;
}

/* The environment sampling tables of the slots that changed (a pass over
 * the map each). */
static volux_status update_env_tables(pt_state *st, const volux_scene *scene, const volux_change_set *c) {
    volux_status g = volux_grow_slots(st->rc.ctx, &st->env, &st->env_cap, volux_scene_light_slots(scene),
                                      sizeof *st->env, "pathtrace: environment tables");
    if (g) return g;
    for (int i = 0; i < st->env_cap; i++) {
        if (!volux_change_light(c, i)) continue;
        const volux_light_desc *d = volux_scene_light(scene, i);
        if (d && d->type == VOLUX_LIGHT_ENVIRONMENT) {
            volux_status s = volux_envmap_sampler_build(st->rc.ctx, d, &st->env[i]);
            if (s) return s;
        } else {
            volux_envmap_sampler_free(st->rc.ctx, &st->env[i]);
        }
    }
    st->n_area = st->rc.lights.n_sphere + st->rc.lights.n_env;
    return VOLUX_OK;
}

static volux_status pt_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    pt_state *st = state;
    volux_status s;
    if ((c->what & VOLUX_CHANGE_PARAMS) && (s = read_params(st, scene))) return s;
    if ((c->what & VOLUX_CHANGE_LIGHTS) && (s = update_env_tables(st, scene, c))) return s;
    return VOLUX_OK;
}

static void pt_release(void *state) {
    pt_state *st = state;
    for (int i = 0; i < st->env_cap; i++) volux_envmap_sampler_free(st->rc.ctx, &st->env[i]);
    volux_free(st->rc.ctx, st->env, sizeof *st->env * (size_t)st->env_cap);
    st->env = NULL;
    st->env_cap = 0;
}

static size_t pt_memory_bytes(const void *state) {
    const pt_state *st = state;
    size_t n = sizeof *st->env * (size_t)st->env_cap;
    for (int i = 0; i < st->env_cap; i++) n += volux_envmap_sampler_bytes(&st->env[i]);
    return n;
}

const volux_technique_class volux_pathtrace_class = {
    {"pathtrace", "unbiased reference volumetric path tracer (delta/ratio tracking on macrocell majorants, NEE + MIS)",
     pt_params, 1},
    sizeof(pt_state), 0, 0,
    NULL, pt_update, volux_pathtrace_render_tile, pt_memory_bytes, pt_release,
    NULL, NULL, NULL, /* no refine, pending work or statistics */
    NULL, /* no bricks: its light leaves the camera ray (scattering, shadows) */
    NULL, /* no per-frame budget (volux_technique_set_budget) */
    volux_pathtrace_estimate_bytes,
    NULL, /* nothing per pass */
};
