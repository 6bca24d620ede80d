/* core/scene.c — the scene and its per-aspect versions (STYLE §5). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "clip_internal.h"
#include "context_internal.h"
#include "scene_internal.h"
#include "vecmath.h"
#include "volume_internal.h"
#include "volux/scene.h"
#include "volux/sequence.h"

enum { A_VOLUME, A_EXTINCTION, A_COLOR, A_DENSITY, A_PHASE, A_LIGHTS, A_CAMERA, A_PARAMS, A_RENDER, A_ALBEDO, A_COUNT };

typedef struct light_slot {
    int present;
    uint64_t edit; /* light_edits at the slot's last change (set, enable, remove) */
    volux_light_desc desc;
    volux_image map; /* owned copy of desc.map */
} light_slot;

typedef struct param_entry {
    char technique[32];
    char name[48];
    double number;
    char *string; /* owned; NULL for numbers */
} param_entry;

struct volux_scene {
    volux_context *ctx;
    uint64_t id;
    volux_volume *volume;
    volux_sequence *seq; /* NULL: a single volume; else `volume` is step `time_step` */
    int time_step;
    volux_transfer_desc tf;
    volux_tf_color_point *color;
    volux_tf_scalar_point *opacity;
    volux_tf_material *materials;
    volux_transfer_lut lut; /* baked by the setters of the volume and the TF */
    volux_clip_desc clip;
    /* The volume techniques render: `volume` with the clipped voxels set to
     * clip_fill (core/clip.c); NULL when nothing is clipped. Rebuilt by the
     * setters of the volume, the clip and the TF (when the fill changes). */
    volux_volume *clipped;
    float clip_fill;
    volux_camera_desc camera;
    light_slot *lights;    /* [light_cap]                                 */
    int light_cap;         /* slots allocated (grown geometrically)       */
    int light_slots;       /* one past the highest occupied slot          */
    uint64_t light_edits;  /* counts light changes; starts at 1 (0 = all) */
    volux_vec3 background;
    volux_render_settings render;
    param_entry params[VOLUX_MAX_PARAMS];
    int n_params;
    uint32_t aspect[A_COUNT];
    char notes[1024];
};

static uint64_t next_scene_id = 1;

void volux_render_settings_defaults(volux_render_settings *r) {
    memset(r, 0, sizeof *r);
    r->width = 512;
    r->height = 512;
    r->spp = 1;
    r->step = 0.5f;
    r->seed = 1;
    r->max_depth = 64;
    strcpy(r->technique, "ea");
}

static void bump(volux_scene *s, int aspect) { s->aspect[aspect]++; }

volux_status volux_scene_create(volux_context *ctx, volux_scene **out) {
    volux_scene *s = volux_calloc(ctx, 1, sizeof *s);
    if (!s) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a scene");
    s->ctx = ctx;
    s->id = __atomic_fetch_add(&next_scene_id, 1, __ATOMIC_RELAXED);
    static const volux_tf_scalar_point ramp[2] = {{0.0f, 0.0f}, {1.0f, 1.0f}};
    volux_transfer_desc_defaults(&s->tf);
    s->tf.opacity = ramp;
    s->tf.n_opacity = 2;
    volux_status st = volux_scene_set_transfer(s, &s->tf);
    if (st) {
        volux_free(ctx, s, sizeof *s);
        return st;
    }
    volux_camera_desc_defaults(&s->camera);
    volux_render_settings_defaults(&s->render);
    for (int a = 0; a < A_COUNT; a++) s->aspect[a] = 1;
    s->light_edits = 1;
    *out = s;
    return VOLUX_OK;
}

static void free_tf_arrays(volux_scene *s) {
    volux_free(s->ctx, s->color, sizeof *s->color * (size_t)s->tf.n_color);
    volux_free(s->ctx, s->opacity, sizeof *s->opacity * (size_t)s->tf.n_opacity);
    volux_free(s->ctx, s->materials, sizeof *s->materials * (size_t)s->tf.n_materials);
    s->color = NULL;
    s->opacity = NULL;
    s->materials = NULL;
}

