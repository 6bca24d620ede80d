/*
 * volux/light.h — light sources (DESIGN §2 units).
 *
 *   directional: `direction` = direction the light travels; irradiance·color
 *   point:       position; intensity (W/sr)·color
 *   spot:        point + direction, cone_angle (full cut-off half-angle) and
 *                falloff_angle (half-angle where the smooth falloff starts), degrees
 *   sphere:      position, radius, radiance·color (area light)
 *   environment: constant radiance·color, or an equirectangular map (+Y up;
 *                u = 0.5 + atan2(d.x, −d.z)/(2π), v = acos(d.y)/π) with
 *                rotation_y and an intensity scale; visible to camera rays
 *                unless visible = 0.
 *
 * DOES NOT: sample lights (techniques do) or read map files (io.h).
 */
#ifndef VOLUX_LIGHT_H
#define VOLUX_LIGHT_H

#include "base.h"
#include "image.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum volux_light_type {
    VOLUX_LIGHT_DIRECTIONAL,
    VOLUX_LIGHT_POINT,
    VOLUX_LIGHT_SPOT,
    VOLUX_LIGHT_SPHERE,
    VOLUX_LIGHT_ENVIRONMENT
} volux_light_type;

VOLUX_API const char *volux_light_type_name(volux_light_type t);

typedef struct volux_light_desc {
    volux_light_type type;
    int enabled;            /* 0: present but switched off (toggle)        */
    volux_vec3 color;       /* [0,∞)³, default (1,1,1)                      */
    volux_vec3 direction;   /* directional, spot: travel direction          */
    volux_vec3 position;    /* point, spot, sphere                          */
    float irradiance;       /* directional                                  */
    float intensity;        /* point, spot (W/sr); environment: map scale   */
    float radiance;         /* sphere, constant environment                 */
    float radius;           /* sphere                                       */
    float cone_angle_deg;   /* spot: half-angle of the cone, (0, 90]        */
    float falloff_angle_deg;/* spot: half-angle where falloff starts, ≤ cone*/
    float rotation_y_deg;   /* environment map rotation about +Y            */
    int visible;            /* environment: seen by camera rays             */
    const volux_image *map; /* environment map, borrowed; the scene copies  */
} volux_light_desc;

/* Defaults for a type: white, enabled, visible, irradiance/intensity/
 * radiance 1, radius 1, cone 30°, falloff 25°, direction (0,0,−1). */
VOLUX_API void volux_light_desc_defaults(volux_light_desc *d, volux_light_type type);

/* Validates values (finite, non-negative, angles in range). */
VOLUX_API volux_status volux_light_desc_validate(volux_context *ctx, const volux_light_desc *d,
                                                 const char *path);

/* Spot cone factor in [0,1] for the angle between the spot axis and the
 * direction to the lit point: 1 inside falloff, smooth (cubic) to 0 at cone. */
VOLUX_API float volux_spot_falloff(const volux_light_desc *d, float cos_angle);

/* Radiance an environment light sends along -dir (i.e. seen looking in
 * direction `dir`), colour and intensity applied; bilinear map lookup. */
VOLUX_API volux_vec3 volux_environment_radiance(const volux_light_desc *d, volux_vec3 dir);
/* Map coordinates (u,v) ∈ [0,1)² of a direction, rotation applied (DESIGN §2). */
VOLUX_API void volux_environment_uv(const volux_light_desc *d, volux_vec3 dir, float *u, float *v);
/* Inverse of volux_environment_uv: unit direction for (u, v). */
VOLUX_API volux_vec3 volux_environment_direction(const volux_light_desc *d, float u, float v);

#ifdef __cplusplus
}
#endif
#endif
