/*
 * volux/camera.h — pinhole and orthographic cameras.
 *
 * Pixel (0,0) is the top-left; pixel centres are at +0.5 (DESIGN §2). An
 * orbit camera is resolved against the volume's bounding sphere:
 * eye = C + distance·R·(cos el·sin az, sin el, cos el·cos az), look_at = C,
 * up = +Y; az = el = 0 looks down −Z. Orthographic framing with an orbit
 * uses height = 2·distance·R·tan(fov_y/2) unless `height` is given.
 *
 * DOES NOT: know images or volumes (the scene resolves orbits).
 */
#ifndef VOLUX_CAMERA_H
#define VOLUX_CAMERA_H

#include "base.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum volux_projection { VOLUX_PERSPECTIVE, VOLUX_ORTHOGRAPHIC } volux_projection;

typedef struct volux_camera_desc {
    volux_projection projection;
    volux_vec3 eye, look_at, up; /* up: also the orbit's axis (default +Y)  */
    float fov_y_deg;   /* perspective vertical field of view, (0,180)      */
    float height;      /* orthographic view height (world units); 0 = from
                          the orbit framing                                */
    int use_orbit;     /* 1: eye/look_at/up come from the orbit below      */
    float azimuth_deg, elevation_deg, distance; /* distance in units of R  */
} volux_camera_desc;

/* Orbit az 30, el 20, distance 1/sin(15°), fov 30: frames the volume. */
VOLUX_API void volux_camera_desc_defaults(volux_camera_desc *d);

/* The orbit's frame for an up axis: basis[1] = up normalised, basis[0]
 * and basis[2] the images of +X and +Z under the shortest rotation taking
 * +Y to up (for up = −Y, the half turn about X). For up = +Y it is the
 * identity, so DESIGN §3's orbit is unchanged. */
VOLUX_API void volux_camera_orbit_basis(volux_vec3 up, volux_vec3 basis[3]);

/* A resolved camera: an orthonormal frame and projection scales. */
typedef struct volux_camera {
    volux_projection projection;
    volux_vec3 eye, forward, right, up;
    float tan_half_fov;  /* perspective */
    float half_height;   /* orthographic */
    int width, height;
} volux_camera;

/* Resolves a description for an image of width×height, given the scene's
 * centre C and bounding radius R (used by orbits). Fails with
 * VOLUX_ERR_INVALID on degenerate frames (eye == look_at, up ∥ view). */
VOLUX_API volux_status volux_camera_resolve(volux_context *ctx, const volux_camera_desc *d,
                                            volux_vec3 center, float radius, int width, int height,
                                            volux_camera *out);

/* Ray through the image point (px, py) in pixel units (0,0 = top-left corner
 * of the image; pixel centres at +0.5). Direction is normalised. */
VOLUX_API void volux_camera_ray(const volux_camera *cam, float px, float py, volux_vec3 *origin,
                                volux_vec3 *dir);

#ifdef __cplusplus
}
#endif
#endif
