/*
 * techniques/lightvol/lightvol.c — the `lightvol` class: parameters, the
 * change-set → cache-work mapping, and the ray caster that reads the
 * illumination volume.
 *
 * Rendering (single scattering from the propagated light):
 *     L = ∫ T(x) σs(x) p(x, ω_o) E(x) dx + T·background,   σs = albedo·c·σt
 * E(x) is the illumination volume (trilinear). With `directional` the
 * volume also holds D = Σ lum(E_l)·ω_l, and the phase function is the HG
 * lobe around ω̄ = D/|D| with g·|D|/lum(E) (this matches the mean cosine of
 * the mixture of the lights' HG lobes, and is exact where one light or
 * aligned lights arrive); without it the phase is isotropic. Optionally the
 * phase lobe is blended with gradient-based Blinn–Phong shading lit by the
 * same propagated (shadowed) light from ω̄.
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/vecmath.h"
#include "lightvol.h"
#include "sweep.h"

static const volux_param_info lightvol_params[] = {
    {"scale", VOLUX_PARAM_NUMBER, 1, 0.0625, 1, NULL,
     "illumination volume resolution as a fraction of the data resolution, per axis (1, 0.5, 0.25)"},
    {"scale_x", VOLUX_PARAM_NUMBER, 0, 0, 1, NULL, "override of scale along x (0 = use scale)"},
    {"scale_y", VOLUX_PARAM_NUMBER, 0, 0, 1, NULL, "override of scale along y (0 = use scale)"},
    {"scale_z", VOLUX_PARAM_NUMBER, 0, 0, 1, NULL, "override of scale along z (0 = use scale)"},
    {"propagation", VOLUX_PARAM_STRING, 0, 0, 0, "coherent",
     "coherent: all lights of a propagation group in one sweep (Sec. 4); sequential: one sweep per light and "
     "group (baseline)"},
    {"cost_rule", VOLUX_PARAM_STRING, 0, 0, 0, "work",
     "selective vs entire light update (Sec. 5): passes (rule 2: fewer propagation passes; ties by rule 1), lights "
     "(rule 1: at most half of the lights changed), work (rule 2 with each pass weighted by the lights it carries, "
     "point/spot lights costing ~3x (AVX2 kernels) or ~13x (portable) a directional one; ties by rule 1), selective, "
     "full"},
    {"positional_grouping", VOLUX_PARAM_STRING, 0, 0, 0, "center",
     "propagation groups of point/spot lights: center (Sec. 4: the two closest faces of the light-to-volume-centre "
     "direction, constant Eq. 5 factors, at most two groups shared with the directional lights; a light inside the "
     "box, or beside it within both groups' slabs, falls back to voxel) or voxel (the two closest faces of each "
     "voxel's own direction to the light, per-voxel factors, up to six groups); same error vs pathtrace, center "
     "about half the time with point/spot lights (docs/techniques/lightvol.md)"},
    {"max_lights_per_pass", VOLUX_PARAM_INT, 32, 1, 256, NULL,
     "lights propagated together in one sweep; larger groups are split (bounds slice-buffer memory)"},
    {"forward_scattering", VOLUX_PARAM_NUMBER, 0, 0, 1, NULL,
     "fraction f of the scattered light that keeps travelling with the light during propagation: extinction along "
     "the light is sigma_t - f*sigma_s (chromatic shadows); 1 is the paper's per-voxel formula with albedo"},
    {"scatter_cone", VOLUX_PARAM_NUMBER, 0, 0, 45, NULL,
     "half-angle (degrees) of the forward-scattering cone the forward-scattered light spreads into (soft "
     "shadows); needs forward_scattering > 0"},
    {"directional", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,
     "also store the luminance-weighted light direction per voxel (3 more floats) so the HG phase function and "
     "local shading see where the light comes from; 0 = RGB only, isotropic phase"},
    {"precision", VOLUX_PARAM_STRING, 0, 0, 0, "auto",
     "storage of the illumination volume: auto (bfloat16, 2 bytes per value, after an entire update; float from the "
     "first selective light update on, since 8 significant bits cannot carry add/subtract edits: the update that "
     "switches is an entire one) or float (always 4 bytes per value)"},
    {"rebaseline_interval", VOLUX_PARAM_INT, 1000, 0, 1000000, NULL,
     "entire update after this many selective updates, bounding accumulated float drift (0 = never)"},
    {"local_shading", VOLUX_PARAM_NUMBER, 0, 0, 1, NULL,
     "weight of gradient-based Blinn-Phong shading (TF material) lit by the propagated light; needs directional"},
    VOLUX_PARAM_GRADIENT_THRESHOLD("local shading is"),
    VOLUX_PARAM_PREINTEGRATE,
    VOLUX_PARAM_EARLY_TERMINATION,
    VOLUX_PARAM_SKIP_EMPTY,
    VOLUX_PARAM_PACKET_KERNEL,
    {"kernel", VOLUX_PARAM_STRING, 0, 0, 0, "auto",
     "propagation row kernels: auto (AVX2+FMA where the CPU has them, AVX-512 steps where it has those too), "
     "scalar (portable reference), simd (as auto; error if unavailable) or avx2 (AVX2 only); same volume up to "
     "float rounding"},
    {"budget_ms", VOLUX_PARAM_NUMBER, 0, 0, 100000, NULL,
     "Sec. 7.3 incremental update: an update (and each volux_technique_refine step, e.g. the viewer's between "
     "frames) propagates about this many milliseconds of light (slice steps at the measured rate), renders use the "
     "partly updated illumination volume, and later steps finish it (bit-identical to an update at once); 0 = all "
     "at once"},
    {"budget_slices", VOLUX_PARAM_INT, 0, 0, 1000000, NULL,
     "as budget_ms, counted in slice steps of the propagation sweeps (deterministic; overrides budget_ms); 0 = use "
     "budget_ms"},
    {"show", VOLUX_PARAM_STRING, 0, 0, 0, "radiance",
     "radiance: the scattered light (the technique); illumination: the illumination volume itself, the RGB "
     "light E arriving at each sample without albedo, colour or phase, through the transfer function's opacity "
     "(the paper's Fig. 4b, a view for checking light setups)"},
    {"env_directions", VOLUX_PARAM_INT, 16, 0, LV_MAX_ENV_DIRS, NULL,
     "environment lights as this many directional lights propagated like the others (the Fibonacci set of "
     "techniques.single.env_directions, each carrying the environment's radiance over its cell; they share the "
     "six propagation groups with the scene's lights); 0 = ignore environment lights (with a warning)"},
    {"rebuild_token", VOLUX_PARAM_NUMBER, 0, 0, 1e15, NULL,
     "benchmark hook: changing this value forces an entire light update"},
    {NULL, 0, 0, 0, 0, NULL, NULL}};

/* ---------------------------------------------------------------- params */

