/* techniques/scatter/lights.c — see lights.h. */
#include <math.h>
#include <string.h>

#include "lights.h"

static volux_vec3 environment_mean(const volux_light_desc *d) {
    if (!d->map) return v3_scale(d->color, d->radiance);
    /* Solid-angle weighted mean of an equirectangular map (rows weighted by
     * sin of the polar angle). */
    const volux_image *m = d->map;
    double sum[3] = {0, 0, 0}, wsum = 0.0;
    for (int y = 0; y < m->height; y++) {
        double w = sin(3.14159265358979323846 * (y + 0.5) / m->height);
        const float *row = m->rgb + 3 * (size_t)y * (size_t)m->width;
        for (int x = 0; x < m->width; x++)
            for (int c = 0; c < 3; c++) sum[c] += w * fmax(row[3 * x + c], 0.0);
        wsum += w * m->width;
    }
    volux_vec3 mean = v3((float)(sum[0] / wsum), (float)(sum[1] / wsum), (float)(sum[2] / wsum));
    return v3_scale(v3_mul(mean, d->color), d->intensity);
}

int scatter_lights_prepare(const volux_scene *s, scatter_light *out, int max, volux_vec3 *ambient) {
    int n = 0;
    *ambient = v3(0, 0, 0);
    for (int i = 0; i < volux_scene_light_slots(s); i++) {
        const volux_light_desc *d = volux_scene_light(s, i);
        if (!d || !d->enabled) continue;
        if (d->type == VOLUX_LIGHT_ENVIRONMENT) {
            *ambient = v3_add(*ambient, environment_mean(d));
            continue;
        }
        if (n >= max) continue;
        scatter_light *l = &out[n++];
        memset(l, 0, sizeof *l);
        l->slot = i;
        l->desc = *d;
        switch (d->type) {
        case VOLUX_LIGHT_DIRECTIONAL:
            l->dir = v3_normalize(d->direction);
            l->power = v3_scale(d->color, d->irradiance);
            break;
        case VOLUX_LIGHT_SPHERE:
            l->positional = 1;
            l->pos = d->position;
            l->power = v3_scale(d->color, d->radiance * VOLUX_PI * d->radius * d->radius);
            break;
        default:
            l->positional = 1;
            l->pos = d->position;
            l->power = v3_scale(d->color, d->intensity);
            l->spot = d->type == VOLUX_LIGHT_SPOT;
            l->spot_dir = v3_normalize(d->direction);
            break;
        }
    }
    return n;
}
