/* render/technique.c — technique instances: generic create/destroy driven
 * by the class's state size, stamp-based update, parameter lookup. Names
 * are resolved one layer up (techniques/registry.c). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/context_internal.h"
#include "memory_model.h"
#include "raycaster.h"
#include "technique_class.h"

struct volux_technique {
    volux_context *ctx;
    const volux_technique_class *cls;
    void *state; /* cls->state_size bytes, starting with a volux_raycaster */
    volux_scene_stamp stamp;
    uint64_t generation; /* unique per (instance, applied update or step) */
};

/* Generations are unique across instances, so a framebuffer can tell its
 * samples' origin apart from any other instance's. */
static uint64_t next_generation = 1;
static uint64_t new_generation(void) { return __atomic_fetch_add(&next_generation, 1, __ATOMIC_RELAXED); }

const void *volux_technique_state(const volux_technique *t) { return t->state; }
volux_status volux_technique_begin_pass(volux_technique *t, const volux_scene *scene, uint32_t sample_index) {
    return t->cls->begin_pass ? t->cls->begin_pass(t->state, scene, sample_index) : VOLUX_OK;
}
const volux_technique_class *volux_technique_class_of(const volux_technique *t) { return t->cls; }
const volux_technique_info *volux_technique_info_of(const volux_technique *t) { return &t->cls->info; }
uint64_t volux_technique_generation(const volux_technique *t) { return t->generation; }

static const volux_param_info *find_param(const volux_technique_info *info, const char *name) {
    for (const volux_param_info *p = info->params; p && p->name; p++)
        if (!strcmp(p->name, name)) return p;
    return NULL;
}

/* The message for a parameter name the technique does not have: the
 * nearest name when one is close (a typo), and every valid name. */
static volux_status unknown_param(volux_context *ctx, const volux_technique_info *info, const char *name) {
    char list[1024] = "", guess[96] = "";
    volux_name_guess g = {0};
    for (const volux_param_info *p = info->params; p && p->name; p++) {
        size_t w = strlen(list);
        snprintf(list + w, sizeof list - w, "%s%s", w ? ", " : "", p->name);
        volux_name_guess_try(&g, name, p->name);
    }
    const char *best = volux_name_guess_best(&g, name);
    if (best) snprintf(guess, sizeof guess, "did you mean '%s'? ", best);
    if (!*list)
        return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s.%s: unknown parameter (%s has none)", info->name,
                           name, info->name);
    return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s.%s: unknown parameter (%sparameters of %s: %s)",
                       info->name, name, guess, info->name, list);
}

volux_status volux_technique_check_param(volux_context *ctx, const volux_technique_info *info, const char *name,
                                         double number, const char *string) {
    const char *tech = info->name;
    const volux_param_info *p = find_param(info, name);
    if (!p) return unknown_param(ctx, info, name);
    int text = p->kind == VOLUX_PARAM_STRING || p->kind == VOLUX_PARAM_FILE;
    if (text != (string != NULL))
        return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s.%s: expected a %s", tech, name,
                           p->kind == VOLUX_PARAM_FILE ? "file name" : text ? "string" : "number");
    if (text) return VOLUX_OK;
    if ((p->kind == VOLUX_PARAM_INT || p->kind == VOLUX_PARAM_BOOL) && number != floor(number))
        return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s.%s: expected an integer, got %g", tech, name, number);
    if (number < p->min || number > p->max)
        return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s.%s: %g is outside [%g, %g]", tech, name, number,
                           p->min, p->max);
    return VOLUX_OK;
}

/* The parameters the scene stores for this class. */
static volux_status check_class_params(volux_context *ctx, const volux_technique_class *cls, const volux_scene *scene) {
    const char *tech, *name, *string;
    double number;
    for (int i = 0; volux_scene_param_at(scene, i, &tech, &name, &number, &string); i++) {
        if (strcmp(tech, cls->info.name) != 0) continue;
        volux_status st = volux_technique_check_param(ctx, &cls->info, name, number, string);
        if (st) return st;
    }
    return VOLUX_OK;
}

double volux_technique_param(const volux_scene *scene, const volux_technique_class *cls, const char *name) {
    const volux_param_info *p = find_param(&cls->info, name);
    return volux_scene_param(scene, cls->info.name, name, p ? p->def : 0.0);
}

const char *volux_technique_param_string(const volux_scene *scene, const volux_technique_class *cls,
                                         const char *name) {
    const volux_param_info *p = find_param(&cls->info, name);
    return volux_scene_param_string(scene, cls->info.name, name, p && p->def_string ? p->def_string : "");
}