void volux_scene_destroy(volux_scene *s) {
    if (!s) return;
    volux_context *ctx = s->ctx;
    volux_volume_release(s->volume);
    volux_volume_release(s->clipped);
    volux_sequence_destroy(s->seq);
    free_tf_arrays(s);
    volux_transfer_lut_free(ctx, &s->lut);
    for (int i = 0; i < s->light_cap; i++) volux_image_free(ctx, &s->lights[i].map);
    volux_free(ctx, s->lights, sizeof *s->lights * (size_t)s->light_cap);
    for (int i = 0; i < s->n_params; i++) volux_strfree(ctx, s->params[i].string);
    volux_free(ctx, s, sizeof *s);
}

volux_context *volux_scene_context(const volux_scene *s) { return s->ctx; }

static float smallest_spacing(const volux_volume *v) {
    double sp[3];
    volux_volume_spacing(v, sp);
    return (float)fmin(sp[0], fmin(sp[1], sp[2]));
}

/* Bakes the LUT of (v, tf) into *out: the tables every technique reads,
 * over the volume's value range. Setters bake before they commit, so the
 * scene never holds a stale LUT and readers never mutate the scene. */
static volux_status bake(volux_scene *s, const volux_volume *v, const volux_transfer_desc *tf,
                         volux_transfer_lut *out) {
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    return volux_transfer_bake(s->ctx, tf, lo, hi, 0, smallest_spacing(v), out);
}

static void replace_lut(volux_scene *s, volux_transfer_lut *lut) {
    volux_transfer_lut_free(s->ctx, &s->lut);
    s->lut = *lut;
}

/* The clipped copy of v under (lut, clip) in *out (NULL: nothing clipped)
 * and its fill value. */
static volux_status derive_clipped(volux_scene *s, const volux_volume *v, const volux_transfer_lut *lut,
                                   const volux_clip_desc *clip, volux_volume **out, float *fill) {
    *out = NULL;
    *fill = 0.0f;
    if (!v || !volux_clip_active(clip)) return VOLUX_OK;
    volux_status st = volux_clip_fill_value(s->ctx, v, lut, fill);
    return st ? st : volux_clip_volume(v, clip, *fill, out);
}

static void replace_clipped(volux_scene *s, volux_volume *clipped, float fill) {
    volux_volume_release(s->clipped);
    s->clipped = clipped;
    s->clip_fill = fill;
}

/* Makes v (retained) the volume after baking its LUT (and clipping it);
 * bumps VOLUME. */
static volux_status replace_volume(volux_scene *s, volux_volume *v) {
    volux_transfer_lut lut;
    volux_volume *clipped;
    float fill;
    volux_status st = bake(s, v, &s->tf, &lut);
    if (st) return st;
    if ((st = derive_clipped(s, v, &lut, &s->clip, &clipped, &fill))) {
        volux_transfer_lut_free(s->ctx, &lut);
        return st;
    }
    replace_lut(s, &lut);
    replace_clipped(s, clipped, fill);
    volux_volume_retain(v);
    volux_volume_release(s->volume);
    s->volume = v;
    bump(s, A_VOLUME);
    return VOLUX_OK;
}

volux_volume *volux_scene_render_volume(const volux_scene *s) { return s->clipped ? s->clipped : s->volume; }

volux_status volux_scene_set_clip(volux_scene *s, const volux_clip_desc *d) {
    volux_clip_desc c;
    memset(&c, 0, sizeof c);
    if (d) {
        volux_status st = volux_clip_desc_validate(s->ctx, d);
        if (st) return st;
        c.has_box = d->has_box;
        if (c.has_box) {
            memcpy(c.box_min, d->box_min, sizeof c.box_min);
            memcpy(c.box_max, d->box_max, sizeof c.box_max);
        }
        c.n_planes = d->n_planes;
        memcpy(c.planes, d->planes, sizeof c.planes[0] * (size_t)c.n_planes);
    }
    if (volux_clip_equal(&c, &s->clip)) return VOLUX_OK;
    volux_volume *clipped;
    float fill;
    volux_status st = derive_clipped(s, s->volume, &s->lut, &c, &clipped, &fill);
    if (st) return st;
    s->clip = c;
    if (s->volume) {
        replace_clipped(s, clipped, fill);
        bump(s, A_VOLUME);
    }
    return VOLUX_OK;
}

