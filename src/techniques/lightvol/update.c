/*
 * techniques/lightvol/update.c — selective light updates (§5): the light in
 * every slot as last applied (lv_applied) against the scene's; each changed
 * slot becomes a remove item (its old source, sign −1) and an add item (its
 * new one, +1), propagated through the same sweeps as an entire update. The
 * cost rule picks selective or entire (plan.c estimates both); an entire
 * update every rebaseline_interval selective ones bounds float drift.
 */

#include <string.h>

#include "core/context_internal.h"
#include "lightvol.h"
#include "sweep.h"

volux_status volux_lightvol_update_lights(lightvol_state *st, const volux_scene *scene, const volux_change_set *c,
                                          int force_full, const char *reason) {
    volux_context *ctx = st->rc.ctx;
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
        int ps = volux_lightvol_plan(items, n, st->p.coherent, st->p.max_per_pass, NULL, NULL);
        int pf = volux_lightvol_plan(full_items, nf, st->p.coherent, st->p.max_per_pass, NULL, NULL);
        const lv_work_weights ww = volux_lightvol_work_weights(st);
        double ws = volux_lightvol_plan_work(items, n, st->p.coherent, st->p.max_per_pass, ww);
        double wf = volux_lightvol_plan_work(full_items, nf, st->p.coherent, st->p.max_per_pass, ww);
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
        s = volux_lightvol_run_passes(st, items, n, 0);
    } else {
        s = volux_lightvol_run_passes(st, full_items, nf, 1);
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
