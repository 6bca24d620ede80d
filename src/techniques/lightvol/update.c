/*
 * techniques/lightvol/update.c — selective light updates (§5): the light in
 * every slot as last applied (lv_applied) against the scene's; each changed
 * slot becomes a remove item (its old source, sign −1) and an add item (its
 * new one, +1), propagated through the same sweeps as an entire update. The
 * cost rule picks selective or entire (plan.c estimates both); an entire
 * update every rebaseline_interval selective ones bounds float drift.
 *
 * §7.3's incremental update ("the illumination volume can be incrementally
 * updated from a specific number of propagations per frame"): an update
 * becomes a job (lv_job) whose slice steps run in budgets — budget_slices
 * steps, or as many as budget_ms allows at the measured rate — one per
 * update and per refine step (volux_technique_refine, called by the front
 * end between frames); renders in between see the partly propagated volume.
 * Light edits while a job runs are queued: when it ends, the next job takes
 * the volume from the job's target to the scene's lights. A medium or
 * parameter change drops the job and starts an entire update. The job's
 * arithmetic does not depend on where the budgets cut it (sweep.c), so the
 * finished volume is bit-identical to the same update run at once.
 */

#include <string.h>
#include <time.h>

#include "core/context_internal.h"
#include "lightvol.h"
#include "sweep.h"

/* What an update from `from` (the applied state) to the scene's lights
 * needs: the next state, the items, and selective or entire. */
typedef struct lv_decision {
    int slots;            /* max(applied slots, the scene's slots)         */
    lv_applied *next;     /* [slots]                                       */
    lv_item *items;       /* the changes (≤ 2 per slot, 1 per environment
                             direction), then `full`                      */
    lv_item *full;        /* the full setup (≤ 1 per slot and direction)   */
    size_t cap;           /* items + full                                  */
    volux_vec3 env_next[LV_MAX_ENV_DIRS];
    int n, nf, changed, total, selective, ps, pf;
    int promote;          /* the volume goes to float (precision auto)   */
    double ws, wf;
    const char *reason;
} lv_decision;

static int any_light(volux_vec3 E) { return E.x > 0.0f || E.y > 0.0f || E.z > 0.0f; }

/* Fills d for the slots set in c (every slot when c is NULL: an unchanged
 * light derives the same source, so it is no change). The environment
 * lights count as one light: when one of them changed, each direction
 * whose irradiance changed becomes one item carrying the difference (the
 * directions are fixed; propagation is linear in the power), which does
 * in one entry what a remove and an add would do in two. No side effects
 * but on the memo of cell integrals. */