const volux_clip_desc *volux_scene_clip(const volux_scene *s) { return &s->clip; }

volux_status volux_scene_set_volume(volux_scene *s, volux_volume *v) {
    if (!v) return volux_error(s->ctx, VOLUX_ERR_INVALID, "scene: volume is NULL");
    volux_status st = replace_volume(s, v);
    if (st) return st;
    volux_sequence_destroy(s->seq);
    s->seq = NULL;
    s->time_step = 0;
    return VOLUX_OK;
}

volux_volume *volux_scene_volume(const volux_scene *s) { return s->volume; }

volux_status volux_scene_set_sequence(volux_scene *s, volux_sequence *q, int step) {
    if (!q) return volux_error(s->ctx, VOLUX_ERR_INVALID, "scene: sequence is NULL");
    if (q == s->seq) return volux_scene_set_time_step(s, step);
    volux_volume *v;
    volux_status st = volux_sequence_acquire(q, step, &v);
    if (st) return st;
    st = replace_volume(s, v);
    volux_volume_release(v);
    if (st) return st;
    volux_sequence_destroy(s->seq);
    s->seq = q;
    s->time_step = step;
    return VOLUX_OK;
}

volux_status volux_scene_check_time_step(const volux_scene *s, int step) {
    int n = volux_scene_time_steps(s);
    if (step < 0 || step >= n)
        return volux_error(s->ctx, VOLUX_ERR_INVALID, "time step %d is outside [0, %d) (the volume has %d time step%s)",
                           step, n, n, n == 1 ? "" : "s");
    return VOLUX_OK;
}

volux_sequence *volux_scene_take_sequence(volux_scene *s) {
    volux_sequence *q = s->seq;
    s->seq = NULL;
    s->time_step = 0;
    return q;
}

volux_status volux_scene_set_time_step(volux_scene *s, int step) {
    volux_status st = volux_scene_check_time_step(s, step);
    if (st) return st;
    if (step == s->time_step) return VOLUX_OK;
    volux_volume *v;
    if ((st = volux_sequence_acquire(s->seq, step, &v))) return st;
    st = replace_volume(s, v);
    volux_volume_release(v);
    if (st) return st;
    s->time_step = step;
    return VOLUX_OK;
}

int volux_scene_time_step(const volux_scene *s) { return s->time_step; }
int volux_scene_time_steps(const volux_scene *s) { return s->seq ? volux_sequence_steps(s->seq) : 1; }
volux_sequence *volux_scene_sequence(const volux_scene *s) { return s->seq; }

static int same_scalar_points(const volux_tf_scalar_point *a, int na, const volux_tf_scalar_point *b, int nb) {
    return na == nb && (na == 0 || memcmp(a, b, sizeof *a * (size_t)na) == 0);
}
static int same_materials(const volux_tf_material *a, int na, const volux_tf_material *b, int nb) {
    if (na != nb) return 0;
    for (int i = 0; i < na; i++)
        if (!volux_tf_material_equal(&a[i], &b[i])) return 0;
    return 1;
}
static int same_color_points(const volux_tf_color_point *a, int na, const volux_tf_color_point *b, int nb) {
    return na == nb && (na == 0 || memcmp(a, b, sizeof *a * (size_t)na) == 0);
}