static volux_status read_params(lightvol_state *st, const volux_scene *scene, lv_params *p) {
    const volux_technique_class *cls = &volux_lightvol_class;
    volux_context *ctx = st->rc.ctx;
    memset(p, 0, sizeof *p);
    float scale = (float)volux_technique_param(scene, cls, "scale");
    static const char *axes[3] = {"scale_x", "scale_y", "scale_z"};
    for (int a = 0; a < 3; a++) {
        double s = volux_technique_param(scene, cls, axes[a]);
        if (s != 0.0 && s < 0.0625)
            return volux_error(ctx, VOLUX_ERR_INVALID,
                               "techniques.lightvol.%s: must be 0 (use scale) or in [0.0625, 1], got %g", axes[a], s);
        p->scale[a] = s != 0.0 ? (float)s : scale;
    }
    const char *prop = volux_technique_param_string(scene, cls, "propagation");
    if (!strcmp(prop, "coherent")) p->coherent = 1;
    else if (!strcmp(prop, "sequential")) p->coherent = 0;
    else
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.lightvol.propagation: expected \"coherent\" or \"sequential\", got \"%s\"", prop);
    const char *rule = volux_technique_param_string(scene, cls, "cost_rule");
    if (!strcmp(rule, "work")) p->cost_rule = LV_RULE_WORK;
    else if (!strcmp(rule, "passes")) p->cost_rule = LV_RULE_PASSES;
    else if (!strcmp(rule, "lights")) p->cost_rule = LV_RULE_LIGHTS;
    else if (!strcmp(rule, "selective")) p->cost_rule = LV_RULE_SELECTIVE;
    else if (!strcmp(rule, "full")) p->cost_rule = LV_RULE_FULL;
    else
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.lightvol.cost_rule: expected \"work\", \"passes\", \"lights\", \"selective\" or \"full\", "
                           "got \"%s\"",
                           rule);
    const char *kernel = volux_technique_param_string(scene, cls, "kernel");
    if (!strcmp(kernel, "auto")) p->kernel = LV_KERNEL_AUTO;
    else if (!strcmp(kernel, "scalar")) p->kernel = LV_KERNEL_SCALAR;
    else if (!strcmp(kernel, "simd")) p->kernel = LV_KERNEL_SIMD;
    else if (!strcmp(kernel, "avx2")) p->kernel = LV_KERNEL_AVX2;
    else
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.lightvol.kernel: expected \"auto\", \"scalar\", \"simd\" or \"avx2\", got \"%s\"",
                           kernel);
    if ((p->kernel == LV_KERNEL_SIMD || p->kernel == LV_KERNEL_AVX2) && !volux_lightvol_simd_available())
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "techniques.lightvol.kernel: \"simd\" needs a CPU with AVX2 and FMA");
    const char *grouping = volux_technique_param_string(scene, cls, "positional_grouping");
    if (!strcmp(grouping, "voxel")) p->grouping = LV_GROUP_VOXEL;
    else if (!strcmp(grouping, "center")) p->grouping = LV_GROUP_CENTER;
    else
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.lightvol.positional_grouping: expected \"voxel\" or \"center\", got \"%s\"",
                           grouping);
    p->max_per_pass = (int)volux_technique_param(scene, cls, "max_lights_per_pass");
    p->forward = (float)volux_technique_param(scene, cls, "forward_scattering");
    p->cone_deg = (float)volux_technique_param(scene, cls, "scatter_cone");
    p->directional = (int)volux_technique_param(scene, cls, "directional");
    const char *precision = volux_technique_param_string(scene, cls, "precision");
    if (strcmp(precision, "auto") != 0 && strcmp(precision, "float") != 0)
        return volux_error(st->rc.ctx, VOLUX_ERR_INVALID,
                           "techniques.lightvol.precision: '%s' is not one of auto, float", precision);
    p->precision_float = !strcmp(precision, "float");
    p->rebaseline = (int)volux_technique_param(scene, cls, "rebaseline_interval");
    p->local_shading = (float)volux_technique_param(scene, cls, "local_shading");
    p->gradient_threshold = (float)volux_technique_param(scene, cls, "gradient_threshold");
    p->preintegrate = (int)volux_technique_param(scene, cls, "preintegrate");
    p->skip_empty = (int)volux_technique_param(scene, cls, "skip_empty");
    p->t_min = (float)volux_technique_param(scene, cls, "early_termination");
    p->rebuild_token = volux_technique_param(scene, cls, "rebuild_token");
    p->budget_ms = (float)volux_technique_param(scene, cls, "budget_ms");
    p->budget_slices = (int)volux_technique_param(scene, cls, "budget_slices");
    const char *show = volux_technique_param_string(scene, cls, "show");
    if (!strcmp(show, "radiance")) p->show_illumination = 0;
    else if (!strcmp(show, "illumination")) p->show_illumination = 1;
    else
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.lightvol.show: expected \"radiance\" or \"illumination\", got \"%s\"", show);
    p->env_dirs = (int)volux_technique_param(scene, cls, "env_directions");
    if (p->local_shading > 0.0f && !p->directional)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.lightvol.local_shading: needs techniques.lightvol.directional = true (the light "
                           "direction comes from the illumination volume)");
    return VOLUX_OK;
}

