/*
 * techniques/lightvol/sources.c — a scene light reduced to what propagation
 * needs (lv_source: power, direction or position, spot cone, the groups it
 * is propagated in with their Eq. 5 factors), and the value it sends to a
 * point without occlusion (the ray caster's and the tests' reference).
 * The per-ray value and spot factor the row loops also use are static
 * inline in sweep.h.
 */

#include <math.h>
#include <string.h>

#include "core/vecmath.h"
#include "lightvol.h"
#include "sweep.h"

void volux_lightvol_unoccluded(const lightvol_state *st, const lv_source *s, volux_vec3 p, float out[3]) {
    lv_ray_value(s, p, out);
    if (s->kind == LV_POSITIONAL) {
        volux_vec3 d = v3_sub(p, s->pos);
        float r2 = fmaxf(v3_dot(d, d), lv_rmin2(st));
        for (int c = 0; c < 3; c++) out[c] /= r2;
    }
}

/* Groups a positional light needs: every group that is one of the two
 * closest faces for the local direction at some point of the box it lights
 * (weights are evaluated per voxel during the sweep). Sampled on a 9³ grid
 * over the box plus, for spots, the cone axis and rim. A group missed by the
 * sampling can only own a thin sliver near a group boundary, where its
 * factor is close to 0 (the factors are continuous). */
static unsigned positional_groups(const lightvol_state *st, const lv_source *s) {
    const volux_volume *v = st->rc.volume;
    volux_vec3 lo, hi;
    volux_volume_bounds(v, &lo, &hi);
    unsigned mask = 0;
    float w[LV_GROUPS];
    const int N = 9;
    for (int k = 0; k < N; k++)
        for (int j = 0; j < N; j++)
            for (int i = 0; i < N; i++) {
                volux_vec3 p = v3(lo.x + (hi.x - lo.x) * (float)i / (float)(N - 1),
                                  lo.y + (hi.y - lo.y) * (float)j / (float)(N - 1),
                                  lo.z + (hi.z - lo.z) * (float)k / (float)(N - 1));
                volux_vec3 d = v3_sub(p, s->pos);
                float r = v3_length(d);
                if (!(r > 1e-6f)) continue;
                d = v3_scale(d, 1.0f / r);
                if (s->spot && lv_spot_factor(s, v3_dot(d, s->dir)) <= 0.0f) continue;
                mask |= lv_face_weights(d, w);
            }
    if (s->spot) {
        volux_vec3 t, b;
        v3_basis(s->dir, &t, &b);
        float ang = acosf(clampf(s->cos_cone, -1.0f, 1.0f)) * 0.999f;
        for (int q = 0; q <= 8; q++) {
            volux_vec3 d = s->dir;
            if (q) {
                float phi = (float)(q - 1) * (VOLUX_PI / 4.0f);
                d = v3_normalize(v3_add(v3_scale(s->dir, cosf(ang)),
                                        v3_add(v3_scale(t, sinf(ang) * cosf(phi)), v3_scale(b, sinf(ang) * sinf(phi)))));
            }
            float t0, t1;
            if (v3_ray_box(s->pos, d, lo, hi, &t0, &t1)) mask |= lv_face_weights(d, w);
        }
    }
    return mask;
}

/* §4's grouping of a point or spot light: by its main direction, light →
 * volume centre, the two closest faces with that direction's Eq. 5 factors
 * (constant over the volume; a voxel one of the two groups cannot reach —
 * it lies behind the light along that group's axis — takes the light from
 * the other one alone, see lv_center_weight). Returns 0 when the two groups
 * do not reach every node of the box (the light lies inside it, or beside it
 * within the slabs of both axes): §7.3's case that needs more groups, left
 * to the per-voxel grouping. */
static int center_groups(const lightvol_state *st, lv_source *s) {
    volux_vec3 lo, hi;
    volux_volume_bounds(st->rc.volume, &lo, &hi);
    volux_vec3 dir = v3_sub(v3_scale(v3_add(lo, hi), 0.5f), s->pos);
    if (!(v3_dot(dir, dir) > 0.0f)) return 0;
    float w[LV_GROUPS];
    unsigned mask = lv_face_weights(v3_normalize(dir), w);
    /* light position in illumination index space, as the sweep computes it */
    volux_vec3 q = v3_sub(s->pos, st->lo);
    const float l[3] = {q.x / st->spacing[0], q.y / st->spacing[1], q.z / st->spacing[2]};
    int covers = 0;
    for (int g = 0; g < LV_GROUPS; g++) {
        if (!(mask & (1u << g))) continue;
        int a = g / 2, sg = (g & 1) ? -1 : 1;
        /* every node k of axis a lies ahead: s·(k − l) > 0 for k = 0 or m − 1 */
        float edge = sg > 0 ? 0.0f : (float)(st->dims[a] - 1);
        covers |= (float)sg * (edge - l[a]) > 0.0f;
    }
    if (!covers) return 0;
    memcpy(s->weight, w, sizeof w);
    s->groups = mask;
    s->center = 1;
    return 1;
}

int volux_lightvol_source(const lightvol_state *st, const volux_light_desc *d, lv_source *s) {
    memset(s, 0, sizeof *s);
    /* environments: as env directions (volux_lightvol_env_source) */
    if (!d || !d->enabled || d->type == VOLUX_LIGHT_ENVIRONMENT) return 0;
    volux_prepared_light l;
    volux_light_prepare(d, 0, &l); /* power, travel direction, position (render/lights.h) */
    s->power = l.power;
    if (!l.positional) {
        s->kind = LV_DIRECTIONAL;
        s->dir = l.travel;
    } else {
        /* a sphere sends the intensity of a point, I = L·π·r², seen from
         * outside (as `shaded` does) */
        s->kind = LV_POSITIONAL;
        s->pos = l.pos;
        if (l.spot) {
            s->spot = 1;
            s->dir = l.axis;
            s->cos_cone = cosf(d->cone_angle_deg * VOLUX_PI / 180.0f);
            s->cos_fall = cosf(d->falloff_angle_deg * VOLUX_PI / 180.0f);
        }
    }
    if (!(s->power.x > 0.0f || s->power.y > 0.0f || s->power.z > 0.0f)) return 0;
    if (s->kind == LV_DIRECTIONAL) s->groups = lv_face_weights(s->dir, s->weight);
    else {
        /* the per-voxel groups also tell whether the light reaches the box
         * at all (a spot turned away: nothing to propagate) */
        s->groups = positional_groups(st, s);
        if (s->groups && st->p.grouping == LV_GROUP_CENTER) center_groups(st, s);
    }
    return s->groups != 0;
}

void volux_lightvol_env_source(const lightvol_state *st, int k, volux_vec3 power, lv_source *s) {
    memset(s, 0, sizeof *s);
    s->kind = LV_DIRECTIONAL;
    s->power = power;
    s->dir = v3_scale(volux_fibonacci_dir(k, st->p.env_dirs), -1.0f); /* travels away from where it comes from */
    s->groups = lv_face_weights(s->dir, s->weight);
}

void volux_lightvol_env_irradiance(const lightvol_state *st, volux_env_cells_cache *cells, const volux_scene *scene,
                                   volux_vec3 *E) {
    const int K = st->p.env_dirs;
    for (int k = 0; k < K; k++) E[k] = v3(0, 0, 0);
    for (int slot = 0; slot < volux_scene_light_slots(scene); slot++) {
        const volux_light_desc *d = volux_scene_light(scene, slot);
        if (d && d->enabled && d->type == VOLUX_LIGHT_ENVIRONMENT) volux_environment_cells_cached(cells, d, K, E);
    }
}
