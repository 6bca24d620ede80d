/* core/camera.c — camera description, orbit resolution, primary rays. */
#include <math.h>
#include <string.h>

#include "context_internal.h"
#include "camera_rays.h"
#include "vecmath.h"
#include "volux/camera.h"

void volux_camera_desc_defaults(volux_camera_desc *d) {
    memset(d, 0, sizeof *d);
    d->projection = VOLUX_PERSPECTIVE;
    d->use_orbit = 1;
    d->azimuth_deg = 30.0f;
    d->elevation_deg = 20.0f;
    d->fov_y_deg = 30.0f;
    d->distance = 1.0f / sinf(15.0f * VOLUX_PI / 180.0f);
    d->up = v3(0, 1, 0);
}

void volux_camera_orbit_basis(volux_vec3 up, volux_vec3 basis[3]) {
    float len = v3_length(up);
    volux_vec3 u = len > 0.0f && isfinite(len) ? v3_scale(up, 1.0f / len) : v3(0, 1, 0);
    if (u.x == 0.0f && u.y == 1.0f && u.z == 0.0f) { /* DESIGN §3's frame, exactly */
        basis[0] = v3(1, 0, 0), basis[1] = v3(0, 1, 0), basis[2] = v3(0, 0, 1);
        return;
    }
    if (u.y < -0.9999f) { /* +Y → −Y: the half turn about X */
        basis[0] = v3(1, 0, 0), basis[1] = u, basis[2] = v3(0, 0, -1);
        return;
    }
    /* The rotation taking +Y to u along the shortest arc (Rodrigues):
     * R·v = v + k×v + k×(k×v)/(1 + cos θ), k = Y×u, cos θ = u.y. */
    volux_vec3 k = v3(u.z, 0.0f, -u.x);
    float f = 1.0f / (1.0f + u.y);
    volux_vec3 ex = v3(1, 0, 0), ez = v3(0, 0, 1);
    basis[0] = v3_normalize(v3_add(v3_add(ex, v3_cross(k, ex)), v3_scale(v3_cross(k, v3_cross(k, ex)), f)));
    basis[1] = u;
    basis[2] = v3_normalize(v3_add(v3_add(ez, v3_cross(k, ez)), v3_scale(v3_cross(k, v3_cross(k, ez)), f)));
}

volux_status volux_camera_resolve(volux_context *ctx, const volux_camera_desc *d, volux_vec3 center, float radius,
                                  int width, int height, volux_camera *out) {
    if (width < 1 || height < 1) return volux_error(ctx, VOLUX_ERR_INVALID, "camera: image size %dx%d", width, height);
    if (!(d->fov_y_deg > 0.0f && d->fov_y_deg < 180.0f))
        return volux_error(ctx, VOLUX_ERR_INVALID, "camera.fov_y: must be in (0, 180), got %g", d->fov_y_deg);
    volux_vec3 eye = d->eye, at = d->look_at, up = d->up;
    if (!v3_finite(up) || v3_length(up) <= 0.0f)
        return volux_error(ctx, VOLUX_ERR_INVALID, "camera.up: must be a non-zero finite vector");
    volux_vec3 basis[3];
    volux_camera_orbit_basis(up, basis);
    if (d->use_orbit) {
        if (!(d->distance > 0.0f) || !isfinite(d->distance))
            return volux_error(ctx, VOLUX_ERR_INVALID, "camera.orbit.distance: must be > 0, got %g", d->distance);
        float az = d->azimuth_deg * VOLUX_PI / 180.0f, el = d->elevation_deg * VOLUX_PI / 180.0f;
        float r = d->distance * radius;
        /* DESIGN §3: eye = C + distance·R·(cos el·sin az, sin el, cos el·cos az)
         * in the orbit's frame (x, up, z): the identity for up = +Y. */
        volux_vec3 off = v3_add(v3_add(v3_scale(basis[0], r * cosf(el) * sinf(az)), v3_scale(basis[1], r * sinf(el))),
                                v3_scale(basis[2], r * cosf(el) * cosf(az)));
        eye = v3_add(center, off);
        at = center;
        up = basis[1];
    }
    if (!v3_finite(eye) || !v3_finite(at) || !v3_finite(up))
        return volux_error(ctx, VOLUX_ERR_INVALID, "camera: eye, look_at and up must be finite");
    volux_vec3 fwd = v3_sub(at, eye);
    if (v3_length(fwd) <= 0.0f) return volux_error(ctx, VOLUX_ERR_INVALID, "camera: eye and look_at coincide");
    fwd = v3_normalize(fwd);
    volux_vec3 right = v3_cross(fwd, up);
    if (v3_length(right) < 1e-6f) {
        /* Looking straight up or down an orbit: pick a stable right vector
         * instead of failing, so el = ±90 works. */
        if (!d->use_orbit) return volux_error(ctx, VOLUX_ERR_INVALID, "camera: up is parallel to the view direction");
        right = v3_cross(fwd, v3_scale(basis[2], -1.0f));
    }
    right = v3_normalize(right);
    out->projection = d->projection;
    out->eye = eye;
    out->forward = fwd;
    out->right = right;
    out->up = v3_cross(right, fwd);
    out->tan_half_fov = tanf(0.5f * d->fov_y_deg * VOLUX_PI / 180.0f);
    if (d->projection == VOLUX_ORTHOGRAPHIC) {
        float h = d->height;
        if (!(h > 0.0f)) /* same framing as the perspective view at the focal point */
            h = 2.0f * v3_length(v3_sub(at, eye)) * out->tan_half_fov;
        if (!(h > 0.0f) || !isfinite(h))
            return volux_error(ctx, VOLUX_ERR_INVALID, "camera.height: must be > 0, got %g", d->height);
        out->half_height = 0.5f * h;
    } else {
        out->half_height = 0.0f;
    }
    out->width = width;
    out->height = height;
    return VOLUX_OK;
}

void volux_camera_ray(const volux_camera *cam, float px, float py, volux_vec3 *origin, volux_vec3 *dir) {
    /* core/camera_rays.h: the packet ray caster builds the same rays from
     * per-column and per-row offsets */
    volux_camera_ray_offsets(cam, volux_camera_offset_x(cam, px), volux_camera_offset_y(cam, py), origin, dir);
}