/* ---------------------------------------------------------------- update */

static volux_status lightvol_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    lightvol_state *st = state;
    volux_raycaster *rc = &st->rc;
    volux_context *ctx = rc->ctx;
    volux_status s;
    int realloc_vol = 0, medium = 0, full = 0;
    const char *reason = NULL;
    const uint32_t w = c->what;
    if (w & VOLUX_CHANGE_VOLUME) {
        realloc_vol = 1;
        reason = "volume changed";
        volux_gradient_cache_free(ctx, &st->grad);
        if ((s = volux_volume_build_bricks(rc->volume))) return s;
    }
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY | VOLUX_CHANGE_COLOR |
             VOLUX_CHANGE_ALBEDO))
        medium = 1;
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) {
        full = 1;
        if (!reason) reason = "transfer function changed";
    }
    if (w & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        lv_params np;
        if ((s = read_params(st, scene, &np))) return s;
        const lv_params *op = &st->p;
        if (memcmp(np.scale, op->scale, sizeof np.scale) != 0 || np.directional != op->directional ||
            (np.precision_float && !st->volf))
            realloc_vol = 1;
        /* a kernel switch rebuilds, so that selective updates never mix two
         * kernels' rounding in one volume */
        if (np.forward != op->forward || np.cone_deg != op->cone_deg || np.rebuild_token != op->rebuild_token ||
            np.kernel != op->kernel || np.grouping != op->grouping || np.env_dirs != op->env_dirs) {
            full = 1;
            if (!reason) reason = "parameters changed";
        }
        st->p = np;
        st->use_simd = np.kernel != LV_KERNEL_SCALAR && volux_lightvol_simd_available();
        st->use_avx512 = st->use_simd && np.kernel != LV_KERNEL_AVX2 && volux_lightvol_avx512_available();
        st->grad_ref = volux_raycaster_gradient_ref(rc, np.gradient_threshold);
    }
    if ((w & (VOLUX_CHANGE_LIGHTS | VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) &&
        (s = volux_raycaster_warn_unused_lights(rc, st->p.env_dirs ? 0u : 1u << VOLUX_LIGHT_ENVIRONMENT,
                                                "techniques.lightvol.env_directions is 0")))
        return s;
    if (st->p.local_shading > 0.0f && !st->grad.grad)
        if ((s = volux_gradient_cache_build(ctx, rc->volume, &st->grad, "lightvol"))) return s;
    if (realloc_vol) {
        if ((s = volux_lightvol_alloc(st))) return s;
        medium = 1;
        full = 1;
        if (!reason) reason = "illumination volume resized";
    }
    if (medium) {
        if ((s = volux_lightvol_build_medium(st))) return s;
        /* σs enters propagation only through forward scattering */
        if ((w & (VOLUX_CHANGE_COLOR | VOLUX_CHANGE_ALBEDO)) && st->p.forward > 0.0f) {
            full = 1;
            if (!reason) reason = "colour or albedo changed (forward scattering)";
        }
    }
    if (w & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME))
        if ((s = volux_packet_kernel_choose(ctx, scene, rc->cls, 1, "", &st->march_lanes))) return s;
    if (st->march_lanes && (s = volux_packet_tables_update(ctx, rc->volume, rc->lut, w, &st->pk))) return s;
    if (!st->march_lanes) volux_packet_tables_free(ctx, &st->pk);
    if (full || !st->valid) return volux_lightvol_update_lights(st, scene, c, 1, reason);
    if (w & VOLUX_CHANGE_LIGHTS) return volux_lightvol_update_lights(st, scene, c, 0, NULL);
    /* any other edit also advances a propagation in progress (§7.3: so much
     * per frame), or finishes it once the budget is switched off */
    if (volux_lightvol_pending(st) > 0) return volux_lightvol_update_lights(st, scene, NULL, 0, NULL);
    return VOLUX_OK;
}