/* Base first, then the technique's caches (which may read the base). */
static volux_status apply(volux_technique *t, const volux_scene *scene, const volux_change_set *c) {
    volux_status st = volux_raycaster_update(t->state, scene, c);
    return st ? st : t->cls->update(t->state, scene, c);
}

static void destroy_state(volux_context *ctx, const volux_technique_class *cls, void *state) {
    if (cls->release) cls->release(state);
    volux_raycaster_release(state);
    volux_free(ctx, state, cls->state_size);
}

volux_status volux_technique_create_class(volux_context *ctx, const volux_technique_class *cls,
                                          const volux_scene *scene, volux_technique **out) {
    const char *name = cls->info.name;
    if (!volux_scene_volume(scene)) return volux_error(ctx, VOLUX_ERR_INVALID, "%s: the scene has no volume", name);
    volux_status st = check_class_params(ctx, cls, scene);
    if (st) return st;
    /* The memory budget, before anything is allocated (docs/SCALE.md). */
    volux_memory_estimate est;
    volux_memory_estimate_class(cls, scene, &est);
    if ((st = volux_memory_check(ctx, name, &est))) return st;
    volux_technique *t = volux_calloc(ctx, 1, sizeof *t);
    void *state = volux_calloc(ctx, 1, cls->state_size);
    if (!t || !state) {
        volux_free(ctx, t, sizeof *t);
        volux_free(ctx, state, cls->state_size);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for technique '%s'", name);
    }
    volux_raycaster *rc = state;
    rc->ctx = ctx;
    rc->cls = cls;
    if (cls->init) cls->init(state);
    t->ctx = ctx;
    t->cls = cls;
    t->state = state;
    t->stamp = volux_scene_stamp_now(scene);
    t->generation = new_generation();
    volux_change_set all = volux_change_all();
    if ((st = apply(t, scene, &all))) {
        destroy_state(ctx, cls, state);
        volux_free(ctx, t, sizeof *t);
        return st;
    }
    *out = t;
    return VOLUX_OK;
}

/* Every light change bumps VOLUX_CHANGE_LIGHTS too. */
static int any_change(const volux_change_set *c) { return c->what != 0; }

int volux_technique_is_current(const volux_technique *t, const volux_scene *scene) {
    volux_change_set c = volux_scene_changes_since(scene, &t->stamp);
    return !any_change(&c);
}

volux_status volux_technique_update(volux_technique *t, const volux_scene *scene, volux_change_set *changed) {
    volux_change_set c = volux_scene_changes_since(scene, &t->stamp);
    if (changed) *changed = c;
    if (!any_change(&c)) return VOLUX_OK;
    volux_status st;
    if ((c.what & VOLUX_CHANGE_PARAMS) && (st = check_class_params(t->ctx, t->cls, scene))) return st;
    /* The stamp moves only on success: a failed update is retried in full
     * by the next call (its caches may be half-built). */
    if ((st = apply(t, scene, &c))) return st;
    t->stamp = volux_scene_stamp_now(scene);
    t->generation = new_generation();
    return VOLUX_OK;
}

volux_status volux_technique_refine(volux_technique *t, const volux_scene *scene, int *refined, int *more) {
    if (more) *more = 0;
    if (refined) *refined = 0;
    volux_status st = volux_technique_update(t, scene, NULL);
    if (st || !t->cls->refine) return st;
    int changed = 0, m = 0;
    st = t->cls->refine(t->state, scene, &changed, &m);
    if (changed) t->generation = new_generation(); /* framebuffers restart */
    if (more) *more = m;
    if (refined) *refined = changed;
    return st;
}

int volux_technique_set_budget(volux_technique *t, double ms) {
    if (!t->cls->set_budget) return 0;
    t->cls->set_budget(t->state, ms > 0.0 ? ms : 0.0); /* NaN fails the test: 0 */
    return 1;
}

uint64_t volux_technique_pending(const volux_technique *t) {
    return t->cls->pending ? t->cls->pending(t->state) : 0;
}

int volux_technique_stats(const volux_technique *t, volux_technique_stat *out, int max) {
    return t->cls->stats ? t->cls->stats(t->state, out, max) : 0;
}

size_t volux_technique_memory_bytes(const volux_technique *t) {
    return sizeof *t + t->cls->state_size + volux_raycaster_memory_bytes(t->state) +
           (t->cls->memory_bytes ? t->cls->memory_bytes(t->state) : 0);
}

void volux_technique_destroy(volux_technique *t) {
    if (!t) return;
    destroy_state(t->ctx, t->cls, t->state);
    volux_free(t->ctx, t, sizeof *t);
}
