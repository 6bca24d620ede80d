/*
 * tools/cli/bench_edits.c — the edits `volux bench --edit KIND` times.
 *
 * Each edit alternates between two states (k even / odd) so that every
 * repetition is a real change the technique must react to.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bench_edits.h"

static volux_status edit_transfer(volux_scene *s, int k, int what) {
    const volux_transfer_desc *cur = volux_scene_transfer(s);
    volux_transfer_desc d = *cur;
    volux_context *ctx = volux_scene_context(s);
    volux_tf_scalar_point op[VOLUX_TF_MAX_POINTS];
    volux_tf_color_point col[VOLUX_TF_MAX_POINTS];
    memcpy(op, cur->opacity, sizeof *op * (size_t)cur->n_opacity);
    if (cur->n_color) memcpy(col, cur->color, sizeof *col * (size_t)cur->n_color);
    d.opacity = op;
    d.color = cur->n_color ? col : NULL;
    float f = (k & 1) ? 0.8f : 1.25f; /* the pair multiplies back to 1 */
    switch (what) {
    case 0: /* tf: the opacity/extinction curve */
        for (int i = 0; i < d.n_opacity; i++) {
            float v = op[i].v * f;
            op[i].v = d.extinction ? v : fminf(v, 1.0f);
        }
        break;
    case 1: /* tf_color: swap red and blue of every colour point */
        for (int i = 0; i < d.n_color; i++) {
            float r = col[i].r;
            col[i].r = col[i].b;
            col[i].b = r;
        }
        if (!d.n_color) d.albedo = (k & 1) ? d.albedo * 0.9f : d.albedo / 0.9f > 1 ? 1 : d.albedo / 0.9f;
        break;
    case 2: d.density_scale *= f; break;
    case 3: d.anisotropy = (k & 1) ? d.anisotropy - 0.2f : d.anisotropy + 0.2f; break;
    }
    (void)ctx;
    return volux_scene_set_transfer(s, &d);
}

static volux_status edit_tf(volux_scene *s, int k) { return edit_transfer(s, k, 0); }
static volux_status edit_tf_color(volux_scene *s, int k) { return edit_transfer(s, k, 1); }
static volux_status edit_density(volux_scene *s, int k) { return edit_transfer(s, k, 2); }
static volux_status edit_phase(volux_scene *s, int k) {
    const volux_transfer_desc *d = volux_scene_transfer(s);
    if (d->anisotropy > 0.75f && !(k & 1)) k = 1; /* keep g inside (−1, 1) */
    return edit_transfer(s, k, 3);
}

static int first_light(const volux_scene *s) {
    for (int i = 0; i < volux_scene_light_slots(s); i++)
        if (volux_scene_light(s, i)) return i;
    return -1;
}

static int last_light(const volux_scene *s) {
    for (int i = volux_scene_light_slots(s) - 1; i >= 0; i--)
        if (volux_scene_light(s, i)) return i;
    return -1;
}

/* Rotates a light about +Y by ±10° (direction and position). */
static volux_status rotate_light(volux_scene *s, int k, int slot) {
    if (slot < 0) return VOLUX_ERR_INVALID;
    volux_light_desc d = *volux_scene_light(s, slot);
    float a = ((k & 1) ? -10.0f : 10.0f) * 3.14159265f / 180.0f, c = cosf(a), sn = sinf(a);
    volux_vec3 v = d.direction, p = d.position;
    d.direction = (volux_vec3){c * v.x + sn * v.z, v.y, -sn * v.x + c * v.z};
    d.position = (volux_vec3){c * p.x + sn * p.z, p.y, -sn * p.x + c * p.z};
    d.rotation_y_deg += (k & 1) ? -10.0f : 10.0f;
    return volux_scene_set_light(s, slot, &d);
}

static volux_status edit_light(volux_scene *s, int k) { return rotate_light(s, k, first_light(s)); }
/* the last light: with one light the same as `light`; lets a scene time a
 * second light type (e.g. a point light after a directional one) */
static volux_status edit_light_last(volux_scene *s, int k) { return rotate_light(s, k, last_light(s)); }

static volux_status edit_light_toggle(volux_scene *s, int k) {
    int slot = first_light(s);
    if (slot < 0) return VOLUX_ERR_INVALID;
    (void)k;
    return volux_scene_set_light_enabled(s, slot, !volux_scene_light(s, slot)->enabled);
}

static volux_status edit_camera(volux_scene *s, int k) {
    volux_camera_desc d = *volux_scene_camera_desc(s);
    if (d.use_orbit) d.azimuth_deg += (k & 1) ? -5.0f : 5.0f;
    else d.eye.x += (k & 1) ? -0.01f : 0.01f;
    return volux_scene_set_camera(s, &d);
}

static volux_status edit_volume(volux_scene *s, int k) {
    (void)k;
    return volux_scene_set_volume(s, volux_scene_volume(s)); /* a new time step: same data, full rebuild */
}

/* lightvol: an entire light update (every light re-propagated) in the
 * given propagation mode, forced through the technique's `rebuild_token`
 * parameter; other techniques do not support it. Sets the mode for the
 * edits that follow. */
static volux_status edit_full(volux_scene *s, int k, const char *mode) {
    if (strcmp(volux_scene_render(s)->technique, "lightvol") != 0) return VOLUX_ERR_UNSUPPORTED;
    volux_status st = volux_scene_set_param(s, "lightvol", "propagation", 0, mode);
    if (st) return st;
    double token = volux_scene_param(s, "lightvol", "rebuild_token", 0.0);
    (void)k;
    return volux_scene_set_param(s, "lightvol", "rebuild_token", token + 1.0, NULL);
}
static volux_status edit_full_coherent(volux_scene *s, int k) { return edit_full(s, k, "coherent"); }
static volux_status edit_full_sequential(volux_scene *s, int k) { return edit_full(s, k, "sequential"); }

static const bench_edit edits[] = {
    {"tf", "scale the opacity/extinction curve", edit_tf},
    {"tf_color", "change colours only", edit_tf_color},
    {"density", "scale density_scale", edit_density},
    {"phase", "change the HG anisotropy", edit_phase},
    {"light", "rotate the first light by 10 degrees", edit_light},
    {"light_last", "rotate the last light by 10 degrees", edit_light_last},
    {"light_toggle", "switch the first light off/on", edit_light_toggle},
    {"camera", "orbit the camera by 5 degrees", edit_camera},
    {"time_step", "replace the volume (same data)", edit_volume},
    {"full_sequential", "lightvol: entire light update, one light per propagation pass", edit_full_sequential},
    {"full_coherent", "lightvol: entire light update, lights grouped by propagation direction", edit_full_coherent},
};

const bench_edit *bench_edit_find(const char *name) {
    for (size_t i = 0; i < sizeof edits / sizeof edits[0]; i++)
        if (!strcmp(edits[i].name, name)) return &edits[i];
    return NULL;
}

const bench_edit *bench_edit_at(int i) {
    return i >= 0 && (size_t)i < sizeof edits / sizeof edits[0] ? &edits[i] : NULL;
}