/* §7.3: the next budget of a propagation in progress. */
static volux_status lightvol_refine(void *state, const volux_scene *scene, int *changed, int *more) {
    lightvol_state *st = state;
    volux_status s = volux_lightvol_continue(st, scene, changed);
    *more = volux_lightvol_pending(st) > 0;
    return s;
}

static uint64_t lightvol_pending(const void *state) { return volux_lightvol_pending(state); }

/* The front end's per-frame budget (volux_technique_set_budget). Switching
 * it off leaves a job in progress to the next update or refine step, which
 * then finishes it at once. */
static void lightvol_set_budget(void *state, double ms) { ((lightvol_state *)state)->frame_budget_ms = ms; }

static void lightvol_release(void *state) {
    lightvol_state *st = state;
    volux_packet_tables_free(st->rc.ctx, &st->pk);
    volux_lightvol_free_buffers(st);
    volux_lightvol_drop_job(st);
    volux_gradient_cache_free(st->rc.ctx, &st->grad);
    volux_free(st->rc.ctx, st->applied, sizeof *st->applied * (size_t)st->applied_cap);
    st->applied = NULL;
    st->applied_cap = 0;
}

static size_t lightvol_memory_bytes(const void *state) {
    const lightvol_state *st = state;
    return volux_packet_tables_bytes(&st->pk) + st->vol_bytes + st->medium_bytes + volux_lightvol_scratch_bytes(st) +
           st->grad.bytes +
           st->job.items_bytes + st->job.passes_bytes + st->job.idx_bytes +
           sizeof *st->applied * (size_t)st->applied_cap;
}