static void decide(const lightvol_state *st, volux_env_cells_cache *cells, const volux_scene *scene,
                   const volux_change_set *c, int force_full, const char *reason, int selective_since_full,
                   lv_decision *d) {
    int n = 0, changed = 0, before = 0, after = 0, env_dirty = force_full || !c;
    static const lv_applied none; /* a slot past `applied`: never active */
    for (int slot = 0; slot < d->slots; slot++) {
        const lv_applied *o = slot < st->applied_cap ? &st->applied[slot] : &none;
        lv_applied *w = &d->next[slot];
        if (force_full || !c || volux_change_light(c, slot)) {
            memset(w, 0, sizeof *w);
            const volux_light_desc *ld = volux_scene_light(scene, slot);
            w->active = volux_lightvol_source(st, ld, &w->src);
            if (ld) {
                w->desc = *ld;
                w->desc.map = NULL;
                w->env = ld->type == VOLUX_LIGHT_ENVIRONMENT;
            }
            if (w->env || o->env) env_dirty = 1;
        } else {
            *w = *o;
        }
        before += o->active;
        after += w->active;
        if (o->active == w->active && (!o->active || memcmp(&o->src, &w->src, sizeof o->src) == 0)) continue;
        changed++;
        if (o->active) d->items[n++] = (lv_item){o->src, -1.0f, slot};
        if (w->active) d->items[n++] = (lv_item){w->src, +1.0f, slot};
    }
    /* The environment directions: their differences. */
    const int K = st->p.env_dirs;
    memset(d->env_next, 0, sizeof d->env_next);
    if (env_dirty) volux_lightvol_env_irradiance(st, cells, scene, d->env_next);
    else memcpy(d->env_next, st->env_E, (size_t)K * sizeof(volux_vec3));
    int env_before = 0, env_after = 0, env_changed = 0;
    for (int k = 0; k < K; k++) {
        const volux_vec3 o = st->env_E[k], w = d->env_next[k];
        env_before |= any_light(o);
        env_after |= any_light(w);
        volux_vec3 delta = v3_sub(w, o);
        if (delta.x == 0.0f && delta.y == 0.0f && delta.z == 0.0f) continue;
        env_changed = 1;
        lv_item *it = &d->items[n++];
        volux_lightvol_env_source(st, k, delta, &it->src);
        it->sign = +1.0f;
        it->slot = -1;
    }
    changed += env_changed;
    before += env_before;
    after += env_after;
    d->n = n;
    d->changed = changed;
    d->total = before > after ? before : after;
    /* The full setup, for the cost estimate and a rebuild. */
    int nf = 0;
    lv_item *full_items = d->full;
    for (int slot = 0; slot < d->slots; slot++)
        if (d->next[slot].active) full_items[nf++] = (lv_item){d->next[slot].src, +1.0f, slot};
    for (int k = 0; k < K; k++) {
        if (!any_light(d->env_next[k])) continue;
        lv_item *it = &full_items[nf++];
        volux_lightvol_env_source(st, k, d->env_next[k], &it->src);
        it->sign = +1.0f;
        it->slot = -1;
    }
    d->nf = nf;
    d->selective = 0;
    d->ps = d->pf = 0;
    d->ws = d->wf = 0.0;
    if (!force_full) {
        /* §5: rule 1 — at most half of the lights changed; rule 2 — fewer
         * propagation passes than an entire update (ties go to rule 1,
         * since add and remove usually share their passes). */
        int ps = volux_lightvol_plan(d->items, n, st->p.coherent, st->p.max_per_pass, NULL, NULL);
        int pf = volux_lightvol_plan(full_items, nf, st->p.coherent, st->p.max_per_pass, NULL, NULL);
        const lv_work_weights ww = volux_lightvol_work_weights(st);
        double ws = volux_lightvol_plan_work(d->items, n, st->p.coherent, st->p.max_per_pass, ww);
        double wf = volux_lightvol_plan_work(full_items, nf, st->p.coherent, st->p.max_per_pass, ww);
        d->ps = ps, d->pf = pf, d->ws = ws, d->wf = wf;
        int rule1 = 2 * changed <= d->total, selective;
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
        if (selective && st->p.rebaseline > 0 && selective_since_full >= st->p.rebaseline)
            selective = 0, reason = "re-baseline after selective updates";
        /* precision auto: selective updates run on a float volume; the
         * first one is entire, so that no bfloat16 rounding stays in it */
        d->promote = 0;
        if (selective && !st->volf) selective = 0, d->promote = 1, reason = "float volume for selective updates";
        d->selective = selective;
    }
    d->reason = reason ? reason : "full rebuild";
}

/* Slice steps of the plan a decision makes. */
static uint64_t decision_steps(const lightvol_state *st, const lv_decision *d, lv_pass *passes, int *idx) {
    const lv_item *items = d->selective ? d->items : d->full;
    int np = volux_lightvol_plan(items, d->selective ? d->n : d->nf, st->p.coherent, st->p.max_per_pass, passes, idx);
    uint64_t steps = 0;
    for (int i = 0; i < np; i++) steps += (uint64_t)volux_lightvol_pass_steps(st, &passes[i]);
    return steps;
}

static void free_job_arrays(volux_context *ctx, lv_job *j) {
    volux_free(ctx, j->items, j->items_bytes);
    volux_free(ctx, j->passes, j->passes_bytes);
    volux_free(ctx, j->idx, j->idx_bytes);
    j->items = NULL, j->passes = NULL, j->idx = NULL;
    j->items_bytes = j->passes_bytes = j->idx_bytes = 0;
}

void volux_lightvol_drop_job(lightvol_state *st) {
    lv_job *j = &st->job;
    free_job_arrays(st->rc.ctx, j);
    double rate = j->ms_per_work;
    memset(j, 0, sizeof *j);
    j->ms_per_work = rate;
}

uint64_t volux_lightvol_pending(const lightvol_state *st) { return st->job.left + st->job.queued; }

/* Makes the decision the job: allocates its plan and the scratch, then (no
 * failure after this point) takes `next` as applied and counts the update.
 * An empty plan (nothing to propagate) finishes at once. */
