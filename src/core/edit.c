/* core/edit.c — see volux/edit.h. */
#include <math.h>
#include <string.h>

#include "context_internal.h"
#include "volume_internal.h"
#include "volux/edit.h"

/* ------------------------------------------------------------------ transfer function */

enum { TF_OPACITY, TF_COLOR, TF_DENSITY, TF_PHASE, TF_ALBEDO };

static volux_status edit_transfer(volux_scene *s, int k, int what) {
    const volux_transfer_desc *cur = volux_scene_transfer(s);
    volux_transfer_desc d = *cur;
    /* On the heap: a TF may have VOLUX_TF_MAX_POINTS (65 536) points. */
    volux_context *ctx = volux_scene_context(s);
    size_t op_bytes = sizeof(volux_tf_scalar_point) * (size_t)cur->n_opacity;
    size_t col_bytes = sizeof(volux_tf_color_point) * (size_t)cur->n_color;
    volux_tf_scalar_point *op = volux_malloc(ctx, op_bytes);
    volux_tf_color_point *col = cur->n_color ? volux_malloc(ctx, col_bytes) : NULL;
    if (!op || (cur->n_color && !col)) {
        volux_free(ctx, op, op_bytes);
        volux_free(ctx, col, col_bytes);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a transfer function edit");
    }
    memcpy(op, cur->opacity, op_bytes);
    if (cur->n_color) memcpy(col, cur->color, col_bytes);
    d.opacity = op;
    d.color = cur->n_color ? col : NULL;
    float f = (k & 1) ? 0.8f : 1.25f; /* the pair multiplies back to 1 */
    switch (what) {
    case TF_OPACITY:
        for (int i = 0; i < d.n_opacity; i++) {
            float v = op[i].v * f;
            op[i].v = d.extinction ? v : fminf(v, 1.0f);
        }
        break;
    case TF_COLOR: /* swap red and blue of every colour point (white TF: tint it, and back) */
        for (int i = 0; i < d.n_color; i++) {
            float r = col[i].r;
            col[i].r = col[i].b;
            col[i].b = r;
        }
        if (!cur->n_color) {
            col[0] = (volux_tf_color_point){0.0f, 1.0f, 0.85f, 0.7f};
            d.color = col;
            d.n_color = 1;
        } else if (cur->n_color == 1 && col[0].r == 0.7f && col[0].g == 0.85f && col[0].b == 1.0f) {
            d.color = NULL; /* the tint of a white TF swapped back: white again */
            d.n_color = 0;
        }
        break;
    case TF_ALBEDO: /* 0.9 ↔ 0.6 (an albedo near 0 scales up, so the pair still alternates) */
        d.albedo = d.albedo >= 0.75f ? d.albedo - 0.3f : d.albedo + 0.3f;
        break;
    case TF_DENSITY: d.density_scale *= f; break;
    case TF_PHASE:
        /* keep g inside (−1, 1): step down from the top of the range */
        if (d.anisotropy > 0.75f && !(k & 1)) k = 1;
        d.anisotropy = (k & 1) ? d.anisotropy - 0.2f : d.anisotropy + 0.2f;
        break;
    }
    volux_status st = volux_scene_set_transfer(s, &d);
    volux_free(ctx, op, op_bytes);
    volux_free(ctx, col, col_bytes);
    return st;
}

static volux_status edit_tf(volux_scene *s, int k) { return edit_transfer(s, k, TF_OPACITY); }
static volux_status edit_tf_color(volux_scene *s, int k) { return edit_transfer(s, k, TF_COLOR); }
static volux_status edit_density(volux_scene *s, int k) { return edit_transfer(s, k, TF_DENSITY); }
static volux_status edit_phase(volux_scene *s, int k) { return edit_transfer(s, k, TF_PHASE); }
static volux_status edit_albedo(volux_scene *s, int k) { return edit_transfer(s, k, TF_ALBEDO); }

/* ------------------------------------------------------------------ lights */

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

/* Rotates a light about +Y by ±10° (direction, position and an
 * environment's rotation). */