/* ---------------------------------------------------------------- kernel */

/* Illumination at illumination-index position q (trilinear, the first
 * `ch` channels; the stride is st->ch). */
static inline void illum_at(const lightvol_state *st, volux_vec3 q, float *out, int ch) {
    const int m0 = st->dims[0], m1 = st->dims[1], m2 = st->dims[2];
    float x = clampf(q.x, 0.0f, (float)(m0 - 1)), y = clampf(q.y, 0.0f, (float)(m1 - 1)),
          z = clampf(q.z, 0.0f, (float)(m2 - 1));
    int i = (int)x, j = (int)y, k = (int)z;
    if (i > m0 - 2) i = m0 - 2;
    if (j > m1 - 2) j = m1 - 2;
    if (k > m2 - 2) k = m2 - 2;
    float fx = x - (float)i, fy = y - (float)j, fz = z - (float)k;
    size_t sx = (size_t)st->ch, sy = (size_t)m0 * sx, sz = (size_t)m1 * sy;
    const size_t b = (((size_t)k * (size_t)m1 + (size_t)j) * (size_t)m0 + (size_t)i) * sx;
    for (size_t c = 0; c < (size_t)ch; c++) {
        float v000 = lv_vol_get(st, b + c), v100 = lv_vol_get(st, b + sx + c);
        float v010 = lv_vol_get(st, b + sy + c), v110 = lv_vol_get(st, b + sy + sx + c);
        float v001 = lv_vol_get(st, b + sz + c), v101 = lv_vol_get(st, b + sz + sx + c);
        float v011 = lv_vol_get(st, b + sz + sy + c), v111 = lv_vol_get(st, b + sz + sy + sx + c);
        float c00 = v000 + (v100 - v000) * fx;
        float c10 = v010 + (v110 - v010) * fx;
        float c01 = v001 + (v101 - v001) * fx;
        float c11 = v011 + (v111 - v011) * fx;
        float c0 = c00 + (c10 - c00) * fy, c1 = c01 + (c11 - c01) * fy;
        out[c] = c0 + (c1 - c0) * fz;
    }
}

