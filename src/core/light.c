/* core/light.c — light descriptions (DESIGN §2 units). */
#include <math.h>
#include <string.h>

#include "context_internal.h"
#include "vecmath.h"
#include "volux/light.h"

const char *volux_light_type_name(volux_light_type t) {
    switch (t) {
    case VOLUX_LIGHT_DIRECTIONAL: return "directional";
    case VOLUX_LIGHT_POINT: return "point";
    case VOLUX_LIGHT_SPOT: return "spot";
    case VOLUX_LIGHT_SPHERE: return "sphere";
    case VOLUX_LIGHT_ENVIRONMENT: return "environment";
    }
    return "unknown";
}

void volux_light_desc_defaults(volux_light_desc *d, volux_light_type type) {
    memset(d, 0, sizeof *d);
    d->type = type;
    d->enabled = 1;
    d->visible = 1;
    d->color = v3(1, 1, 1);
    d->direction = v3(0, 0, -1);
    d->irradiance = 1.0f;
    d->intensity = 1.0f;
    d->radiance = 1.0f;
    d->radius = 1.0f;
    d->cone_angle_deg = 30.0f;
    d->falloff_angle_deg = 25.0f;
}

volux_status volux_light_desc_validate(volux_context *ctx, const volux_light_desc *d, const char *path) {
    if (!path) path = "light";
    if ((unsigned)d->type > VOLUX_LIGHT_ENVIRONMENT)
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s.type: unknown light type", path);
    if (!v3_finite(d->color) || d->color.x < 0 || d->color.y < 0 || d->color.z < 0)
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s.color: must be finite and >= 0", path);
    if (!v3_finite(d->position)) return volux_error(ctx, VOLUX_ERR_INVALID, "%s.position: must be finite", path);
    const struct {
        const char *name;
        float v;
    } scalars[] = {{"irradiance", d->irradiance}, {"intensity", d->intensity}, {"radiance", d->radiance},
                   {"radius", d->radius}};
    for (size_t i = 0; i < sizeof scalars / sizeof scalars[0]; i++)
        if (!(scalars[i].v >= 0.0f) || !isfinite(scalars[i].v))
            return volux_error(ctx, VOLUX_ERR_INVALID, "%s.%s: must be finite and >= 0, got %g", path, scalars[i].name,
                               scalars[i].v);
    if ((d->type == VOLUX_LIGHT_DIRECTIONAL || d->type == VOLUX_LIGHT_SPOT) &&
        (!v3_finite(d->direction) || v3_length(d->direction) <= 0.0f))
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s.direction: must be a non-zero vector", path);
    if (d->type == VOLUX_LIGHT_SPOT) {
        if (!(d->cone_angle_deg > 0.0f && d->cone_angle_deg <= 90.0f))
            return volux_error(ctx, VOLUX_ERR_INVALID, "%s.cone_angle: must be in (0, 90], got %g", path,
                               d->cone_angle_deg);
        if (!(d->falloff_angle_deg >= 0.0f && d->falloff_angle_deg <= d->cone_angle_deg))
            return volux_error(ctx, VOLUX_ERR_INVALID, "%s.falloff_angle: must be in [0, cone_angle], got %g", path,
                               d->falloff_angle_deg);
    }
    if (d->type == VOLUX_LIGHT_SPHERE && !(d->radius > 0.0f))
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s.radius: must be > 0", path);
    if (!isfinite(d->rotation_y_deg)) return volux_error(ctx, VOLUX_ERR_INVALID, "%s.rotation_y: must be finite", path);
    return VOLUX_OK;
}

float volux_spot_falloff(const volux_light_desc *d, float cos_angle) {
    float cos_cone = cosf(d->cone_angle_deg * VOLUX_PI / 180.0f);
    float cos_fall = cosf(d->falloff_angle_deg * VOLUX_PI / 180.0f);
    if (cos_angle >= cos_fall) return 1.0f;
    if (cos_angle <= cos_cone) return 0.0f;
    /* smoothstep in cos between the cone edge and the falloff start (pbrt's spot) */
    float t = (cos_angle - cos_cone) / (cos_fall - cos_cone);
    return t * t * (3.0f - 2.0f * t);
}

/* DESIGN §2: u = 0.5 + atan2(d.x, −d.z)/(2π), v = acos(d.y)/π, with the map
 * turned by rotation_y about +Y (a positive rotation turns the map the same
 * way as rotating the world direction by −rotation_y). */
void volux_environment_uv(const volux_light_desc *d, volux_vec3 dir, float *u, float *v) {
    float rot = d->rotation_y_deg * VOLUX_PI / 180.0f;
    float c = cosf(rot), s = sinf(rot);
    volux_vec3 r = v3(c * dir.x - s * dir.z, dir.y, s * dir.x + c * dir.z);
    float uu = 0.5f + atan2f(r.x, -r.z) * (0.5f * VOLUX_INV_PI);
    uu -= floorf(uu);
    *u = uu;
    *v = acosf(clampf(r.y, -1.0f, 1.0f)) * VOLUX_INV_PI;
}

volux_vec3 volux_environment_direction(const volux_light_desc *d, float u, float v) {
    float phi = (u - 0.5f) * 2.0f * VOLUX_PI, theta = v * VOLUX_PI;
    float st = sinf(theta);
    volux_vec3 r = v3(st * sinf(phi), cosf(theta), -st * cosf(phi));
    float rot = d->rotation_y_deg * VOLUX_PI / 180.0f;
    float c = cosf(rot), s = sinf(rot);
    return v3(c * r.x + s * r.z, r.y, -s * r.x + c * r.z);
}

volux_vec3 volux_environment_radiance(const volux_light_desc *d, volux_vec3 dir) {
    volux_vec3 scale = v3_scale(d->color, d->map ? d->intensity : d->radiance);
    if (!d->map) return scale;
    float u, v;
    volux_environment_uv(d, dir, &u, &v);
    const volux_image *m = d->map;
    /* Texel centres at (i+0.5)/w; wrap in u, clamp in v. */
    float x = u * (float)m->width - 0.5f, y = v * (float)m->height - 0.5f;
    int x0 = (int)floorf(x), y0 = (int)floorf(y);
    float fx = x - (float)x0, fy = y - (float)y0;
    int x1 = x0 + 1, y1 = y0 + 1;
    x0 = ((x0 % m->width) + m->width) % m->width;
    x1 = ((x1 % m->width) + m->width) % m->width;
    if (y0 < 0) y0 = 0;
    if (y1 > m->height - 1) y1 = m->height - 1;
    if (y0 > m->height - 1) y0 = m->height - 1;
    const float *p00 = &m->rgb[3 * ((size_t)y0 * (size_t)m->width + (size_t)x0)];
    const float *p10 = &m->rgb[3 * ((size_t)y0 * (size_t)m->width + (size_t)x1)];
    const float *p01 = &m->rgb[3 * ((size_t)y1 * (size_t)m->width + (size_t)x0)];
    const float *p11 = &m->rgb[3 * ((size_t)y1 * (size_t)m->width + (size_t)x1)];
    float rgb[3];
    for (int c = 0; c < 3; c++) {
        float a = p00[c] + (p10[c] - p00[c]) * fx, b = p01[c] + (p11[c] - p01[c]) * fx;
        rgb[c] = fmaxf(a + (b - a) * fy, 0.0f); /* maps may hold tiny negatives */
    }
    return v3_mul(v3(rgb[0], rgb[1], rgb[2]), scale);
}