static volux_status rotate_light(volux_scene *s, int k, int slot) {
    if (slot < 0) return VOLUX_ERR_UNSUPPORTED;
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

/* Scales the first light's strength (irradiance, intensity or radiance,
 * whichever its type uses) by 1.25, undone by odd calls. */
static volux_status edit_light_intensity(volux_scene *s, int k) {
    int slot = first_light(s);
    if (slot < 0) return VOLUX_ERR_UNSUPPORTED;
    volux_light_desc d = *volux_scene_light(s, slot);
    float f = (k & 1) ? 0.8f : 1.25f;
    d.irradiance *= f;
    d.intensity *= f;
    d.radiance *= f;
    return volux_scene_set_light(s, slot, &d);
}

static volux_status edit_light_toggle(volux_scene *s, int k) {
    (void)k;
    int slot = first_light(s);
    if (slot < 0) return VOLUX_ERR_UNSUPPORTED;
    return volux_scene_set_light_enabled(s, slot, !volux_scene_light(s, slot)->enabled);
}

/* Adds a white point light above the volume in the first free slot after
 * the last light (even k), removes it again (odd k). */
static volux_status edit_light_add(volux_scene *s, int k) {
    int slot = last_light(s);
    if (k & 1) return slot >= 0 ? volux_scene_remove_light(s, slot) : VOLUX_ERR_UNSUPPORTED;
    if (slot + 1 >= VOLUX_MAX_LIGHTS) return VOLUX_ERR_UNSUPPORTED; /* the last slot is taken */
    volux_vec3 c;
    float r;
    volux_scene_bounds_sphere(s, &c, &r);
    volux_light_desc d;
    volux_light_desc_defaults(&d, VOLUX_LIGHT_POINT);
    d.position = (volux_vec3){c.x + 0.8f * r, c.y + 1.5f * r, c.z + 0.5f * r};
    d.intensity = 2.0f * r * r; /* irradiance ≈ 1 at the volume */
    return volux_scene_set_light(s, slot + 1, &d);
}

/* Scales the first light's colour by (1, 0.8, 0.6) (even k) and back (odd
 * k): a colour-and-intensity change with the same position/direction. */
static volux_status edit_light_color(volux_scene *s, int k) {
    int slot = first_light(s);
    if (slot < 0) return VOLUX_ERR_UNSUPPORTED;
    volux_light_desc d = *volux_scene_light(s, slot);
    const float f[3] = {1.0f, 0.8f, 0.6f};
    d.color.y = (k & 1) ? d.color.y / f[1] : d.color.y * f[1];
    d.color.z = (k & 1) ? d.color.z / f[2] : d.color.z * f[2];
    return volux_scene_set_light(s, slot, &d);
}

/* Turns the first environment light by ±10° about +Y (rotation_y). */
static volux_status edit_light_rotate_env(volux_scene *s, int k) {
    for (int i = 0; i < volux_scene_light_slots(s); i++) {
        const volux_light_desc *l = volux_scene_light(s, i);
        if (!l || l->type != VOLUX_LIGHT_ENVIRONMENT) continue;
        volux_light_desc d = *l;
        d.rotation_y_deg += (k & 1) ? -10.0f : 10.0f;
        return volux_scene_set_light(s, i, &d);
    }
    return VOLUX_ERR_UNSUPPORTED;
}

/* ------------------------------------------------------------------ material channel */

/* Appends a Blinn–Phong material over the upper half of the volume's value
 * range to the TF's material channel (even k), removes the last material
 * again (odd k). */
static volux_status edit_material(volux_scene *s, int k) {
    const volux_transfer_desc *cur = volux_scene_transfer(s);
    const volux_volume *v = volux_scene_volume(s);
    if (!v) return VOLUX_ERR_UNSUPPORTED;
    volux_tf_material mats[VOLUX_TF_MAX_MATERIALS];
    int n = cur->n_materials;
    if (n) memcpy(mats, cur->materials, sizeof *mats * (size_t)n);
    if (k & 1) {
        if (n == 0) return VOLUX_ERR_UNSUPPORTED;
        n--;
    } else {
        if (n == VOLUX_TF_MAX_MATERIALS) return VOLUX_ERR_UNSUPPORTED;
        double lo, hi;
        volux_volume_range(v, &lo, &hi);
        volux_tf_material_defaults(&mats[n], VOLUX_MATERIAL_BLINN_PHONG);
        mats[n].s0 = (float)(0.5 * (lo + hi));
        mats[n].s1 = (float)hi;
        n++;
    }
    volux_transfer_desc d = *cur;
    d.materials = n ? mats : NULL;
    d.n_materials = n;
    return volux_scene_set_transfer(s, &d);
}

/* ------------------------------------------------------------------ camera, render, volume */

static volux_status edit_camera(volux_scene *s, int k) {
    volux_camera_desc d = *volux_scene_camera_desc(s);
    if (d.use_orbit) d.azimuth_deg += (k & 1) ? -5.0f : 5.0f;
    else d.eye.x += (k & 1) ? -0.01f : 0.01f;
    return volux_scene_set_camera(s, &d);
}

static volux_status edit_background(volux_scene *s, int k) {
    volux_vec3 b = volux_scene_background(s);
    float add = (k & 1) ? -0.1f : 0.1f;
    volux_scene_set_background(s, (volux_vec3){b.x + add, b.y, b.z + 0.5f * add});
    return VOLUX_OK;
}

static volux_status edit_step(volux_scene *s, int k) {
    volux_render_settings r = *volux_scene_render(s);
    r.step *= (k & 1) ? 0.8f : 1.25f;
    return volux_scene_set_render(s, &r);
}

/* The volume mirrored along x, as a new volume (a new time step: same
 * size, type and box, different data). */
static volux_status mirrored(const volux_volume *v, volux_volume **out) {
    volux_volume *m;
    volux_status st = volux_volume_create_storage(v->ctx, v->dims, v->spacing, v->type, &m);
    if (st) return st;
    size_t elem = v->storage == VOLUX_STORE_U8 ? 1 : v->storage == VOLUX_STORE_U16 ? 2 : 4;
    const unsigned char *src = v->data;
    unsigned char *dst = m->data;
    size_t nx = (size_t)v->dims[0], rows = (size_t)v->dims[1] * (size_t)v->dims[2];
    for (size_t r = 0; r < rows; r++)
        for (size_t i = 0; i < nx; i++) memcpy(dst + (r * nx + i) * elem, src + (r * nx + nx - 1 - i) * elem, elem);
    double origin[3] = {v->origin.x, v->origin.y, v->origin.z};
    if ((st = volux_volume_finalize(m, origin))) {
        volux_volume_release(m);
        return st;
    }
    *out = m;
    return VOLUX_OK;
}

/* The next time step of a sequence (wrapping: the k-th call plays the
 * sequence forward, as an animation does); a single volume is replaced by
 * its mirror image, a new volume of the same shape. */
static volux_status edit_time_step(volux_scene *s, int k) {
    (void)k;
    int n = volux_scene_time_steps(s);
    if (n > 1) return volux_scene_set_time_step(s, (volux_scene_time_step(s) + 1) % n);
    const volux_volume *v = volux_scene_volume(s);
    if (!v) return VOLUX_ERR_UNSUPPORTED;
    volux_volume *next;
    volux_status st = mirrored(v, &next);
    if (st) return st;
    st = volux_scene_set_volume(s, next); /* retains */
    volux_volume_release(next);
    return st;
}

/* A clipping plane through the volume's centre that removes the +x side
 * (tilted, so no axis-aligned shortcut hides a bug), appended to the
 * scene's clip; the next call removes it again. */
static volux_status edit_clip(volux_scene *s, int k) {
    const volux_volume *v = volux_scene_volume(s);
    if (!v) return VOLUX_ERR_UNSUPPORTED;
    volux_clip_desc d = *volux_scene_clip(s);
    if (k & 1) {
        if (d.n_planes == 0) return VOLUX_ERR_UNSUPPORTED;
        d.n_planes--;
    } else {
        if (d.n_planes == VOLUX_CLIP_MAX_PLANES) return VOLUX_ERR_UNSUPPORTED;
        volux_vec3 lo, hi;
        volux_volume_bounds(v, &lo, &hi);
        d.planes[d.n_planes++] = (volux_clip_plane){{0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y), 0.5 * (lo.z + hi.z)},
                                                    {1.0, 0.3, 0.2}};
    }
    return volux_scene_set_clip(s, &d);
}