volux_status volux_scene_set_transfer(volux_scene *s, const volux_transfer_desc *d) {
    volux_status st = volux_transfer_desc_validate(s->ctx, d);
    if (st) return st;
    volux_tf_color_point *color = NULL;
    volux_tf_material *materials = NULL;
    volux_tf_scalar_point *opacity = volux_malloc(s->ctx, sizeof *opacity * (size_t)d->n_opacity);
    if (d->n_color > 0) color = volux_malloc(s->ctx, sizeof *color * (size_t)d->n_color);
    if (d->n_materials > 0) materials = volux_malloc(s->ctx, sizeof *materials * (size_t)d->n_materials);
    if (!opacity || (d->n_color > 0 && !color) || (d->n_materials > 0 && !materials)) {
        volux_free(s->ctx, opacity, sizeof *opacity * (size_t)d->n_opacity);
        volux_free(s->ctx, color, sizeof *color * (size_t)d->n_color);
        volux_free(s->ctx, materials, sizeof *materials * (size_t)d->n_materials);
        return volux_error(s->ctx, VOLUX_ERR_NOMEM, "out of memory for transfer function points");
    }
    memcpy(opacity, d->opacity, sizeof *opacity * (size_t)d->n_opacity);
    if (d->n_color > 0) memcpy(color, d->color, sizeof *color * (size_t)d->n_color);
    if (d->n_materials > 0) memcpy(materials, d->materials, sizeof *materials * (size_t)d->n_materials);

    /* Classify the edit before replacing anything (gage-style diff). */
    const volux_transfer_desc *o = &s->tf;
    int first = s->opacity == NULL;
    int extinction = first || !same_scalar_points(o->opacity, o->n_opacity, d->opacity, d->n_opacity) ||
                     o->extinction != d->extinction || o->opacity_unit_distance != d->opacity_unit_distance;
    int density = first || o->density_scale != d->density_scale;
    int colors = first || !same_color_points(o->color, o->n_color, d->color, d->n_color);
    int albedo = first || o->albedo != d->albedo;
    int appearance = colors || memcmp(&o->material, &d->material, sizeof o->material) != 0 ||
                     !same_materials(o->materials, o->n_materials, d->materials, d->n_materials);
    int phase = first || o->anisotropy != d->anisotropy;
    /* The LUT holds σt and the colour curve (not albedo, material or g). */
    if (s->volume && (extinction || density || colors)) {
        volux_transfer_lut lut;
        volux_volume *clipped = NULL;
        float fill = s->clip_fill;
        if ((st = bake(s, s->volume, d, &lut))) {
            volux_free(s->ctx, opacity, sizeof *opacity * (size_t)d->n_opacity);
            volux_free(s->ctx, color, sizeof *color * (size_t)d->n_color);
            volux_free(s->ctx, materials, sizeof *materials * (size_t)d->n_materials);
            return st;
        }
        /* The fill is a function of the TF: when it moves, the clipped copy
         * is rebuilt (VOLUME), so an edited scene equals a fresh one. */
        if (volux_clip_active(&s->clip) && (st = volux_clip_fill_value(s->ctx, s->volume, &lut, &fill)) == VOLUX_OK &&
            fill != s->clip_fill)
            st = volux_clip_volume(s->volume, &s->clip, fill, &clipped);
        if (st) {
            volux_transfer_lut_free(s->ctx, &lut);
            volux_free(s->ctx, opacity, sizeof *opacity * (size_t)d->n_opacity);
            volux_free(s->ctx, color, sizeof *color * (size_t)d->n_color);
            volux_free(s->ctx, materials, sizeof *materials * (size_t)d->n_materials);
            return st;
        }
        replace_lut(s, &lut);
        if (clipped) {
            replace_clipped(s, clipped, fill);
            bump(s, A_VOLUME);
        }
    }
    if (extinction) bump(s, A_EXTINCTION);
    if (density) bump(s, A_DENSITY);
    if (appearance) bump(s, A_COLOR);
    if (albedo) bump(s, A_ALBEDO);
    if (phase) bump(s, A_PHASE);

    free_tf_arrays(s);
    s->tf = *d;
    s->color = color;
    s->opacity = opacity;
    s->materials = materials;
    s->tf.color = color;
    s->tf.opacity = opacity;
    s->tf.materials = materials;
    return VOLUX_OK;
}

const volux_transfer_desc *volux_scene_transfer(const volux_scene *s) { return &s->tf; }

const volux_transfer_lut *volux_scene_transfer_lut(const volux_scene *s) { return s->volume ? &s->lut : NULL; }

volux_status volux_scene_set_camera(volux_scene *s, const volux_camera_desc *d) {
    volux_camera probe;
    volux_status st = volux_camera_resolve(s->ctx, d, v3(0, 0, 0), 1.0f, 4, 4, &probe);
    if (st) return st;
    s->camera = *d;
    bump(s, A_CAMERA);
    return VOLUX_OK;
}

const volux_camera_desc *volux_scene_camera_desc(const volux_scene *s) { return &s->camera; }

