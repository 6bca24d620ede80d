/*
 * core/camera_rays.h — volux_camera_ray split by image axis, for loops
 * over many pixels (the packet ray caster's ray list).
 *
 * The image-plane offset of a ray is right·(sx·s) + up·(sy·s) with sx a
 * function of the column only and sy of the row only (s = half height,
 * orthographic, or tan(fov/2), perspective), so a tile's offsets can be
 * computed once per column and once per row. volux_camera_ray is written
 * with these same functions, so a ray assembled from them has the same
 * bits (no operation is reordered or fused: C11 mode, fp-contract off).
 */
#ifndef VOLUX_CAMERA_RAYS_H
#define VOLUX_CAMERA_RAYS_H

#include "core/vecmath.h"
#include "volux/camera.h"

static inline float volux_camera_scale_(const volux_camera *cam) {
    return cam->projection == VOLUX_ORTHOGRAPHIC ? cam->half_height : cam->tan_half_fov;
}

/* right·(sx·s) of image column coordinate px (pixel units, 0 = left edge). */
static inline volux_vec3 volux_camera_offset_x(const volux_camera *cam, float px) {
    float aspect = (float)cam->width / (float)cam->height;
    /* Normalised device coordinates: x right, y up, in [−1, 1]. */
    float sx = (2.0f * px / (float)cam->width - 1.0f) * aspect;
    return v3_scale(cam->right, sx * volux_camera_scale_(cam));
}

/* up·(sy·s) of image row coordinate py (0 = top edge). */
static inline volux_vec3 volux_camera_offset_y(const volux_camera *cam, float py) {
    float sy = 1.0f - 2.0f * py / (float)cam->height;
    return v3_scale(cam->up, sy * volux_camera_scale_(cam));
}

/* The ray of the offsets ox (column) and oy (row). */
static inline void volux_camera_ray_offsets(const volux_camera *cam, volux_vec3 ox, volux_vec3 oy, volux_vec3 *origin,
                                            volux_vec3 *dir) {
    if (cam->projection == VOLUX_ORTHOGRAPHIC) {
        *origin = v3_add(cam->eye, v3_add(ox, oy));
        *dir = cam->forward;
    } else {
        *origin = cam->eye;
        *dir = v3_normalize(v3_add(cam->forward, v3_add(ox, oy)));
    }
}

#endif
