/*
 * techniques/lightvol/plan.c — which propagation passes a set of light
 * items needs (coherent: the lights of one group together, §4; sequential:
 * one pass per light and group) and what they cost (§5's rule 2, with each
 * pass weighted by the light entries it carries). update.c compares the
 * costs of a selective and an entire update; sweep.c runs the plan.
 */

#include "lightvol.h"
#include "sweep.h"

/* Plans the passes for `items`: coherent = one pass per non-empty group
 * (split at max_per_pass lights), groups in axis order so same-axis groups
 * are consecutive (§4); sequential = one pass per light and group. Returns
 * the number of passes; fills passes/idx when non-NULL. */
int volux_lightvol_plan(const lv_item *items, int n, int coherent, int max_per_pass, lv_pass *passes, int *idx) {
    int np = 0, ni = 0;
    if (coherent) {
        for (int g = 0; g < LV_GROUPS; g++) {
            int in_pass = 0;
            for (int i = 0; i < n; i++) {
                if (!(items[i].src.groups & (1u << g))) continue;
                if (in_pass == 0 || in_pass == max_per_pass) {
                    if (passes) passes[np] = (lv_pass){g, ni, 0};
                    np++;
                    in_pass = 0;
                }
                if (passes) {
                    idx[ni] = i;
                    passes[np - 1].n++;
                }
                ni++;
                in_pass++;
            }
        }
    } else {
        for (int i = 0; i < n; i++)
            for (int g = 0; g < LV_GROUPS; g++) {
                if (!(items[i].src.groups & (1u << g))) continue;
                if (passes) {
                    passes[np] = (lv_pass){g, ni, 1};
                    idx[ni] = i;
                }
                np++;
                ni++;
            }
    }
    return np;
}

/* Estimated work of a plan in units of one pass's per-voxel fixed cost
 * (reading and classifying a slice, writing the volume): each pass costs
 * 1 plus, per light entry, the entry's weight (directional; point, spot,
 * sphere: per-voxel geometry, Eq. 5 factors and gathers). Calibrated on the
 * engine and bonsai at scale 1 (bench/lightvol, docs/techniques/lightvol.md):
 * with the portable kernel a directional entry costs ~0.3 of the fixed part
 * and a positional one ~4; with the AVX2 kernels ~0.2 and ~0.65 without
 * forward scattering, ~0.5 and 1.0–1.5 with it (f = 0.5, 10° cone: four
 * medium planes, the cone's taps; a close spot, sampled more densely along
 * its oblique segments, at the top). Near a tie either choice costs the
 * same, so the weights err towards the entire update. */
static const lv_work_weights LV_WORK_SCALAR = {0.3, 4.0}, LV_WORK_SIMD = {0.2, 0.7},
                             LV_WORK_SIMD_FORWARD = {0.5, 1.4};

lv_work_weights volux_lightvol_work_weights(const lightvol_state *st) {
    return !st->use_simd ? LV_WORK_SCALAR : st->p.forward > 0.0f ? LV_WORK_SIMD_FORWARD : LV_WORK_SIMD;
}

double volux_lightvol_plan_work(const lv_item *items, int n, int coherent, int max_per_pass, lv_work_weights w) {
    double work = 0.0;
    if (coherent) {
        for (int g = 0; g < LV_GROUPS; g++) {
            int count = 0;
            for (int i = 0; i < n; i++) {
                if (!(items[i].src.groups & (1u << g))) continue;
                count++;
                work += items[i].src.kind == LV_DIRECTIONAL ? w.dir : w.pos;
            }
            work += (double)((count + max_per_pass - 1) / max_per_pass);
        }
    } else {
        for (int i = 0; i < n; i++)
            for (int g = 0; g < LV_GROUPS; g++)
                if (items[i].src.groups & (1u << g))
                    work += 1.0 + (items[i].src.kind == LV_DIRECTIONAL ? w.dir : w.pos);
    }
    return work;
}