static volux_status start_job(lightvol_state *st, const lv_decision *d) {
    volux_context *ctx = st->rc.ctx;
    lv_job *j = &st->job;
    const lv_item *src = d->selective ? d->items : d->full;
    int n = d->selective ? d->n : d->nf;
    int np = volux_lightvol_plan(src, n, st->p.coherent, st->p.max_per_pass, NULL, NULL);
    lv_job nj;
    memset(&nj, 0, sizeof nj);
    nj.items_bytes = (size_t)(n > 0 ? n : 1) * sizeof(lv_item);
    nj.passes_bytes = (size_t)(np > 0 ? np : 1) * sizeof(lv_pass);
    nj.idx_bytes = (size_t)(n > 0 ? n : 1) * LV_GROUPS * sizeof(int);
    nj.items = volux_malloc(ctx, nj.items_bytes);
    nj.passes = volux_malloc(ctx, nj.passes_bytes);
    nj.idx = volux_malloc(ctx, nj.idx_bytes);
    volux_status s = VOLUX_OK;
    if (!nj.items || !nj.passes || !nj.idx) {
        s = volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the pass plan");
        goto fail;
    }
    if ((s = volux_grow_slots(ctx, &st->applied, &st->applied_cap, d->slots, sizeof *st->applied,
                              "lightvol: the applied lights")))
        goto fail;
    memcpy(nj.items, src, (size_t)n * sizeof(lv_item));
    volux_lightvol_plan(nj.items, n, st->p.coherent, st->p.max_per_pass, nj.passes, nj.idx);
    int most = 0;
    for (int i = 0; i < np; i++) {
        if (nj.passes[i].n > most) most = nj.passes[i].n;
        nj.left += (uint64_t)volux_lightvol_pass_steps(st, &nj.passes[i]);
    }
    if (most > 0 && (s = volux_lightvol_ensure_scratch(st, most))) goto fail;
    nj.active = np > 0;
    nj.full = !d->selective;
    nj.n = n;
    nj.np = np;
    nj.ms_per_work = j->ms_per_work;
    free_job_arrays(ctx, j);
    *j = nj;
    if (!nj.active) {
        free_job_arrays(ctx, j);
        if (nj.full) memset(st->vol ? (void *)st->vol : (void *)st->volf, 0, st->vol_bytes); /* no light: zero */
    }
    if (d->slots > 0) memcpy(st->applied, d->next, (size_t)d->slots * sizeof(lv_applied));
    memcpy(st->env_E, d->env_next, sizeof st->env_E);
    st->valid = 1;
    st->stats.changed = d->changed;
    st->stats.total = d->total;
    st->stats.passes_selective = d->ps;
    st->stats.passes_full = d->pf;
    st->stats.work_selective = d->ws;
    st->stats.work_full = d->wf;
    st->stats.passes = np;
    st->stats.entries = 0;
    for (int i = 0; i < np; i++) st->stats.entries += j->passes[i].n;
    st->stats.last = d->selective ? LV_UPDATE_SELECTIVE : LV_UPDATE_FULL;
    st->stats.reason = d->reason;
    if (d->selective) {
        st->stats.selective_since_full++;
        st->stats.selective_updates++;
    } else {
        st->stats.selective_since_full = 0;
        st->stats.full_rebuilds++;
    }
    return VOLUX_OK;
fail:
    volux_free(ctx, nj.items, nj.items_bytes);
    volux_free(ctx, nj.passes, nj.passes_bytes);
    volux_free(ctx, nj.idx, nj.idx_bytes);
    return s;
}

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* Longest piece of an unbudgeted propagation between two cancel checks. */
#define CANCEL_CHUNK_MS 40.0

/* Runs slice steps of the current job: all (budget off), budget_slices, or
 * as many as budget_ms allows at the measured rate (at least one). The job
 * keeps its place after a cancellation. */