void volux_scene_bounds_sphere(const volux_scene *s, volux_vec3 *center, float *radius) {
    if (!s->volume) {
        *center = v3(0, 0, 0);
        *radius = 1.0f;
        return;
    }
    volux_vec3 lo, hi;
    /* a brick of a whole grid frames the whole (every rank the same view) */
    volux_volume_domain_bounds(s->volume, &lo, &hi);
    *center = v3_scale(v3_add(lo, hi), 0.5f);
    float r = 0.5f * v3_length(v3_sub(hi, lo));
    *radius = r > 0.0f ? r : 1.0f;
}

volux_status volux_scene_camera(const volux_scene *s, volux_camera *out) {
    volux_vec3 c;
    float r;
    volux_scene_bounds_sphere(s, &c, &r);
    return volux_camera_resolve(s->ctx, &s->camera, c, r, s->render.width, s->render.height, out);
}

static int valid_slot(const volux_scene *s, int slot) { return s && slot >= 0 && slot < s->light_cap; }

/* Makes slots [0, need) exist (new ones empty, never changed). Doubling
 * keeps n lights added in slot order at O(n) copies in all. */
static volux_status grow_lights(volux_scene *s, int need) {
    if (need <= s->light_cap) return VOLUX_OK;
    int cap = s->light_cap ? s->light_cap : 8;
    while (cap < need) cap = cap > VOLUX_MAX_LIGHTS / 2 ? VOLUX_MAX_LIGHTS : 2 * cap;
    size_t old = (size_t)s->light_cap, n = (size_t)cap;
    light_slot *l = volux_realloc(s->ctx, s->lights, sizeof *l * old, sizeof *l * n);
    if (!l) return volux_error(s->ctx, VOLUX_ERR_NOMEM, "out of memory for %d light slots", cap);
    s->lights = l;
    memset(l + old, 0, sizeof *l * (n - old));
    /* map pointers point into the slot itself: re-aim them after the move */
    for (size_t i = 0; i < old; i++)
        if (l[i].desc.map) l[i].desc.map = &l[i].map;
    s->light_cap = cap;
    return VOLUX_OK;
}

static void touch_light(volux_scene *s, int slot) {
    s->lights[slot].edit = ++s->light_edits;
    bump(s, A_LIGHTS);
    if (s->lights[slot].present) {
        if (slot >= s->light_slots) s->light_slots = slot + 1;
    } else if (slot == s->light_slots - 1) {
        /* the highest light left: walk down to the next occupied slot
         * (each empty slot is passed once per removal of the top) */
        int n = slot;
        while (n > 0 && !s->lights[n - 1].present) n--;
        s->light_slots = n;
    }
}

volux_status volux_scene_set_light(volux_scene *s, int slot, const volux_light_desc *d) {
    if (slot < 0)
        return volux_error(s->ctx, VOLUX_ERR_INVALID, "lights[%d]: slot outside [0, %d)", slot, VOLUX_MAX_LIGHTS);
    if (slot >= VOLUX_MAX_LIGHTS)
        return volux_error(s->ctx, VOLUX_ERR_LIMIT, "lights[%d]: at most %d light slots", slot, VOLUX_MAX_LIGHTS);
    char path[32];
    snprintf(path, sizeof path, "lights[%d]", slot);
    volux_status st = volux_light_desc_validate(s->ctx, d, path);
    if (st) return st;
    volux_image map = {0};
    if (d->type == VOLUX_LIGHT_ENVIRONMENT && d->map) {
        /* Texels: NaN/Inf are refused (they would reach every pixel that
         * sees the sky); values above VOLUX_ENV_TEXEL_MAX are clamped with
         * a warning, so sums over the map, its sampling table and
         * radiance × intensity × throughput stay finite (an RGBE exponent
         * of 255 gives 1.7e38). Negative values are kept (filters leave
         * tiny ones; lookups clamp at 0). */
        const volux_image *m = d->map;
        size_t n = 3 * (size_t)m->width * (size_t)m->height, bad = 0, first = 0, clamped = 0;
        for (size_t i = 0; i < n; i++)
            if (!isfinite(m->rgb[i]) && !bad++) first = i / 3;
        if (bad)
            return volux_error(s->ctx, VOLUX_ERR_INVALID,
                               "%s.file: %zu non-finite texel values (NaN/Inf), the first at texel (%zu, %zu)", path,
                               bad, first % (size_t)m->width, first / (size_t)m->width);
        st = volux_image_copy(s->ctx, m, &map);
        if (st) return st;
        for (size_t i = 0; i < n; i++)
            if (fabsf(map.rgb[i]) > VOLUX_ENV_TEXEL_MAX) {
                map.rgb[i] = map.rgb[i] > 0.0f ? VOLUX_ENV_TEXEL_MAX : -VOLUX_ENV_TEXEL_MAX;
                clamped++;
            }
        if (clamped)
            volux_warn(s->ctx, "%s.file: %zu texel values above %g clamped to it", path, clamped,
                       (double)VOLUX_ENV_TEXEL_MAX);
    }
    /* d may point into this scene's table, which growing moves */
    const volux_light_desc copy = *d;
    if ((st = grow_lights(s, slot + 1))) {
        volux_image_free(s->ctx, &map);
        return st;
    }
    light_slot *l = &s->lights[slot];
    volux_image_free(s->ctx, &l->map);
    l->present = 1;
    l->desc = copy;
    l->map = map;
    l->desc.map = map.rgb ? &l->map : NULL;
    touch_light(s, slot);
    return VOLUX_OK;
}