/* lightvol: an entire light update (every light re-propagated) in the
 * given propagation mode, forced through the technique's `rebuild_token`
 * parameter. Sets the mode for the edits that follow. */
static volux_status edit_full(volux_scene *s, int coherent) {
    volux_status st = volux_scene_set_param(s, "lightvol", "propagation", 0, coherent ? "coherent" : "sequential");
    if (st) return st;
    double token = volux_scene_param(s, "lightvol", "rebuild_token", 0.0);
    return volux_scene_set_param(s, "lightvol", "rebuild_token", token + 1.0, NULL);
}
static volux_status edit_full_coherent(volux_scene *s, int k) { return (void)k, edit_full(s, 1); }
static volux_status edit_full_sequential(volux_scene *s, int k) { return (void)k, edit_full(s, 0); }

/* ------------------------------------------------------------------ the list */

static const volux_edit edits[] = {
    {"tf", "scale the opacity/extinction curve", VOLUX_CHANGE_EXTINCTION, NULL, 1, edit_tf},
    {"tf_color", "swap red and blue of the colour curve", VOLUX_CHANGE_COLOR, NULL, 1, edit_tf_color},
    {"density", "scale density_scale", VOLUX_CHANGE_DENSITY, NULL, 1, edit_density},
    {"phase", "change the HG anisotropy by 0.2", VOLUX_CHANGE_PHASE, NULL, 1, edit_phase},
    {"albedo", "change the scattering albedo by 0.3 (0.9 <-> 0.6)", VOLUX_CHANGE_ALBEDO, NULL, 1, edit_albedo},
    {"light", "rotate the first light by 10 degrees about +Y", VOLUX_CHANGE_LIGHTS, NULL, 1, edit_light},
    {"light_last", "rotate the last light by 10 degrees about +Y", VOLUX_CHANGE_LIGHTS, NULL, 1, edit_light_last},
    {"light_intensity", "scale the first light's irradiance/intensity/radiance by 1.25", VOLUX_CHANGE_LIGHTS, NULL,
     1, edit_light_intensity},
    {"light_toggle", "switch the first light off/on", VOLUX_CHANGE_LIGHTS, NULL, 1, edit_light_toggle},
    {"light_add", "add a point light after the last one / remove it", VOLUX_CHANGE_LIGHTS, NULL, 1, edit_light_add},
    {"light_color", "scale the first light's green and blue by 0.8 and 0.6 (colour and intensity)",
     VOLUX_CHANGE_LIGHTS, NULL, 1, edit_light_color},
    /* invisible for a constant environment (the test matrix's): no claim */
    {"light_rotate_env", "turn the first environment light by 10 degrees about +Y", VOLUX_CHANGE_LIGHTS, NULL, 0,
     edit_light_rotate_env},
    /* only `sh` reads the material channel: no claim for the others */
    {"material", "add a Blinn-Phong material over the upper half of the values / remove it", VOLUX_CHANGE_COLOR,
     NULL, 0, edit_material},
    {"camera", "orbit the camera by 5 degrees", VOLUX_CHANGE_CAMERA, NULL, 1, edit_camera},
    {"background", "change the background colour", VOLUX_CHANGE_RENDER, NULL, 1, edit_background},
    {"step", "scale the ray-march step (render.step)", VOLUX_CHANGE_RENDER, NULL, 0, edit_step},
    {"time_step", "the next step of a sequence (a single volume: replaced by its mirror image)", VOLUX_CHANGE_VOLUME, NULL, 1, edit_time_step},
    {"clip", "add a clipping plane through the volume's centre / remove it", VOLUX_CHANGE_VOLUME, NULL, 1, edit_clip},
    {"full_sequential", "entire light update, one light per propagation pass", VOLUX_CHANGE_PARAMS, "lightvol",
     0, edit_full_sequential},
    {"full_coherent", "entire light update, lights grouped by propagation direction", VOLUX_CHANGE_PARAMS,
     "lightvol", 0, edit_full_coherent},
};

int volux_edit_count(void) { return (int)(sizeof edits / sizeof edits[0]); }

const volux_edit *volux_edit_at(int index) { return index >= 0 && index < volux_edit_count() ? &edits[index] : NULL; }

const volux_edit *volux_edit_find(const char *name) {
    for (int i = 0; i < volux_edit_count(); i++)
        if (!strcmp(edits[i].name, name)) return &edits[i];
    return NULL;
}

volux_status volux_edit_apply(const volux_edit *e, volux_scene *s, int k) {
    volux_context *ctx = volux_scene_context(s);
    if (e->technique && strcmp(volux_scene_render(s)->technique, e->technique) != 0)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "edit %s: only for technique %s", e->name, e->technique);
    volux_status st = e->apply(s, k);
    if (st == VOLUX_ERR_UNSUPPORTED)
        return volux_error(ctx, st, "edit %s: the scene has nothing it can edit (no light?)", e->name);
    if (st) volux_error_prefix(ctx, "edit %s: ", e->name);
    return st;
}