static volux_status run_job(lightvol_state *st, int *did) {
    volux_context *ctx = st->rc.ctx;
    lv_job *j = &st->job;
    if (!j->active) return VOLUX_OK;
    int most = 0;
    for (int i = j->pass; i < j->np; i++)
        if (j->passes[i].n > most) most = j->passes[i].n;
    size_t ebytes = (size_t)(most > 0 ? most : 1) * sizeof(lv_entry);
    lv_entry *E = volux_malloc(ctx, ebytes);
    if (!E) return volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the pass entries");
    int budget_slices;
    double budget_ms;
    lv_budget(st, &budget_slices, &budget_ms);
    const int by_slices = budget_slices > 0, by_ms = budget_ms > 0.0;
    /* budget_ms: modelled work allowed at the measured rate (none measured
     * yet: one step at a time until there is) */
    double work_left = by_ms && j->ms_per_work > 0.0 ? budget_ms / j->ms_per_work : 0.0;
    long steps_left = by_slices ? budget_slices : -1;
    volux_status s = VOLUX_OK;
    int first = 1;
    while (j->pass < j->np) {
        const int p = j->pass, total = volux_lightvol_pass_steps(st, &j->passes[p]);
        const double sw = volux_lightvol_step_work(st, j, p);
        int s1 = total;
        if (by_slices) {
            if (steps_left <= 0) break;
            if ((long)(s1 - j->step) > steps_left) s1 = j->step + (int)steps_left;
        } else if (by_ms) {
            long fit = (long)(work_left / sw);
            if (fit <= 0) {
                if (!first) break;
                fit = 1; /* every call makes progress */
            }
            if ((long)(s1 - j->step) > fit) s1 = j->step + (int)fit;
        } else {
            /* no budget: still in pieces of ~CANCEL_CHUNK_MS at the measured
             * rate (one step until there is one), so that a cancel lands
             * between them; the pieces give the same bits as one sweep */
            long fit = j->ms_per_work > 0.0 ? (long)(CANCEL_CHUNK_MS / (j->ms_per_work * sw)) : 1;
            if (fit < 1) fit = 1;
            if ((long)(s1 - j->step) > fit) s1 = j->step + (int)fit;
        }
        double t0 = now_ms();
        volux_lightvol_sweep_steps(st, j, p, j->step, s1, E);
        double dt = now_ms() - t0, work = sw * (double)(s1 - j->step);
        /* the rate of the latest chunk of real size (short ones are noisy) */
        if (dt > 1.0 || j->ms_per_work == 0.0) j->ms_per_work = dt / work;
        if (by_slices) steps_left -= s1 - j->step;
        if (by_ms) work_left -= work;
        j->left -= (uint64_t)(s1 - j->step);
        j->step = s1;
        first = 0;
        *did = 1;
        if (j->step == total) {
            j->pass++;
            j->step = 0;
        }
        if (volux_progress(ctx, "preparing lightvol", 1.0 - (double)j->left / (double)(j->left + 1 + (uint64_t)j->step))) {
            s = volux_error(ctx, VOLUX_ERR_CANCELLED, "lightvol: propagation cancelled");
            break;
        }
    }
    volux_free(ctx, E, ebytes);
    if (j->pass == j->np) {
        free_job_arrays(ctx, j);
        j->active = 0;
        j->pass = j->step = 0;
        j->left = 0;
    }
    return s;
}

/* Allocates the decision's arrays for the slots of `applied` and of the
 * scene. */
static volux_status decision_alloc(volux_context *ctx, const lightvol_state *st, const volux_scene *scene,
                                   lv_decision *d) {
    memset(d, 0, sizeof *d);
    int slots = volux_scene_light_slots(scene);
    d->slots = st->applied_cap > slots ? st->applied_cap : slots;
    size_t n = d->slots > 0 ? (size_t)d->slots : 1, K = (size_t)st->p.env_dirs;
    d->cap = 3 * n + 2 * K;
    d->items = volux_malloc(ctx, d->cap * sizeof(lv_item));
    d->next = volux_malloc(ctx, n * sizeof(lv_applied));
    if (!d->items || !d->next) {
        volux_free(ctx, d->items, d->items ? d->cap * sizeof(lv_item) : 0);
        volux_free(ctx, d->next, d->next ? n * sizeof(lv_applied) : 0);
        d->items = NULL, d->next = NULL;
        return volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the light update (%d slots)", d->slots);
    }
    d->full = d->items + 2 * n + K; /* after ≤ 2 items per slot and 1 per direction */
    return VOLUX_OK;
}

static void decision_free(volux_context *ctx, lv_decision *d) {
    size_t n = d->slots > 0 ? (size_t)d->slots : 1;
    volux_free(ctx, d->items, d->cap * sizeof(lv_item));
    volux_free(ctx, d->next, n * sizeof(lv_applied));
}

/* The size of the plan that would follow the current job (0 if the scene's
 * lights equal its target), so that pending() counts it. */
