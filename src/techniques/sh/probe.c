/*
 * techniques/sh/probe.c — the scene's lights as one SH light probe L_i
 * (Lindemann & Ropinski 2010, §4.3: "the same projection technique to
 * represent light probes"), seen from the volume's centre: the paper's L_i
 * has no position, so positional lights become distant ones there.
 *
 *   environment  constant: L·colour·√(4π) in the constant term; a map:
 *                quadrature over its pixels (exact solid angle per row) in
 *                the map's own frame, then rotated by rotation_y with the
 *                SH rotation, so turning the probe never re-reads the map
 *   directional  a delta of irradiance E from −direction: E·Y_j(ω)
 *   point, spot  a delta of I/d² (spot: its falloff towards the centre)
 *   sphere       a cap of radiance L and half-angle asin(r/d) (Funk–Hecke
 *                with the cap's zonal coefficients); the full sphere if
 *                the centre is inside it
 */
#include <math.h>
#include <string.h>

#include "sh.h"

#define SQRT_4PI 3.5449077018110318

static void project_map(const volux_light_desc *d, double acc[3][SH_MAX_COEFFS]) {
    const volux_image *m = d->map;
    const int W = m->width, H = m->height;
    memset(acc, 0, sizeof(double) * 3 * SH_MAX_COEFFS);
    double dphi = 2.0 * 3.14159265358979323846 / W;
    float y[SH_MAX_COEFFS];
    for (int row = 0; row < H; row++) {
        double th0 = 3.14159265358979323846 * row / H, th1 = 3.14159265358979323846 * (row + 1) / H;
        double th = 0.5 * (th0 + th1), domega = dphi * (cos(th0) - cos(th1));
        double st = sin(th), ct = cos(th);
        double row_acc[3][SH_MAX_COEFFS];
        memset(row_acc, 0, sizeof row_acc);
        const float *px = m->rgb + 3 * (size_t)row * (size_t)W;
        /* φ advances by dφ per texel: cos/sin by the angle-addition
         * recurrence instead of two library calls per texel */
        double phi0 = (0.5 / W - 0.5) * 2.0 * 3.14159265358979323846, cp = cos(phi0), sp = sin(phi0);
        const double cd = cos(dphi), sd = sin(dphi);
        for (int x = 0; x < W; x++) {
            /* DESIGN §2 at rotation 0: φ = (u − 0.5)·2π, d = (sin θ sin φ, cos θ, −sin θ cos φ) */
            volux_vec3 dir = v3((float)(st * sp), (float)ct, (float)(-st * cp));
            double c2 = cp * cd - sp * sd;
            sp = sp * cd + cp * sd;
            cp = c2;
            sh_eval(4, dir, y);
            for (int c = 0; c < 3; c++) {
                double v = px[3 * x + c] > 0.0f ? px[3 * x + c] : 0.0;
                if (v == 0.0) continue;
                for (int j = 0; j < SH_MAX_COEFFS; j++) row_acc[c][j] += v * y[j];
            }
        }
        for (int c = 0; c < 3; c++)
            for (int j = 0; j < SH_MAX_COEFFS; j++) acc[c][j] += domega * row_acc[c][j];
    }
}

static void delta(volux_vec3 from, volux_vec3 e, float out[3][SH_MAX_COEFFS]) {
    float y[SH_MAX_COEFFS];
    sh_eval(4, v3_normalize(from), y);
    const float ev[3] = {e.x, e.y, e.z};
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < SH_MAX_COEFFS; j++) out[c][j] = ev[c] * y[j];
}

volux_status sh_light_project(volux_context *ctx, const volux_light_desc *d, volux_vec3 centre,
                              float out[3][SH_MAX_COEFFS]) {
    (void)ctx;
    memset(out, 0, sizeof(float) * 3 * SH_MAX_COEFFS);
    switch (d->type) {
    case VOLUX_LIGHT_ENVIRONMENT: {
        if (!d->map) {
            const float L[3] = {d->color.x * d->radiance, d->color.y * d->radiance, d->color.z * d->radiance};
            for (int c = 0; c < 3; c++) out[c][0] = (float)(L[c] * SQRT_4PI);
            break;
        }
        double acc[3][SH_MAX_COEFFS];
        project_map(d, acc);
        double r[9];
        sh_rotation_y((double)d->rotation_y_deg * 3.14159265358979323846 / 180.0, r);
        sh_rotation rot;
        sh_rotation_from_matrix(r, 4, &rot);
        const float scale[3] = {d->color.x * d->intensity, d->color.y * d->intensity, d->color.z * d->intensity};
        for (int c = 0; c < 3; c++) {
            float tmp[SH_MAX_COEFFS];
            for (int j = 0; j < SH_MAX_COEFFS; j++) tmp[j] = (float)(acc[c][j] * scale[c]);
            sh_rotate(&rot, tmp, out[c]);
        }
        break;
    }
    case VOLUX_LIGHT_DIRECTIONAL:
        delta(v3_scale(d->direction, -1.0f), v3_scale(d->color, d->irradiance), out);
        break;
    case VOLUX_LIGHT_POINT:
    case VOLUX_LIGHT_SPOT: {
        volux_vec3 to = v3_sub(d->position, centre);
        float d2 = v3_dot(to, to);
        if (d2 <= 1e-12f) break;
        float f = 1.0f / d2;
        if (d->type == VOLUX_LIGHT_SPOT)
            f *= volux_spot_falloff(d, v3_dot(v3_scale(to, -1.0f / sqrtf(d2)), v3_normalize(d->direction)));
        delta(to, v3_scale(d->color, d->intensity * f), out);
        break;
    }
    case VOLUX_LIGHT_SPHERE: {
        volux_vec3 to = v3_sub(d->position, centre);
        float dist = v3_length(to);
        const float L[3] = {d->color.x * d->radiance, d->color.y * d->radiance, d->color.z * d->radiance};
        if (dist <= d->radius) {
            for (int c = 0; c < 3; c++) out[c][0] = (float)(L[c] * SQRT_4PI);
            break;
        }
        double k[SH_MAX_BANDS];
        for (int l = 0; l < SH_MAX_BANDS; l++) k[l] = sh_cap_zonal(l, asin(d->radius / dist));
        for (int c = 0; c < 3; c++) sh_zonal_add(4, k, v3_scale(to, 1.0f / dist), L[c], out[c]);
        break;
    }
    }
    return VOLUX_OK;
}