volux_status volux_scene_remove_light(volux_scene *s, int slot) {
    if (!valid_slot(s, slot) || !s->lights[slot].present)
        return volux_error(s->ctx, VOLUX_ERR_INVALID, "lights[%d]: no light in this slot", slot);
    light_slot *l = &s->lights[slot];
    volux_image_free(s->ctx, &l->map);
    memset(&l->desc, 0, sizeof l->desc);
    l->present = 0;
    touch_light(s, slot);
    return VOLUX_OK;
}

volux_status volux_scene_set_light_enabled(volux_scene *s, int slot, int enabled) {
    if (!valid_slot(s, slot) || !s->lights[slot].present)
        return volux_error(s->ctx, VOLUX_ERR_INVALID, "lights[%d]: no light in this slot", slot);
    if (s->lights[slot].desc.enabled == (enabled != 0)) return VOLUX_OK;
    s->lights[slot].desc.enabled = enabled != 0;
    touch_light(s, slot);
    return VOLUX_OK;
}

const volux_light_desc *volux_scene_light(const volux_scene *s, int slot) {
    if (slot < 0 || slot >= s->light_cap || !s->lights[slot].present) return NULL;
    return &s->lights[slot].desc;
}

int volux_scene_light_slots(const volux_scene *s) { return s->light_slots; }

const char *volux_scene_notes(const volux_scene *s) { return s->notes; }

void volux_scene_add_note(volux_scene *s, const char *note) {
    size_t n = strlen(s->notes);
    if (n + 2 >= sizeof s->notes) return;
    snprintf(s->notes + n, sizeof s->notes - n, "%s%s", n ? "\n" : "", note);
}

void volux_scene_set_background(volux_scene *s, volux_vec3 rgb) {
    if (memcmp(&rgb, &s->background, sizeof rgb) == 0) return;
    s->background = rgb;
    bump(s, A_RENDER);
}

volux_vec3 volux_scene_background(const volux_scene *s) { return s->background; }

