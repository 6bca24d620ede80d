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
 * (≈ 4π/K each). Without the scale: see volux_environment_cells_scale. */
void volux_environment_cell_integrals(const volux_light_desc *d, int K, const volux_vec3 *from, volux_vec3 *S) {
    for (int k = 0; k < K; k++) S[k] = v3(0.0f, 0.0f, 0.0f);
    if (K <= 0) return;
    if (!d->map) {
        int N = 64 * K;
        float w = (float)(4.0 * 3.14159265358979323846 / N);
        for (int i = 0; i < N; i++) {
            int k = nearest_dir(from, K, volux_fibonacci_dir(i, N));
            S[k] = v3_add(S[k], v3(w, w, w));
        }
        return;
    }
    const volux_image *m = d->map;
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
            S[k] = v3_madd(S[k], L, w);
        }
    }
}

volux_vec3 volux_environment_cells_scale(const volux_light_desc *d) {
    /* as volux_environment_radiance scales the map or the constant */
    return v3_scale(d->color, d->map ? d->intensity : d->radiance);
}

static void add_scaled(const volux_light_desc *d, int K, const volux_vec3 *S, volux_vec3 *E) {
    const volux_vec3 scale = volux_environment_cells_scale(d);
    for (int k = 0; k < K; k++) E[k] = v3_add(E[k], v3_mul(S[k], scale));
}

void volux_environment_cells(const volux_light_desc *d, int K, const volux_vec3 *from, volux_vec3 *E) {
    if (K <= 0) return;
    volux_vec3 S[VOLUX_ENV_CELLS_MAX];
    if (K > VOLUX_ENV_CELLS_MAX) K = VOLUX_ENV_CELLS_MAX; /* the techniques' env_directions limit (256) */
    volux_environment_cell_integrals(d, K, from, S);
    add_scaled(d, K, S, E);
}

/* 64-bit hash of a map's texel bits (multiply–xorshift per 32-bit word;
 * the order matters, so a rotated or shifted map hashes differently). */
static uint64_t map_hash(const volux_image *m) {
    uint64_t h = 0x9E3779B97F4A7C15ull ^ ((uint64_t)m->width << 32 | (uint64_t)(uint32_t)m->height);
    const size_t n = 3 * (size_t)m->width * (size_t)m->height;
    for (size_t i = 0; i < n; i++) {
        uint32_t x;
        memcpy(&x, &m->rgb[i], sizeof x);
        h = (h ^ x) * 0xBF58476D1CE4E5B9ull;
        h ^= h >> 31;
    }
    return h;
}

void volux_environment_cells_cached(volux_env_cells_cache *c, const volux_light_desc *d, int K, volux_vec3 *E) {
    if (K <= 0) return;
    if (K > VOLUX_ENV_CELLS_MAX) K = VOLUX_ENV_CELLS_MAX;
    const int has_map = d->map != NULL;
    const int w = has_map ? d->map->width : 0, h = has_map ? d->map->height : 0;
    /* a constant environment's integrals depend on K alone */
    const float rot = has_map ? d->rotation_y_deg : 0.0f;
    const uint64_t hash = has_map ? map_hash(d->map) : 0;
    c->clock++;
    int hit = -1, victim = 0;
    for (int i = 0; i < VOLUX_ENV_CELLS_SLOTS; i++) {
        if (c->e[i].used && c->e[i].K == K && c->e[i].has_map == has_map && c->e[i].width == w &&
            c->e[i].height == h && c->e[i].rotation_y_deg == rot && c->e[i].hash == hash) {
            hit = i;
            break;
        }
        if (!c->e[i].used || (c->e[victim].used && c->e[i].last_use < c->e[victim].last_use)) victim = i;
    }
    if (hit < 0) {
        volux_vec3 from[VOLUX_ENV_CELLS_MAX];
        for (int k = 0; k < K; k++) from[k] = volux_fibonacci_dir(k, K);
        hit = victim;
        volux_environment_cell_integrals(d, K, from, c->e[hit].S);
        c->e[hit].used = 1, c->e[hit].K = K, c->e[hit].has_map = has_map;
        c->e[hit].width = w, c->e[hit].height = h, c->e[hit].rotation_y_deg = rot, c->e[hit].hash = hash;
        c->misses++;
    } else {
        c->hits++;
    }
    c->e[hit].last_use = c->clock;
    add_scaled(d, K, c->e[hit].S, E);
}
