/*
 * tests/support/lightvol_fixture.h — tiny scenes and state access for the
 * `lightvol` tests (header-only; include after test_util.h).
 *
 * Volumes are float32 with an identity extinction transfer function
 * (σt = value, 1/world unit), so a test states optical depths directly.
 */
#ifndef VOLUX_LIGHTVOL_FIXTURE_H
#define VOLUX_LIGHTVOL_FIXTURE_H

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "render/technique_class.h"

#include "techniques/lightvol/lightvol.h"
#include "test_util.h"

/* Scene over a float32 volume of σt values (data borrowed), white TF colour
 * (or `color` if non-NULL: rgb for every value), albedo a, small image. */
static inline volux_scene *lvf_scene(volux_context *ctx, int nx, int ny, int nz, const float *sigma, float albedo,
                                     const float *color) {
    volux_volume_desc vd;
    memset(&vd, 0, sizeof vd);
    vd.dims[0] = nx, vd.dims[1] = ny, vd.dims[2] = nz;
    vd.spacing[0] = vd.spacing[1] = vd.spacing[2] = 1.0;
    vd.type = VOLUX_FLOAT32;
    vd.data = sigma;
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_create(ctx, &vd, &v), VOLUX_OK);
    volux_scene *s = NULL;
    assert_int_equal(volux_scene_create(ctx, &s), VOLUX_OK);
    assert_int_equal(volux_scene_set_volume(s, v), VOLUX_OK);
    volux_volume_release(v);
    volux_transfer_desc tf;
    volux_transfer_desc_defaults(&tf);
    static const volux_tf_scalar_point ident[2] = {{0.0f, 0.0f}, {1000.0f, 1000.0f}};
    tf.opacity = ident;
    tf.n_opacity = 2;
    tf.extinction = 1;
    tf.albedo = albedo;
    volux_tf_color_point col[2];
    if (color) {
        col[0] = (volux_tf_color_point){0.0f, color[0], color[1], color[2]};
        col[1] = (volux_tf_color_point){1000.0f, color[0], color[1], color[2]};
        tf.color = col;
        tf.n_color = 2;
    }
    assert_int_equal(volux_scene_set_transfer(s, &tf), VOLUX_OK);
    volux_render_settings rs;
    volux_render_settings_defaults(&rs);
    rs.width = rs.height = 24;
    strcpy(rs.technique, "lightvol");
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    return s;
}

static inline volux_light_desc lvf_directional(float dx, float dy, float dz, float e) {
    volux_light_desc d;
    volux_light_desc_defaults(&d, VOLUX_LIGHT_DIRECTIONAL);
    d.direction = (volux_vec3){dx, dy, dz};
    d.irradiance = e;
    return d;
}

static inline volux_light_desc lvf_point(float x, float y, float z, float intensity) {
    volux_light_desc d;
    volux_light_desc_defaults(&d, VOLUX_LIGHT_POINT);
    d.position = (volux_vec3){x, y, z};
    d.intensity = intensity;
    return d;
}

static inline volux_light_desc lvf_spot(float x, float y, float z, float dx, float dy, float dz, float intensity,
                                        float cone, float falloff) {
    volux_light_desc d;
    volux_light_desc_defaults(&d, VOLUX_LIGHT_SPOT);
    d.position = (volux_vec3){x, y, z};
    d.direction = (volux_vec3){dx, dy, dz};
    d.intensity = intensity;
    d.cone_angle_deg = cone;
    d.falloff_angle_deg = falloff;
    return d;
}

static inline const lightvol_state *lvf_state(const volux_technique *t) { return volux_technique_state(t); }

static inline size_t lvf_count(const lightvol_state *st) {
    return (size_t)st->dims[0] * (size_t)st->dims[1] * (size_t)st->dims[2] * (size_t)st->ch;
}

/* Value i of the illumination volume as a float (either precision). */
static inline float lvf_value(const lightvol_state *st, size_t i) { return lv_vol_get(st, i); }

/* Copy of the illumination volume as floats (caller frees with free()). */
static inline float *lvf_copy(const volux_technique *t) {
    const lightvol_state *st = lvf_state(t);
    size_t n = lvf_count(st);
    float *c = malloc(n * sizeof(float));
    assert_non_null(c);
    for (size_t i = 0; i < n; i++) c[i] = lvf_value(st, i);
    return c;
}

/* max |a − b| over all channels, and max |b| (for relative tolerances). */
static inline double lvf_max_diff(const float *a, const float *b, size_t n, double *bmax) {
    double m = 0.0, mb = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = fabs((double)a[i] - (double)b[i]);
        if (d > m) m = d;
        if (fabs((double)b[i]) > mb) mb = fabs((double)b[i]);
    }
    if (bmax) *bmax = mb;
    return m;
}

/* The channels of node (i,j,k) as floats; valid until 16 further calls
 * (a ring of decoded nodes, so that a test can hold a few at once). */
static inline const float *lvf_at(const lightvol_state *st, int i, int j, int k) {
    static float ring[16][6];
    static unsigned next;
    float *out = ring[next++ % 16];
    size_t at = (((size_t)k * (size_t)st->dims[1] + (size_t)j) * (size_t)st->dims[0] + (size_t)i) * (size_t)st->ch;
    for (int c = 0; c < st->ch; c++) out[c] = lvf_value(st, at + (size_t)c);
    return out;
}

/* A lightvol instance with a float illumination volume (`precision`), so
 * that selective and entire updates compare at float rounding; the
 * default bfloat16 storage has tests of its own (test_lightvol_updates). */
static inline volux_technique *lvf_create(volux_context *ctx, volux_scene *s) {
    assert_int_equal(volux_scene_set_param(s, "lightvol", "precision", 0, "float"), VOLUX_OK);
    volux_technique *t = NULL;
    volux_status st = volux_technique_create(ctx, "lightvol", s, &t);
    if (st) fail_msg("lightvol create: %s", volux_context_error(ctx));
    return t;
}

static inline void lvf_update(volux_technique *t, volux_scene *s) {
    volux_status st = volux_technique_update(t, s, NULL);
    if (st) fail_msg("lightvol update: %s", volux_context_error(volux_scene_context(s)));
}

#endif