volux_status volux_scene_set_render(volux_scene *s, const volux_render_settings *r) {
    volux_context *ctx = s->ctx;
    if (r->width < 1 || r->height < 1 || r->width > VOLUX_MAX_IMAGE_DIM || r->height > VOLUX_MAX_IMAGE_DIM)
        return volux_error(ctx, VOLUX_ERR_INVALID, "render.width/height: %dx%d is outside [1, %d]", r->width,
                           r->height, VOLUX_MAX_IMAGE_DIM);
    if (r->spp < 1 || r->spp > (1 << 24))
        return volux_error(ctx, VOLUX_ERR_INVALID, "render.spp: must be in [1, 2^24], got %d", r->spp);
    if (!(r->step > 0.0f) || !(r->step <= 64.0f))
        return volux_error(ctx, VOLUX_ERR_INVALID, "render.step: must be in (0, 64], got %g", r->step);
    if (r->max_depth < 0 || r->max_depth > 100000)
        return volux_error(ctx, VOLUX_ERR_INVALID, "render.max_depth: must be in [0, 100000] (0: no scattering), got %d", r->max_depth);
    if (!isfinite(r->exposure) || fabsf(r->exposure) > 64.0f)
        return volux_error(ctx, VOLUX_ERR_INVALID, "render.exposure: must be in [-64, 64], got %g", r->exposure);
    if (r->threads < 0 || r->threads > 1024)
        return volux_error(ctx, VOLUX_ERR_INVALID, "render.threads: must be in [0, 1024], got %d", r->threads);
    if (!(r->time_ms >= 0.0) || !(r->target_error >= 0.0))
        return volux_error(ctx, VOLUX_ERR_INVALID, "render.time_ms/target_error: must be >= 0");
    if (!memchr(r->technique, 0, sizeof r->technique))
        return volux_error(ctx, VOLUX_ERR_INVALID, "render.technique: name too long");
    /* Only what changes pixels bumps RENDER (threads and limits do not). */
    const volux_render_settings *o = &s->render;
    if (o->width != r->width || o->height != r->height || o->step != r->step || o->seed != r->seed ||
        o->max_depth != r->max_depth || strcmp(o->technique, r->technique) != 0)
        bump(s, A_RENDER);
    s->render = *r;
    return VOLUX_OK;
}

const volux_render_settings *volux_scene_render(const volux_scene *s) { return &s->render; }

static param_entry *find_param(const volux_scene *s, const char *technique, const char *name) {
    for (int i = 0; i < s->n_params; i++)
        if (!strcmp(s->params[i].technique, technique) && !strcmp(s->params[i].name, name))
            return (param_entry *)&s->params[i];
    return NULL;
}

volux_status volux_scene_set_param(volux_scene *s, const char *technique, const char *name, double number,
                                   const char *string) {
    volux_context *ctx = s->ctx;
    if (strlen(technique) >= sizeof s->params[0].technique || strlen(name) >= sizeof s->params[0].name)
        return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%.32s.%.48s: name too long", technique, name);
    if (!string && !isfinite(number))
        return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s.%s: must be finite", technique, name);
    param_entry *p = find_param(s, technique, name);
    if (!p) {
        if (s->n_params >= VOLUX_MAX_PARAMS)
            return volux_error(ctx, VOLUX_ERR_LIMIT, "techniques: more than %d parameters", VOLUX_MAX_PARAMS);
        p = &s->params[s->n_params];
        memset(p, 0, sizeof *p);
        strcpy(p->technique, technique);
        strcpy(p->name, name);
        s->n_params++;
    }
    char *copy = NULL;
    if (string && !(copy = volux_strdup(ctx, string)))
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a parameter");
    volux_strfree(ctx, p->string);
    p->string = copy;
    p->number = string ? 0.0 : number;
    bump(s, A_PARAMS);
    return VOLUX_OK;
}

volux_status volux_scene_remove_param(volux_scene *s, const char *technique, const char *name) {
    param_entry *p = find_param(s, technique, name);
    if (!p) return VOLUX_OK;
    volux_strfree(s->ctx, p->string);
    /* Keep the order of the others: volux_scene_param_at enumerates them. */
    size_t i = (size_t)(p - s->params);
    memmove(p, p + 1, sizeof *p * ((size_t)s->n_params - i - 1));
    s->n_params--;
    memset(&s->params[s->n_params], 0, sizeof s->params[0]);
    bump(s, A_PARAMS);
    return VOLUX_OK;
}

double volux_scene_param(const volux_scene *s, const char *technique, const char *name, double fallback) {
    const param_entry *p = find_param(s, technique, name);
    return p && !p->string ? p->number : fallback;
}

const char *volux_scene_param_string(const volux_scene *s, const char *technique, const char *name,
                                     const char *fallback) {
    const param_entry *p = find_param(s, technique, name);
    return p && p->string ? p->string : fallback;
}

int volux_scene_param_at(const volux_scene *s, int index, const char **technique, const char **name, double *number,
                         const char **string) {
    if (index < 0 || index >= s->n_params) return 0;
    const param_entry *p = &s->params[index];
    *technique = p->technique;
    *name = p->name;
    *number = p->number;
    *string = p->string;
    return 1;
}

float volux_scene_step_world(const volux_scene *s) {
    float sp = s->volume ? smallest_spacing(s->volume) : 1.0f;
    return s->render.step * sp;
}

