/*
 * techniques/guided/lazy.c — lazy visibility updates for sequences (§9):
 * which time step each direction of the visibility grid is computed from.
 *
 * The paper updates a subset of the directions per frame as an animation
 * plays. We make the subset a function of the time step t alone, so the
 * visibility at step t is the same whether the instance stepped through
 * the sequence or was created at t (the technique × edit invariant), and
 * stepping forward by one recomputes exactly the paper's per-frame subset:
 *
 *   round_robin: directions in bit-reversed Morton order (Fig. 7: the
 *       position p's bits reversed give the Morton code of the direction,
 *       so consecutive positions spread over the octahedron), `budget` per
 *       step, cyclically: position p is refreshed at the steps
 *       t ≡ ⌊p / budget⌋ (mod K), K = ⌈D / budget⌉; its source is the last
 *       such step ≤ t.
 *   environment: at every step t ≥ 1, `budget` directions drawn from the
 *       environment's luminance at the grid's angular resolution (random
 *       stream keyed by t); a direction's source is the last step that drew
 *       it.
 *   static: every direction from ⌊t / K⌋·K ("full every K frames").
 *   off: every direction from t.
 *
 * Before a direction's first refresh its source is step 0 (the paper starts
 * an animation with one full computation).
 */
#include <string.h>

#include "core/context_internal.h"
#include "core/rng.h"
#include "guided.h"
#include "sample/octahedral.h"

static uint32_t reverse_bits(uint32_t x, int bits) {
    uint32_t r = 0;
    for (int i = 0; i < bits; i++) r |= ((x >> i) & 1u) << (bits - 1 - i);
    return r;
}

volux_status guided_lazy_sources(volux_context *ctx, const guided_vis_params *p, int dirs, const guided_env *env,
                                 uint64_t seed, int t, int *src) {
    int budget = p->budget < dirs ? p->budget : dirs;
    int K = (dirs + budget - 1) / budget;
    int bits = 0;
    while ((1 << bits) < dirs) bits++;
    switch (p->lazy) {
    case GUIDED_LAZY_OFF:
        for (int d = 0; d < dirs; d++) src[d] = t;
        return VOLUX_OK;
    case GUIDED_LAZY_STATIC:
        for (int d = 0; d < dirs; d++) src[d] = t / K * K;
        return VOLUX_OK;
    case GUIDED_LAZY_ROUND_ROBIN:
        for (int d = 0; d < dirs; d++) {
            int slot = (int)reverse_bits((uint32_t)d, bits) / budget; /* the reversal is its own inverse */
            int s = t - ((t - slot) % K + K) % K;
            src[d] = s < 0 ? 0 : s;
        }
        return VOLUX_OK;
    default: break;
    }
    /* environment-guided: the discrete distribution of the environment's
     * level with one node per direction (uniform without an environment) */
    size_t cdf_bytes = sizeof(double) * (size_t)(dirs + 1);
    double *cdf = volux_malloc(ctx, cdf_bytes);
    if (!cdf) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the lazy update schedule");
    int level = 0;
    while ((1 << (2 * level)) < dirs) level++;
    cdf[0] = 0.0;
    for (int d = 0; d < dirs; d++)
        cdf[d + 1] = cdf[d] + (env && env->present ? (double)env->nodes[volux_qt_offset(level) + (uint32_t)d] : 1.0);
    for (int d = 0; d < dirs; d++) src[d] = -1;
    int missing = dirs;
    for (int s = t; s >= 1 && missing > 0; s--) {
        volux_rng rng = volux_rng_make(seed, 0x1a2bu, (uint64_t)s, 7);
        for (int i = 0; i < budget; i++) {
            double u = volux_rng_double(&rng) * cdf[dirs];
            int lo = 0, hi = dirs - 1; /* first d with cdf[d + 1] > u */
            while (lo < hi) {
                int mid = (lo + hi) / 2;
                if (cdf[mid + 1] > u) hi = mid;
                else lo = mid + 1;
            }
            if (src[lo] < 0) {
                src[lo] = s;
                missing--;
            }
        }
    }
    for (int d = 0; d < dirs; d++)
        if (src[d] < 0) src[d] = 0;
    volux_free(ctx, cdf, cdf_bytes);
    return VOLUX_OK;
}