static inline float hg(float g, float cos_theta) {
    float d = 1.0f + g * g - 2.0f * g * cos_theta;
    return VOLUX_INV_4PI * (1.0f - g * g) / (d * sqrtf(d));
}

/* Radiance scattered towards the camera per unit optical depth at data
 * index q (world p), colour c (TF colour, σt-weighted over the segment). */
static inline __attribute__((always_inline)) void scatter(const lightvol_state *st, volux_vec3 p, volux_vec3 q, volux_vec3 dir, const float c[3],
                           float S[3], int local) {
    float I[6];
    volux_vec3 qi = v3(q.x * st->data_to_ill[0], q.y * st->data_to_ill[1], q.z * st->data_to_ill[2]);
    /* The mean light direction (channels 3–5) only shapes the phase
     * function and the local shading: with g = 0 and no local shading the
     * phase is 1/4π whatever it is (hg(0, ·) = 1/4π exactly), so it is not
     * interpolated — the same image, fewer lerps per sample. */
    const int need_dir = st->ch == 6 && (st->rc.g != 0.0f || local);
    illum_at(st, qi, I, need_dir ? 6 : 3);
    /* selective updates may leave −ε where a light was removed */
    volux_vec3 E = v3(fmaxf(I[0], 0.0f), fmaxf(I[1], 0.0f), fmaxf(I[2], 0.0f));
    if (st->p.show_illumination) { /* Fig. 4b: the light volume itself */
        S[0] = E.x, S[1] = E.y, S[2] = E.z;
        return;
    }
    float lum = v3_luminance(E);
    if (!(lum > 0.0f)) {
        S[0] = S[1] = S[2] = 0.0f;
        return;
    }
    float phase = VOLUX_INV_4PI;
    volux_vec3 wbar = v3(0, 0, 0);
    if (need_dir) {
        volux_vec3 D = v3(I[3], I[4], I[5]);
        float dl = v3_length(D);
        if (dl > 0.0f) {
            wbar = v3_scale(D, 1.0f / dl);
            float r = fminf(dl / lum, 1.0f);
            phase = hg(st->rc.g * r, -v3_dot(wbar, dir));
        }
    }
    float a = st->rc.albedo;
    S[0] = a * c[0] * E.x * phase;
    S[1] = a * c[1] * E.y * phase;
    S[2] = a * c[2] * E.z * phase;
    if (!local || (wbar.x == 0.0f && wbar.y == 0.0f && wbar.z == 0.0f)) return;
    volux_vec3 n;
    float m = volux_shading_normal(volux_gradient_cache_sample(&st->grad, st->rc.volume, q), st->grad_ref, dir, &n);
    if (m <= 0.0f) return;
    (void)p;
    const volux_material *mat = &st->rc.material;
    volux_vec3 diff = v3(0, 0, 0), spec = v3(0, 0, 0);
    volux_blinn_phong(mat, n, v3_scale(wbar, -1.0f), dir, E, &diff, &spec);
    /* Lambert-normalised surface radiance: (albedo·c·(ka·E + kd·E·cos) + ks·E·lobe)/π */
    float surf[3] = {(a * c[0] * (mat->ambient * E.x + diff.x) + spec.x) * VOLUX_INV_PI,
                     (a * c[1] * (mat->ambient * E.y + diff.y) + spec.y) * VOLUX_INV_PI,
                     (a * c[2] * (mat->ambient * E.z + diff.z) + spec.z) * VOLUX_INV_PI};
    float wl = st->p.local_shading * m;
    for (int k = 0; k < 3; k++) S[k] += (surf[k] - S[k]) * wl;
}

/* The ray caster (render/raycaster.h) specialised by `variant`: bit 0
 * local shading, bit 1 pre-integration; each segment scatters the
 * illumination volume's light at its end. */
enum { LV_LOCAL = 1, LV_PREINT = 2 };

