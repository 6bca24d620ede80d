/* render/lights.c — see lights.h. */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "lights.h"

volux_vec3 volux_environment_mean(const volux_light_desc *d) {
    if (!d->map) return v3_scale(d->color, d->radiance);
    const volux_image *m = d->map;
    double sum[3] = {0, 0, 0}, wsum = 0.0;
    for (int y = 0; y < m->height; y++) {
        double w = sin(3.14159265358979323846 * (y + 0.5) / m->height); /* solid angle of the row */
        const float *row = m->rgb + 3 * (size_t)y * (size_t)m->width;
        for (int x = 0; x < m->width; x++)
            for (int c = 0; c < 3; c++) sum[c] += w * fmax(row[3 * x + c], 0.0);
        wsum += w * m->width;
    }
    volux_vec3 mean = v3((float)(sum[0] / wsum), (float)(sum[1] / wsum), (float)(sum[2] / wsum));
    return v3_scale(v3_mul(mean, d->color), d->intensity);
}

void volux_light_prepare(const volux_light_desc *d, int slot, volux_prepared_light *l) {
    memset(l, 0, sizeof *l);
    l->slot = slot;
    l->type = d->type;
    l->desc = d;
    switch (d->type) {
    case VOLUX_LIGHT_DIRECTIONAL:
        l->travel = v3_normalize(d->direction);
        l->power = v3_scale(d->color, d->irradiance);
        break;
    case VOLUX_LIGHT_SPHERE:
        /* Irradiance from a sphere of radiance L, radius r at distance
         * d > r facing it: E = L·π·r²/d², i.e. a point of I = L·π·r². */
        l->positional = 1;
        l->pos = d->position;
        l->radius = d->radius;
        l->power = v3_scale(d->color, d->radiance * VOLUX_PI * d->radius * d->radius);
        l->radiance = v3_scale(d->color, d->radiance);
        break;
    case VOLUX_LIGHT_ENVIRONMENT: break;
    default: /* point, spot */
        l->positional = 1;
        l->pos = d->position;
        l->power = v3_scale(d->color, d->intensity);
        l->spot = d->type == VOLUX_LIGHT_SPOT;
        l->axis = v3_normalize(d->direction);
        break;
    }
}

volux_status volux_light_list_prepare(const volux_scene *s, volux_light_list *out) {
    out->n_all = out->n_direct = out->n_env = out->n_sphere = 0;
    out->env_mean = v3(0, 0, 0);
    int need = volux_scene_light_slots(s);
    if (need > out->cap) {
        /* both arrays the same length: grow a copy of the count for each */
        volux_context *ctx = volux_scene_context(s);
        int cap_all = out->cap, cap_direct = out->cap;
        volux_status st = volux_grow_slots(ctx, &out->all, &cap_all, need, sizeof *out->all, "prepared lights");
        if (!st) st = volux_grow_slots(ctx, &out->direct, &cap_direct, need, sizeof *out->direct, "prepared lights");
        if (st) {
            /* keep what grew (freed by volux_light_list_free at its size) */
            volux_free(ctx, out->all, sizeof *out->all * (size_t)cap_all);
            volux_free(ctx, out->direct, sizeof *out->direct * (size_t)cap_direct);
            out->all = out->direct = NULL;
            out->cap = 0;
            return st;
        }
        out->cap = cap_all;
    }
    for (int i = 0; i < volux_scene_light_slots(s); i++) {
        const volux_light_desc *d = volux_scene_light(s, i);
        if (!d || !d->enabled) continue;
        volux_prepared_light *l = &out->all[out->n_all++];
        volux_light_prepare(d, i, l);
        if (d->type == VOLUX_LIGHT_ENVIRONMENT) {
            out->env_mean = v3_add(out->env_mean, volux_environment_mean(d));
            out->n_env++;
            continue;
        }
        out->n_sphere += d->type == VOLUX_LIGHT_SPHERE;
        out->direct[out->n_direct++] = *l;
    }
    return VOLUX_OK;
}

void volux_light_list_free(volux_context *ctx, volux_light_list *l) {
    volux_free(ctx, l->all, sizeof *l->all * (size_t)l->cap);
    volux_free(ctx, l->direct, sizeof *l->direct * (size_t)l->cap);
    l->all = l->direct = NULL;
    l->cap = l->n_all = l->n_direct = l->n_env = l->n_sphere = 0;
}

volux_vec3 volux_fibonacci_dir(int i, int n) {
    const double golden = 2.39996322972865332; /* π(3 − √5) */
    double z = 1.0 - (2.0 * i + 1.0) / n, r = sqrt(fmax(0.0, 1.0 - z * z)), phi = golden * i;
    return v3((float)(r * cos(phi)), (float)z, (float)(r * sin(phi)));
}

/* Index of the direction of `from` (K unit vectors) nearest to d. */
static int nearest_dir(const volux_vec3 *from, int K, volux_vec3 d) {
    int best = 0;
    float best_dot = -2.0f;
    for (int k = 0; k < K; k++) {
        float c = v3_dot(d, from[k]);
        if (c > best_dot) best_dot = c, best = k;
    }
    return best;
}

/* A map texel by texel (solid angle (2π/W)(π/H)·sin θ each): a sun lands
 * in its nearest direction instead of falling between point samples; a
 * constant environment with 64 finer Fibonacci points per direction
 * (≈ L·4π/K each). */
void volux_environment_cells(const volux_light_desc *d, int K, const volux_vec3 *from, volux_vec3 *E) {
    if (K <= 0) return;
    if (!d->map) {
        int N = 64 * K;
        float w = (float)(4.0 * 3.14159265358979323846 / N);
        for (int i = 0; i < N; i++) {
            volux_vec3 dir = volux_fibonacci_dir(i, N);
            int k = nearest_dir(from, K, dir);
            E[k] = v3_madd(E[k], volux_environment_radiance(d, dir), w);
        }
        return;
    }
    const volux_image *m = d->map;
    volux_vec3 scale = v3_scale(d->color, d->intensity);
    double dtheta = 3.14159265358979323846 / m->height, dphi = 2.0 * 3.14159265358979323846 / m->width;
    for (int j = 0; j < m->height; j++) {
        float v = ((float)j + 0.5f) / (float)m->height;
        float w = (float)(dphi * dtheta * sin(((double)j + 0.5) * dtheta));
        for (int i = 0; i < m->width; i++) {
            const float *t = &m->rgb[3 * ((size_t)j * (size_t)m->width + (size_t)i)];
            volux_vec3 L = v3(fmaxf(t[0], 0.0f), fmaxf(t[1], 0.0f), fmaxf(t[2], 0.0f));
            if (L.x <= 0.0f && L.y <= 0.0f && L.z <= 0.0f) continue;
            volux_vec3 dir = volux_environment_direction(d, ((float)i + 0.5f) / (float)m->width, v);
            int k = nearest_dir(from, K, dir);
            E[k] = v3_madd(E[k], v3_mul(L, scale), w);
        }
    }
}
