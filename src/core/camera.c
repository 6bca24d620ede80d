/* core/camera.c — camera description, orbit resolution, primary rays. */
#include <math.h>
#include <string.h>

#include "context_internal.h"
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

volux_status volux_camera_resolve(volux_context *ctx, const volux_camera_desc *d, volux_vec3 center, float radius,
                                  int width, int height, volux_camera *out) {
    if (width < 1 || height < 1) return volux_error(ctx, VOLUX_ERR_INVALID, "camera: image size %dx%d", width, height);
    if (!(d->fov_y_deg > 0.0f && d->fov_y_deg < 180.0f))
        return volux_error(ctx, VOLUX_ERR_INVALID, "camera.fov_y: must be in (0, 180), got %g", d->fov_y_deg);
    volux_vec3 eye = d->eye, at = d->look_at, up = d->up;
    if (d->use_orbit) {
        if (!(d->distance > 0.0f) || !isfinite(d->distance))
            return volux_error(ctx, VOLUX_ERR_INVALID, "camera.orbit.distance: must be > 0, got %g", d->distance);
        float az = d->azimuth_deg * VOLUX_PI / 180.0f, el = d->elevation_deg * VOLUX_PI / 180.0f;
        float r = d->distance * radius;
        /* DESIGN §3: eye = C + distance·R·(cos el·sin az, sin el, cos el·cos az) */
        eye = v3_add(center, v3(r * cosf(el) * sinf(az), r * sinf(el), r * cosf(el) * cosf(az)));
        at = center;
        up = v3(0, 1, 0);
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
        right = v3_cross(fwd, v3(0, 0, -1));
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
    float aspect = (float)cam->width / (float)cam->height;
    /* Normalised device coordinates: x right, y up, in [−1, 1]. */
    float sx = (2.0f * px / (float)cam->width - 1.0f) * aspect;
    float sy = 1.0f - 2.0f * py / (float)cam->height;
    if (cam->projection == VOLUX_ORTHOGRAPHIC) {
        *origin = v3_add(cam->eye, v3_add(v3_scale(cam->right, sx * cam->half_height),
                                          v3_scale(cam->up, sy * cam->half_height)));
        *dir = cam->forward;
    } else {
        *origin = cam->eye;
        volux_vec3 d = v3_add(cam->forward, v3_add(v3_scale(cam->right, sx * cam->tan_half_fov),
                                                   v3_scale(cam->up, sy * cam->tan_half_fov)));
        *dir = v3_normalize(d);
    }
}