static inline __attribute__((always_inline)) float sample_at(const void *tech, const volux_ray *r, float t,
                                                              int variant) {
    (void)variant;
    const lightvol_state *st = tech;
    /* the bricked copy (lightvol_update builds it): the same value as the
     * linear layout, fewer cache misses along oblique rays */
    return volux_volume_sample_bricked(st->rc.volume, r->q0.x + r->dq.x * t, r->q0.y + r->dq.y * t,
                                       r->q0.z + r->dq.z * t, st->rc.volume->storage);
}

static inline __attribute__((always_inline)) void shade_at(const void *tech, const volux_ray *ray, float t,
                                                            float c[3], int variant) {
    float S[3];
    scatter(tech, v3_madd(ray->o, ray->d, t), v3_madd(ray->q0, ray->dq, t), ray->d, c, S, variant & LV_LOCAL);
    c[0] = S[0], c[1] = S[1], c[2] = S[2];
}

void volux_lightvol_shade_lane(const void *tech, const volux_packet_lane *in, float c[3]) {
    const lightvol_state *st = tech;
    float S[3];
    scatter(st, in->p, in->q, in->d, c, S, st->p.local_shading > 0.0f && st->grad.grad);
    c[0] = S[0], c[1] = S[1], c[2] = S[2];
}

static inline __attribute__((always_inline)) volux_vec3 integrate(const void *tech, const volux_ray *ray,
                                                                   float jitter, float *T, uint64_t *samples,
                                                                   int variant) {
    const lightvol_state *st = tech;
    const volux_ea_march_desc m = {st->rc.lut, st->p.skip_empty ? &st->rc.grid : NULL, st->rc.step, st->p.t_min};
    return volux_ea_march(&m, tech, ray, jitter, T, samples, (variant & LV_PREINT) != 0, sample_at, shade_at,
                          variant);
}

static void lightvol_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                 volux_tile_stats *stats) {
    const lightvol_state *st = state;
    if (st->march_lanes) { /* the packet march (march_lanes.h) */
        const volux_packet_march pm = {&st->rc, st->rc.lut, &st->pk, st->p.t_min, st->p.skip_empty,
                                       st->p.preintegrate};
        if (st->march_lanes == 16) volux_lightvol_march_avx512(&pm, st, scene, tile, rgb, stats);
        else volux_lightvol_march_avx2(&pm, st, scene, tile, rgb, stats);
        return;
    }
    int local = st->p.local_shading > 0.0f && st->grad.grad;
    if (st->p.preintegrate && local)
        volux_raycaster_tile(&st->rc, st, scene, tile, rgb, stats, integrate, LV_PREINT | LV_LOCAL);
    else if (st->p.preintegrate) volux_raycaster_tile(&st->rc, st, scene, tile, rgb, stats, integrate, LV_PREINT);
    else if (local) volux_raycaster_tile(&st->rc, st, scene, tile, rgb, stats, integrate, LV_LOCAL);
    else volux_raycaster_tile(&st->rc, st, scene, tile, rgb, stats, integrate, 0);
}

/* The phase function and all lights reach the image; nothing is ignored.
 * Update tolerance: with precision auto an instance whose lights were
 * edited holds a float volume, a fresh one a bfloat16 volume (lightvol.h):
 * their images differ by that rounding, up to one bfloat16 step (2⁻⁸) of
 * the brightest value (measured 6.3e-4 of the image maximum in the
 * technique matrix, 2.9e-3 on the engine scene); float arithmetic alone
 * stays below 1e-4. */
const volux_technique_class volux_lightvol_class = {
    {"lightvol",
     "multi-light illumination volume: coherent propagation + selective light updates (Sunden & Ropinski 2015)",
     lightvol_params, 0},
    sizeof(lightvol_state), 0, 4e-3f,
    NULL, lightvol_update, lightvol_render_tile, lightvol_memory_bytes, lightvol_release,
    lightvol_refine, lightvol_pending, NULL, /* §7.3 budget; no statistics */
    NULL, /* no bricks: its light leaves the camera ray (scattering, shadows) */
    lightvol_set_budget,
    volux_lightvol_estimate_bytes,
    NULL, /* nothing per pass */
};