volux_scene_stamp volux_scene_stamp_now(const volux_scene *s) {
    volux_scene_stamp st;
    memset(&st, 0, sizeof st);
    st.scene_id = s->id;
    memcpy(st.aspect, s->aspect, sizeof st.aspect);
    st.light_edits = s->light_edits;
    return st;
}

int volux_change_light(const volux_change_set *c, int slot) {
    if (c->since == 0) return 1;
    const volux_scene *s = c->scene;
    return s && slot >= 0 && slot < s->light_cap && s->lights[slot].edit > c->since;
}

int volux_change_light_count(const volux_change_set *c) {
    if (c->since == 0) return -1;
    int n = 0;
    for (int i = 0; c->scene && i < c->scene->light_cap; i++) n += c->scene->lights[i].edit > c->since;
    return n;
}

volux_change_set volux_scene_changes_since(const volux_scene *s, const volux_scene_stamp *seen) {
    volux_change_set c;
    memset(&c, 0, sizeof c);
    if (!seen || seen->scene_id != s->id) return volux_change_all();
    for (int a = 0; a < A_COUNT; a++)
        if (seen->aspect[a] != s->aspect[a]) c.what |= 1u << a;
    /* the counter starts at 1, so a stamp of this scene never has 0 (which
     * means "all") */
    c.since = seen->light_edits;
    c.scene = s;
    return c;
}

volux_vec3 volux_scene_escape_radiance(const volux_scene *s, volux_vec3 dir) {
    volux_vec3 sum = v3(0, 0, 0);
    int any = 0;
    for (int i = 0; i < s->light_slots; i++) {
        const light_slot *l = &s->lights[i];
        if (!l->present || l->desc.type != VOLUX_LIGHT_ENVIRONMENT || !l->desc.visible || !l->desc.enabled)
            continue;
        any = 1;
        sum = v3_add(sum, volux_environment_radiance(&l->desc, dir));
    }
    return any ? sum : s->background;
}

/* Light descriptions equal, maps compared by content (each scene owns its copy). */
static int light_equal(const volux_light_desc *a, const volux_light_desc *b) {
    volux_light_desc x = *a, y = *b;
    x.map = y.map = NULL;
    if (memcmp(&x, &y, sizeof x) != 0) return 0;
    if (!a->map || !b->map) return a->map == b->map;
    return a->map->width == b->map->width && a->map->height == b->map->height &&
           memcmp(a->map->rgb, b->map->rgb, sizeof(float) * 3 * (size_t)a->map->width * (size_t)a->map->height) == 0;
}

volux_status volux_scene_assign(volux_scene *dst, const volux_scene *src, int keep_volume) {
    volux_status st;
    if (!keep_volume && src->volume && src->volume != dst->volume &&
        (st = volux_scene_set_volume(dst, src->volume)))
        return st;
    if ((st = volux_scene_set_transfer(dst, &src->tf))) return st;
    if ((st = volux_scene_set_clip(dst, &src->clip))) return st;
    if (memcmp(&dst->camera, &src->camera, sizeof src->camera) != 0 && (st = volux_scene_set_camera(dst, &src->camera)))
        return st;
    int slots = dst->light_slots > src->light_slots ? dst->light_slots : src->light_slots;
    for (int i = 0; i < slots; i++) {
        const volux_light_desc *a = volux_scene_light(dst, i), *b = volux_scene_light(src, i);
        if (b && (!a || !light_equal(a, b))) {
            if ((st = volux_scene_set_light(dst, i, b))) return st;
        } else if (!b && a && (st = volux_scene_remove_light(dst, i)))
            return st;
    }
    volux_scene_set_background(dst, src->background);
    if ((st = volux_scene_set_render(dst, &src->render))) return st;
    for (int i = 0; i < src->n_params; i++) {
        const param_entry *p = &src->params[i], *q = find_param(dst, p->technique, p->name);
        int same = q && (p->string ? q->string && !strcmp(p->string, q->string) : !q->string && q->number == p->number);
        if (!same && (st = volux_scene_set_param(dst, p->technique, p->name, p->number, p->string))) return st;
    }
    return VOLUX_OK;
}