static volux_status measure_queue(lightvol_state *st, const volux_scene *scene) {
    volux_context *ctx = st->rc.ctx;
    lv_decision d;
    volux_status s = decision_alloc(ctx, st, scene, &d);
    if (s) return s;
    /* ≤ 2 items per slot and 1 per environment direction */
    const size_t most = ((d.slots > 0 ? (size_t)d.slots : 1) * 2 + (size_t)st->p.env_dirs) * LV_GROUPS;
    lv_pass *passes = volux_malloc(ctx, most * sizeof(lv_pass));
    int *idx = volux_malloc(ctx, most * sizeof(int));
    if (!passes || !idx) {
        s = volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the light update");
    } else {
        decide(st, &st->env_cells, scene, NULL, 0, NULL, st->stats.selective_since_full, &d);
        st->job.queued = d.changed ? decision_steps(st, &d, passes, idx) : 0;
        if (d.changed && st->job.queued == 0) st->job.queued = 1; /* a change with nothing to propagate */
    }
    volux_free(ctx, passes, passes ? most * sizeof(lv_pass) : 0);
    volux_free(ctx, idx, idx ? most * sizeof(int) : 0);
    decision_free(ctx, &d);
    return s;
}

/* Starts the plan from `applied` to the scene (for the slots in c; all when
 * NULL) as the job. */
static volux_status start_update(lightvol_state *st, const volux_scene *scene, const volux_change_set *c,
                                 int force_full, const char *reason) {
    volux_context *ctx = st->rc.ctx;
    lv_decision d;
    volux_status s = decision_alloc(ctx, st, scene, &d);
    if (s) return s;
    decide(st, &st->env_cells, scene, c, force_full, reason, st->stats.selective_since_full, &d);
    st->stats.changed = d.changed;
    st->stats.total = d.total;
    if (!force_full && d.changed == 0) {
        st->stats.last = LV_UPDATE_NONE;
        st->stats.reason = "no light changed";
        st->stats.passes = st->stats.entries = 0;
    } else {
        if (d.promote) s = volux_lightvol_promote(st);
        if (!s) s = start_job(st, &d);
    }
    decision_free(ctx, &d);
    return s;
}

volux_status volux_lightvol_continue(lightvol_state *st, const volux_scene *scene, int *did) {
    *did = 0;
    if (st->job.active || !st->job.queued) return run_job(st, did);
    /* the queued plan, in a call of its own (a failure to start it then
     * changes nothing): from the finished job's target to the scene; its
     * size was measured with the same inputs (measure_queue), so pending()
     * only falls */
    volux_status s = start_update(st, scene, NULL, 0, NULL);
    if (s) return s;
    st->job.queued = 0;
    *did = 1;
    return run_job(st, did);
}

volux_status volux_lightvol_update_lights(lightvol_state *st, const volux_scene *scene, const volux_change_set *c,
                                          int force_full, const char *reason) {
    int budget_slices;
    double budget_ms;
    const int budget = lv_budget(st, &budget_slices, &budget_ms);
    int did = 0;
    volux_status s;
    if (!st->valid) force_full = 1, reason = reason ? reason : "illumination volume invalid";
    if (force_full) {
        /* the medium or the propagation changed under the job: an entire
         * update overwrites whatever it had done; a volume that is not valid
         * (new, resized, failed) is built at once */
        const int at_once = !st->valid || !budget;
        volux_lightvol_drop_job(st);
        if ((s = start_update(st, scene, NULL, 1, reason))) goto fail;
        if (at_once) {
            /* (a cancelled build leaves the volume invalid, as before) */
            while (st->job.active)
                if ((s = run_job(st, &did))) goto fail;
            return VOLUX_OK;
        }
        return run_job(st, &did);
    }
    if (st->job.active || st->job.queued) {
        /* light edits wait for the plan in progress (or the queued plan not
         * started yet, which then covers them too); count what they need */
        if ((s = measure_queue(st, scene))) return s;
    } else if (c) {
        if ((s = start_update(st, scene, c, 0, NULL))) return s;
    }
    if (!budget) {
        do {
            if ((s = volux_lightvol_continue(st, scene, &did))) return s;
        } while (volux_lightvol_pending(st) > 0);
        return VOLUX_OK;
    }
    return volux_lightvol_continue(st, scene, &did);
fail:
    volux_lightvol_drop_job(st);
    st->valid = 0;
    return s;
}
