/*
 * techniques/sh/sh.c — `sh`: advanced light–material interaction with
 * spherical harmonics (Lindemann & Ropinski 2010): the class, its update
 * (edits map to the least work) and the renderer (Eq. 3).
 *
 * Rendering. Each camera ray composites front to back (the ray-caster
 * base's emission–absorption march); a segment emits, per unit opacity,
 *
 *     L(x, ω_o) = [∫ M L_i dω_i] · [∫ L'_mi L_i dω_i] / ∫ L_i dω_i
 *
 * — the paper's two successive double products (§4.3), divided by the
 * light's total so the result is a radiance (a deviation, see the docs:
 * the product is then exact when either M or L'_mi is constant over the
 * sphere, e.g. for an isotropic phase function or for an unshadowed
 * point). The second factor does not depend on ω_o: it is evaluated once
 * per coefficient node when the light or the coefficients change (the
 * shade volume S, three floats per node, trilinear at render time) —
 * the same dot products, in an order that makes camera edits free and
 * light edits a bake of S. The first factor is, for the TF's phase
 * function and phase materials, albedo·c(s)·Σ_lm g^l L_lm Y_lm(ω) per ray
 * (Funk–Hecke with the HG kernel), and for BRDF materials a lookup of the
 * material–light table F(n, ω_o) (material.c) at the gradient normal,
 * blended with the phase function by the gradient magnitude (surfaces
 * reflect, homogeneous regions scatter).
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "sh.h"

static const volux_param_info sh_params[] = {
    {"bands", VOLUX_PARAM_INT, 4, 1, 4, NULL, "SH bands L + 1 of every projection (the paper: 4, i.e. 16 coefficients)"},
    {"chroma_bands", VOLUX_PARAM_INT, 0, 0, 4, NULL,
     "0: RGB coefficients at `bands`; n > 0: luma at `bands`, chroma (Cb, Cr) at n bands (the paper's §5: 2)"},
    {"downsample", VOLUX_PARAM_INT, 3, 1, 8, NULL,
     "fine voxels per coefficient voxel (the paper: coefficient volumes at ~33 % resolution)"},
    {"rays", VOLUX_PARAM_INT, 64, 4, 4096, NULL, "rays per coefficient voxel (stratified over the sampling region)"},
    {"step_growth", VOLUX_PARAM_NUMBER, 1.15, 1, 2, NULL,
     "factor by which the projection's ray step grows per step (Ritschel 2007); coarser pyramid levels follow it"},
    {"ray_opacity", VOLUX_PARAM_NUMBER, 0.95, 0.5, 0.9999, NULL,
     "a projection ray stops at this opacity (the paper: 95 %)"},
    {"bleeding", VOLUX_PARAM_BOOL, 0, 0, 1, NULL,
     "colour bleeding: project T + the composited albedo·colour along each ray (RGB coefficients)"},
    {"scattering", VOLUX_PARAM_BOOL, 0, 0, 1, NULL,
     "scattering pass (Eq. 4): gather L_mi over N(x) weighted by the dipole R_d of `scatter_material`"},
    {"scatter_material", VOLUX_PARAM_STRING, 0, 0, 0, "skin1",
     "R_d preset (Jensen et al. 2001): apple, chicken1, chicken2, cream, ketchup, marble, potato, skimmilk, "
     "skin1, skin2, spectralon, wholemilk"},
    {"scatter_scale", VOLUX_PARAM_NUMBER, 0.5, 1e-3, 1e3, NULL,
     "millimetres of material per world unit (the presets' coefficients are per mm)"},
    {"neighbourhood", VOLUX_PARAM_NUMBER, 0.1, 0.01, 0.5, NULL,
     "radius of the scattering neighbourhood N(x) as a fraction of the largest extent (the paper: 10 %)"},
    {"env_product", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,
     "environment lights through the triple product: L_env*L'_mi projected per node, so the phase function sees where "
     "the environment is occluded (16 coefficients per colour and node); false: the paper's two double products (Eq. 3 "
     "as in §4.3), which multiply the phase-weighted light by the mean visibility"},
    {"progressive", VOLUX_PARAM_BOOL, 0, 0, 1, NULL,
     "project coarse first (2x coarser grid, 1/8 of the rays) and refine in later steps (volux_technique_refine)"},
    {"surface_offset", VOLUX_PARAM_NUMBER, 1, 0, 4, NULL,
     "coefficient cells by which a surface's shading samples read the grid outward along the opacity gradient, and "
     "its nodes start their rays (the depth on the way is taken from the volume per light direction); 0: at the "
     "sample, which draws contour rings on dense surfaces (issue 28)"},
    {"delta_shadows", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,
     "delta lights (directional, point, spot) shadowed by a per-node transmittance towards each (a sweep at the "
     "volume's resolution) instead of the 4-band visibility, which lights the far side of plates thinner than a "
     "coefficient cell; only without bleeding and scattering (their coefficients carry colour) (issue 28)"},
    {"near_field", VOLUX_PARAM_NUMBER, 2, 0, 8, NULL,
     "with delta_shadows: coefficient cells of the way to a delta light each sample marches before it reads the "
     "per-node transmittance (nodes around the sample sit either side of thin plates)"},
    VOLUX_PARAM_GRADIENT_THRESHOLD("BRDF shading is"),
    VOLUX_PARAM_PREINTEGRATE,
    VOLUX_PARAM_EARLY_TERMINATION,
    VOLUX_PARAM_SKIP_EMPTY,
    {NULL, 0, 0, 0, 0, NULL, NULL}};

/* ------------------------------------------------------------------ update */

static volux_status read_projection_params(sh_state *st, const volux_scene *scene, sh_projection_params *p) {
    const volux_technique_class *cls = st->rc.cls;
    memset(p, 0, sizeof *p);
    p->bands = (int)volux_technique_param(scene, cls, "bands");
    p->chroma_bands = (int)volux_technique_param(scene, cls, "chroma_bands");
    p->downsample = (int)volux_technique_param(scene, cls, "downsample");
    p->rays = (int)volux_technique_param(scene, cls, "rays");
    p->step_growth = (float)volux_technique_param(scene, cls, "step_growth");
    p->ray_opacity = (float)volux_technique_param(scene, cls, "ray_opacity");
    p->bleeding = (int)volux_technique_param(scene, cls, "bleeding");
    p->scattering = (int)volux_technique_param(scene, cls, "scattering");
    p->scatter_scale = (float)volux_technique_param(scene, cls, "scatter_scale");
    p->neighbourhood = (float)volux_technique_param(scene, cls, "neighbourhood");
    p->progressive = (int)volux_technique_param(scene, cls, "progressive");
    p->surface_offset = (float)volux_technique_param(scene, cls, "surface_offset");
    const char *name = volux_technique_param_string(scene, cls, "scatter_material");
    const sh_dipole_material *m = sh_dipole_find(name);
    if (!m)
        return volux_error(st->rc.ctx, VOLUX_ERR_INVALID,
                           "techniques.sh.scatter_material: unknown preset \"%s\" (apple, chicken1, chicken2, cream, "
                           "ketchup, marble, potato, skimmilk, skin1, skin2, spectralon, wholemilk)",
                           name);
    p->scatter_preset = (int)(m - sh_dipole_at(0));
    if (!p->scattering) p->scatter_preset = 0, p->scatter_scale = 0, p->neighbourhood = 0;
    if (!p->bleeding && !p->scattering) p->chroma_bands = 0;
    return VOLUX_OK;
}

/* FNV-1a over the colour curve and albedo: what bleeding reads of COLOR. */
static uint64_t color_hash(const volux_transfer_desc *tf) {
    uint64_t h = 1469598103934665603ull;
    const unsigned char *p = (const unsigned char *)tf->color;
    for (size_t i = 0; i < sizeof *tf->color * (size_t)tf->n_color; i++) h = (h ^ p[i]) * 1099511628211ull;
    p = (const unsigned char *)&tf->albedo;
    for (size_t i = 0; i < sizeof tf->albedo; i++) h = (h ^ p[i]) * 1099511628211ull;
    return h ^ (uint64_t)tf->n_color;
}

typedef struct bake_job {
    const sh_state *st;
    const sh_grid *grid;
    const sh_layout *L;
    const float *coef;
    float *shade;
    float *prod;                 /* NULL: no triple product          */
    float ld[3][SH_MAX_COEFFS];  /* the lights S is normalised over  */
    float E[3];
    /* M_c[k][j] = Σ_i Γ_ijk L_env,c,i: the product with the environment
     * as a 16 × 16 matrix, so a node costs 256 multiply-adds per channel */
    float M[3][SH_MAX_COEFFS][SH_MAX_COEFFS];
} bake_job;

/* S_c = ∫ L'_mi,c L_d,c / ∫ L_d,c at every node (Eq. 3's second factor,
 * normalised; L_d = every light, or the delta lights when the environment
 * goes through the triple product); Y/Cb/Cr channels are mixed back to RGB
 * linearly. With `prod`: (L_env,c·L'_mi,c) projected, 16 per channel. */
static void bake_slice(void *user, int64_t z, int thread) {
    (void)thread;
    const bake_job *b = user;
    const sh_state *st = b->st;
    const sh_layout *L = b->L;
    static const float ycc[3][3] = {{1.0f, 0.0f, 1.5748f}, {1.0f, -0.18732f, -0.46812f}, {1.0f, 1.8556f, 0.0f}};
    size_t per = (size_t)b->grid->dims[0] * b->grid->dims[1];
    for (size_t n = (size_t)z * per; n < (size_t)(z + 1) * per; n++) {
        const float *cf = b->coef + n * (size_t)L->stride;
        float *S = b->shade + 4 * n;
        for (int c = 0; c < 3; c++) {
            float v = 0.0f;
            if (L->channels == 1) v = sh_dot(L->bands[0], cf, b->ld[c]);
            else if (!L->ycc) v = sh_dot(L->bands[c], cf + L->offset[c], b->ld[c]);
            else
                for (int q = 0; q < 3; q++)
                    if (ycc[c][q] != 0.0f) v += ycc[c][q] * sh_dot(L->bands[q], cf + L->offset[q], b->ld[c]);
            S[c] = b->E[c] > 1e-12f && v > 0.0f ? v / b->E[c] : 0.0f;
            if (b->prod) {
                /* channel c's L'_mi, zero above its bands */
                float V[SH_MAX_COEFFS] = {0};
                for (int q = 0; q < 3; q++) {
                    float wq = L->channels == 1 ? (q == 0) : !L->ycc ? (q == c) : ycc[c][q];
                    if (wq == 0.0f) continue;
                    const int bq = L->bands[L->channels == 1 ? 0 : q];
                    const float *cq = cf + (L->channels == 1 ? 0 : L->offset[q]);
                    for (int j = 0; j < bq * bq; j++) V[j] += wq * cq[j];
                }
                float *W = b->prod + (n * 3 + (size_t)c) * SH_MAX_COEFFS;
                int flat = 1; /* unoccluded (skipped nodes, empty space): L_env·V0/√(4π) */
                for (int j = 1; j < SH_MAX_COEFFS && flat; j++) flat = V[j] == 0.0f;
                if (flat)
                    for (int j = 0; j < SH_MAX_COEFFS; j++) W[j] = st->le[c][j] * V[0] * 0.28209479f;
                else
                    for (int k = 0; k < SH_MAX_COEFFS; k++) {
                        float w = 0.0f;
                        for (int j = 0; j < SH_MAX_COEFFS; j++) w += b->M[c][k][j] * V[j];
                        W[k] = w;
                    }
            }
        }
        S[3] = 0.0f;
    }
}

/* The lights the shade volume S stands for: all of them, or without the
 * environment when that goes through the triple product. */
static void delta_lights(const sh_state *st, float ld[3][SH_MAX_COEFFS]) {
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < SH_MAX_COEFFS; j++) ld[c][j] = st->li[c][j] - (st->product_on ? st->le[c][j] : 0.0f);
}

/* Bakes the shade volume of (grid, layout, coef) into shade (4 per node)
 * and, with the triple product, the product volume into prod. */
static void bake_into(sh_state *st, const sh_grid *g, const sh_layout *L, const float *coef, float *shade,
                      float *prod) {
    bake_job b; /* 3 KB of matrices: fine on the stack */
    memset(&b, 0, sizeof b);
    b.st = st, b.grid = g, b.L = L, b.coef = coef, b.shade = shade, b.prod = st->product_on ? prod : NULL;
    delta_lights(st, b.ld);
    for (int c = 0; c < 3; c++) b.E[c] = 3.5449077f * b.ld[c][0]; /* ∫ L_d = √(4π)·L_00 */
    if (st->dvis_on)
        /* the true delta lights are shadowed by their transmittance grids
         * (deltavis.c): S keeps the others, still normalised over all */
        for (int i = 0; i < st->n_delta; i++) {
            if (!st->delta_exact[i]) continue;
            const sh_light_coeffs *lc = &st->light_sh[st->rc.lights.all[st->delta_light[i]].slot];
            for (int c = 0; c < 3; c++) {
                for (int j = 0; j < SH_MAX_COEFFS; j++) b.ld[c][j] -= lc->c[c][j];
                st->dvis_w[i][c] = b.E[c] > 1e-12f ? st->delta_w[i][c] / b.E[c] : 0.0f;
            }
        }
    if (b.prod)
        for (int n = 0; n < st->triple.n; n++)
            for (int c = 0; c < 3; c++)
                b.M[c][st->triple.k[n]][st->triple.j[n]] += st->triple.v[n] * st->le[c][st->triple.i[n]];
    volux_parallel_for(st->rc.threads, g->dims[2], bake_slice, &b);
    st->bakes++;
}

static size_t prod_bytes(const sh_state *st, const sh_grid *g) {
    return st->product_on ? g->nodes * 3 * SH_MAX_COEFFS * sizeof(float) : 0;
}

static volux_status bake(sh_state *st) {
    size_t bytes = st->grid.nodes * 4 * sizeof(float);
    if (bytes != st->shade_bytes) {
        if (st->shade) volux_free_aligned(st->rc.ctx, st->shade, st->shade_bytes);
        st->shade_bytes = 0;
        if (!(st->shade = volux_alloc_aligned(st->rc.ctx, bytes)))
            return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the shade volume");
        st->shade_bytes = bytes;
    }
    size_t pb = prod_bytes(st, &st->grid);
    if (pb != st->prod_bytes) {
        if (st->prod) volux_free_aligned(st->rc.ctx, st->prod, st->prod_bytes);
        st->prod = NULL;
        st->prod_bytes = 0;
        if (pb && !(st->prod = volux_alloc_aligned(st->rc.ctx, pb)))
            return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the environment product volume");
        st->prod_bytes = pb;
    }
    bake_into(st, &st->grid, &st->layout, st->coef, st->shade, st->prod);
    if (!st->dvis_on) {
        sh_delta_visibility_free(st);
        return VOLUX_OK;
    }
    return sh_delta_visibility(st);
}

static void free_materials(sh_state *st) {
    for (int i = 0; i < SH_MAX_MATERIALS; i++) sh_material_free(st->rc.ctx, &st->mat[i]);
    st->n_materials = 0;
    st->any_brdf = 0;
}

static volux_status prepare_materials(sh_state *st, const volux_scene *scene) {
    const volux_transfer_desc *tf = volux_scene_transfer(scene);
    const volux_transfer_lut *lut = st->rc.lut;
    free_materials(st);
    volux_status s;
    for (int i = 0; i < tf->n_materials; i++) {
        if ((s = sh_material_prepare(st->rc.ctx, &tf->materials[i], &st->mat[i]))) {
            free_materials(st);
            return s;
        }
        st->n_materials = i + 1;
        st->any_brdf |= st->mat[i].brdf;
    }
    /* material per LUT entry: the first range that holds the scalar */
    int n = lut->n < 4096 ? lut->n : 4096;
    for (int e = 0; e < 4096; e++) {
        float sv = lut->s_min + (float)(e < n ? e : n - 1) * (lut->s_max - lut->s_min) / (float)(n > 1 ? n - 1 : 1);
        st->mat_index[e] = 255;
        for (int i = 0; i < tf->n_materials; i++)
            if (sv >= tf->materials[i].s0 && sv <= tf->materials[i].s1) {
                st->mat_index[e] = (uint8_t)i;
                break;
            }
    }
    return VOLUX_OK;
}


/* ------------------------------------------------------------------ surfaces (issue 28) */

/* Legendre coefficients λ⁺_l(D) = 2π ∫_0^1 e^{−D/μ} P_l(μ) dμ of the
 * zonal near-surface transmittance K_D(μ) = e^{−D/μ} for μ > 0 (leaving
 * through optical depth D measured along the normal: a half-space); the
 * shading adds (1 − w)·2π ∫_{−1}^0 P_l for μ ≤ 0 (into the material).
 * Funk–Hecke: ∫ K_D(ω·n) L(ω) dω = Σ_lm λ_l L_lm Y_lm(n), exact for a
 * band-limited L. */
static void kdepth_init(float k[SH_KD_N][SH_MAX_BANDS]) {
    enum { M = 4096 };
    for (int i = 0; i < SH_KD_N; i++) {
        double D = (double)SH_KD_MAX * i / (SH_KD_N - 1), acc[SH_MAX_BANDS] = {0, 0, 0, 0};
        for (int s = 0; s < M; s++) {
            double mu = (s + 0.5) / M, K = exp(-D / mu);
            double P[SH_MAX_BANDS] = {1.0, mu, 0.5 * (3 * mu * mu - 1), 0.5 * (5 * mu * mu * mu - 3 * mu)};
            for (int l = 0; l < SH_MAX_BANDS; l++) acc[l] += K * P[l] / M;
        }
        for (int l = 0; l < SH_MAX_BANDS; l++) k[i][l] = (float)(2.0 * VOLUX_PI * acc[l]);
    }
}

/* The lights as the surface attenuation weighs them: every non-environment
 * light as a direction seen from the volume's centre (as its SH probe,
 * probe.c) with weight ∫L per colour; environments through st->le. */
static void surface_lights(sh_state *st, volux_vec3 centre) {
    const volux_light_list *ll = &st->rc.lights;
    st->n_delta = 0;
    for (int k = 0; k < 3; k++) st->delta_sum[k] = 0.0f, st->env_sum[k] = 3.5449077f * st->le[k][0];
    for (int k = 0; k < 3; k++) st->rest_sum[k] = 0.0f;
    for (int i = 0; i < ll->n_all && st->n_delta < SH_MAX_DELTA; i++) {
        const volux_prepared_light *l = &ll->all[i];
        if (l->type == VOLUX_LIGHT_ENVIRONMENT) continue;
        volux_vec3 d = l->positional ? v3_sub(l->pos, centre) : v3_scale(l->travel, -1.0f);
        float len = v3_length(d);
        if (!(len > 0.0f)) continue;
        int n = st->n_delta++;
        st->delta_dir[n] = v3_scale(d, 1.0f / len);
        st->delta_exact[n] = l->type != VOLUX_LIGHT_SPHERE; /* a sphere is a cap in its probe */
        st->delta_light[n] = i;
        volux_vec3 tr, e0 = volux_light_irradiance(l, centre, &tr);
        st->delta_e0[n] = e0.x + e0.y + e0.z;
        for (int k = 0; k < 3; k++) {
            float w = 3.5449077f * st->light_sh[l->slot].c[k][0];
            st->delta_w[n][k] = w > 0.0f ? w : 0.0f;
            st->delta_sum[k] += st->delta_w[n][k];
            if (!st->delta_exact[n]) st->rest_sum[k] += st->delta_w[n][k];
        }
    }
}

static volux_status sh_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    sh_state *st = state;
    volux_raycaster *rc = &st->rc;
    const volux_technique_class *cls = rc->cls;
    const uint32_t w = c->what;
    volux_status s;
    if (w & VOLUX_CHANGE_VOLUME) {
        if ((s = volux_volume_build_bricks(rc->volume))) return s;
        st->have_grad = 0;
    }
    if (w & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        st->preintegrate = (int)volux_technique_param(scene, cls, "preintegrate");
        st->skip_empty = (int)volux_technique_param(scene, cls, "skip_empty");
        st->t_min = (float)volux_technique_param(scene, cls, "early_termination");
        st->grad_ref = volux_raycaster_gradient_ref(rc, volux_technique_param(scene, cls, "gradient_threshold"));
        int ep = (int)volux_technique_param(scene, cls, "env_product");
        if (ep != st->env_product) st->have_shade = 0;
        st->env_product = ep;
        int ds = (int)volux_technique_param(scene, cls, "delta_shadows");
        if (ds != st->delta_shadows) st->have_shade = 0;
        st->delta_shadows = ds;
        st->near_field = (float)volux_technique_param(scene, cls, "near_field");
    }
    if (!st->have_triple) {
        sh_triple_init(&st->triple);
        kdepth_init(st->kdepth);
        st->have_triple = 1;
    }
    if (w & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        st->surface_offset = (float)volux_technique_param(scene, cls, "surface_offset");
        int ratio = (int)volux_technique_param(scene, cls, "downsample");
        st->hc = (float)ratio * rc->min_spacing;
        double sp[3];
        volux_volume_spacing(rc->volume, sp);
        for (int a = 0; a < 3; a++) st->sp_inv[a] = (float)(1.0 / sp[a]);
    }
    sh_projection_params p;
    if ((s = read_projection_params(st, scene, &p))) return s;
    uint64_t ch = p.bleeding ? color_hash(volux_scene_transfer(scene)) : 0;
    int reproject = !st->have_coef || (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) ||
                    memcmp(&p, &st->applied, sizeof p) != 0 || ch != st->applied_color;
    int relight = (w & (VOLUX_CHANGE_LIGHTS | VOLUX_CHANGE_VOLUME)) != 0;
    {
        int on = st->delta_shadows && !p.bleeding && !p.scattering;
        if (on != st->dvis_on) st->have_shade = 0;
        st->dvis_on = on;
    }
    if (reproject) {
        st->have_coef = st->have_shade = 0;
        if (st->coef) volux_free_aligned(rc->ctx, st->coef, st->coef_bytes);
        st->coef = NULL;
        st->coef_bytes = 0;
        /* progressive: the coarse level first (2× coarser grid, ⅛ of the rays) */
        int ratio = p.progressive ? 2 * p.downsample : p.downsample;
        int rays = p.progressive ? (p.rays + 7) / 8 : p.rays;
        if ((s = sh_project(st, &p, ratio, rays, &st->grid, &st->layout, &st->coef, &st->coef_bytes))) return s;
        st->applied = p;
        st->applied_color = ch;
        st->coarse = p.progressive;
        st->have_coef = 1;
        st->projections++;
    }
    if (relight) {
        volux_vec3 centre;
        float radius;
        volux_scene_bounds_sphere(scene, &centre, &radius);
        if ((s = volux_grow_slots(rc->ctx, &st->light_sh, &st->light_sh_cap, volux_scene_light_slots(scene),
                                  sizeof *st->light_sh, "sh: light projections")))
            return s;
        for (int i = 0; i < volux_scene_light_slots(scene); i++) {
            const volux_light_desc *d = volux_scene_light(scene, i);
            if (d && ((w & VOLUX_CHANGE_VOLUME) || volux_change_light(c, i))) {
                if ((s = sh_light_project(rc->ctx, d, centre, st->light_sh[i].c))) return s;
                st->light_projections++;
            }
        }
        memset(st->li, 0, sizeof st->li);
        memset(st->le, 0, sizeof st->le);
        for (int i = 0; i < rc->lights.n_all; i++) {
            int slot = rc->lights.all[i].slot, env = rc->lights.all[i].type == VOLUX_LIGHT_ENVIRONMENT;
            for (int k = 0; k < 3; k++)
                for (int j = 0; j < SH_MAX_COEFFS; j++) {
                    st->li[k][j] += st->light_sh[slot].c[k][j];
                    if (env) st->le[k][j] += st->light_sh[slot].c[k][j];
                }
        }
        st->have_shade = st->have_light_tables = 0;
        surface_lights(st, centre);
    }
    if (!st->have_shade) {
        st->product_on = st->env_product && (st->le[0][0] > 0.0f || st->le[1][0] > 0.0f || st->le[2][0] > 0.0f);
        /* whether the shade/product volumes hold any light (with
         * delta_shadows and only true delta lights they are 0) */
        st->grid_lights = !st->dvis_on;
        for (int k = 0; k < 3; k++) st->grid_lights |= st->rest_sum[k] > 0.0f || st->env_sum[k] > 0.0f;
        if ((s = bake(st))) return s;
        st->have_shade = 1;
    }
    if ((w & (VOLUX_CHANGE_COLOR | VOLUX_CHANGE_VOLUME)) || !st->have_tables) {
        st->have_tables = st->have_light_tables = 0;
        if ((s = prepare_materials(st, scene))) return s;
        st->have_tables = 1;
    }
    if (!st->have_light_tables) {
        for (int i = 0; i < st->n_materials; i++)
            if ((s = sh_material_light_table(rc->ctx, &st->mat[i], (const float(*)[SH_MAX_COEFFS])st->li))) return s;
        st->have_light_tables = 1;
    }
    if (st->any_brdf && !st->have_grad) {
        if ((s = volux_gradient_cache_build(rc->ctx, rc->volume, &st->grad, "sh"))) return s;
        st->have_grad = 1;
    }
    return VOLUX_OK;
}

/* Progressive mode: the full projection replaces the coarse one. */
static volux_status sh_refine(void *state, const volux_scene *scene, int *changed, int *more) {
    (void)scene;
    sh_state *st = state;
    *more = 0;
    if (!st->coarse) return VOLUX_OK;
    sh_grid g;
    sh_layout lay;
    float *coef = NULL;
    size_t bytes = 0;
    volux_status s = sh_project(st, &st->applied, st->applied.downsample, st->applied.rays, &g, &lay, &coef, &bytes);
    if (s) return s; /* the coarse level stays, and renders */
    size_t shade_bytes = g.nodes * 4 * sizeof(float);
    float *shade = volux_alloc_aligned(st->rc.ctx, shade_bytes);
    if (!shade) {
        volux_free_aligned(st->rc.ctx, coef, bytes);
        return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the shade volume");
    }
    size_t pb = prod_bytes(st, &g);
    float *prod = pb ? volux_alloc_aligned(st->rc.ctx, pb) : NULL;
    if (pb && !prod) {
        volux_free_aligned(st->rc.ctx, coef, bytes);
        volux_free_aligned(st->rc.ctx, shade, shade_bytes);
        return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the environment product volume");
    }
    bake_into(st, &g, &lay, coef, shade, prod);
    volux_free_aligned(st->rc.ctx, st->coef, st->coef_bytes);
    if (st->shade) volux_free_aligned(st->rc.ctx, st->shade, st->shade_bytes);
    if (st->prod) volux_free_aligned(st->rc.ctx, st->prod, st->prod_bytes);
    st->grid = g, st->layout = lay;
    st->coef = coef, st->coef_bytes = bytes;
    st->shade = shade, st->shade_bytes = shade_bytes;
    st->prod = prod, st->prod_bytes = pb;
    st->coarse = 0;
    st->projections++;
    *changed = 1;
    return st->dvis_on ? sh_delta_visibility(st) : VOLUX_OK; /* on the new grid */
}

static size_t sh_memory_bytes(const void *state) {
    const sh_state *st = state;
    size_t tables = 0;
    for (int i = 0; i < st->n_materials; i++) {
        if (st->mat[i].table) tables += sizeof *st->mat[i].table * SH_TABLE_THETA;
        if (st->mat[i].light_table) tables += sizeof(float) * 6 * SH_OCTA * SH_OCTA * SH_OCTA * SH_OCTA;
    }
    return st->coef_bytes + st->shade_bytes + st->prod_bytes + st->dvis_bytes + tables + st->grad.bytes +
           sizeof *st->light_sh * (size_t)st->light_sh_cap;
}

static void sh_release(void *state) {
    sh_state *st = state;
    volux_context *ctx = st->rc.ctx;
    if (st->coef) volux_free_aligned(ctx, st->coef, st->coef_bytes);
    if (st->shade) volux_free_aligned(ctx, st->shade, st->shade_bytes);
    if (st->prod) volux_free_aligned(ctx, st->prod, st->prod_bytes);
    st->coef = st->shade = st->prod = NULL;
    st->prod_bytes = 0;
    sh_delta_visibility_free(st);
    free_materials(st);
    volux_gradient_cache_free(ctx, &st->grad);
    volux_free(ctx, st->light_sh, sizeof *st->light_sh * (size_t)st->light_sh_cap);
    st->light_sh = NULL;
    st->light_sh_cap = 0;
}

/* ------------------------------------------------------------------ render */

/* What one camera ray needs: the first factor of Eq. 3 for the TF's phase
 * function and each phase material (constant along the ray), and the
 * outgoing direction's cell of the material–light tables. */
typedef struct sh_ray {
    const sh_state *st;
    float a_def[3];
    float a_mat[SH_MAX_MATERIALS][3];
    int wo_cell[4];
    float wo_w[4];
    /* triple product: albedo·g^l·Y_lm(d) for the TF's phase function and
     * each phase material (∫ p_g(ω·d) F(ω) dω = Σ_lm that · F_lm), and for
     * BRDF materials the first factor over every light */
    float h_def[SH_MAX_COEFFS];
    float h_mat[SH_MAX_MATERIALS][SH_MAX_COEFFS];
    float a_tot[3];
} sh_ray;

/* albedo·∫ p_g(ω·d) L_i(ω) dω per colour = albedo·Σ_l g^l Σ_m L_lm Y_lm(d)
 * (Funk–Hecke with the HG kernel), for the band sums b[c][l] of this ray. */
static inline void phase_factor(float albedo, float g, const float b[3][SH_MAX_BANDS], float out[3]) {
    const float g2 = g * g, gl[SH_MAX_BANDS] = {1.0f, g, g2, g2 * g};
    for (int c = 0; c < 3; c++)
        out[c] = albedo * (b[c][0] + gl[1] * b[c][1] + gl[2] * b[c][2] + gl[3] * b[c][3]);
}

/* Henyey–Greenstein p_g(c), c the cosine between the direction to the
 * light and the camera ray's direction (forward scattering at c = 1),
 * and its 4-band truncation Σ_{l<4} (2l+1)/(4π) g^l P_l(c) — what the
 * Funk–Hecke form below gives for a delta light. */
static inline float hg_exact(float g, float c) {
    float d = 1.0f + g * g - 2.0f * g * c;
    return (1.0f - g * g) / (12.566371f * d * sqrtf(d));
}
static inline float hg_bands(float g, float c) {
    const float p2 = 0.5f * (3.0f * c * c - 1.0f), p3 = 0.5f * c * (5.0f * c * c - 3.0f);
    return (1.0f + g * (3.0f * c + g * (5.0f * p2 + 7.0f * g * p3))) * 0.07957747f;
}

/* Issue 28: the first factor of Eq. 3 for delta lights exactly. At 4
 * bands an HG lobe with g = 0.6 is a quarter of itself in back-scattering
 * (and goes negative, i.e. black after clamping, near 150°) and 0.6 of it
 * forward: the engine's key light came out dark over half the block and
 * its back light too strong relative to it (the blue tint). A delta light
 * contributes E_i·p_g(ω_i·d) exactly; out += albedo·E_i·(p − p₄) swaps
 * its 4-band term for the exact one (the band sums keep every other light). */
static inline void phase_delta_exact(const sh_state *st, float albedo, float g, volux_vec3 d, float out[3]) {
    for (int i = 0; i < st->n_delta; i++) {
        if (!st->delta_exact[i]) continue;
        const float c = v3_dot(st->delta_dir[i], d), f = albedo * (hg_exact(g, c) - hg_bands(g, c));
        for (int k = 0; k < 3; k++) out[k] += f * st->delta_w[i][k];
    }
}

/* Σ_m L_lm Y_lm(d) per colour and band, for the lights li. */
static inline void band_sums(const float li[3][SH_MAX_COEFFS], const float y[SH_MAX_COEFFS],
                             float b[3][SH_MAX_BANDS]) {
    for (int c = 0; c < 3; c++)
        for (int l = 0; l < SH_MAX_BANDS; l++) {
            float s = 0.0f;
            for (int j = l * l; j < (l + 1) * (l + 1); j++) s += li[c][j] * y[j];
            b[c][l] = s;
        }
}

/* albedo·g^l·Y_lm(d): the zonal HG kernel about d (Funk–Hecke). */
static inline void phase_kernel(float albedo, float g, const float y[SH_MAX_COEFFS], float h[SH_MAX_COEFFS]) {
    float gl = albedo;
    for (int l = 0; l < SH_MAX_BANDS; l++, gl *= g)
        for (int j = l * l; j < (l + 1) * (l + 1); j++) h[j] = gl * y[j];
}

/* Bilinear cells of an octahedral table for direction d. */
static void octa_cells(volux_vec3 d, int cell[4], float wgt[4]) {
    float u, v;
    sh_octa_encode(d, &u, &v);
    float x = u * SH_OCTA - 0.5f, y = v * SH_OCTA - 0.5f;
    int x0 = (int)floorf(x), y0 = (int)floorf(y);
    float fx = x - (float)x0, fy = y - (float)y0;
    for (int k = 0; k < 4; k++) {
        int xi = x0 + (k & 1), yi = y0 + (k >> 1);
        xi = xi < 0 ? 0 : xi >= SH_OCTA ? SH_OCTA - 1 : xi;
        yi = yi < 0 ? 0 : yi >= SH_OCTA ? SH_OCTA - 1 : yi;
        cell[k] = yi * SH_OCTA + xi;
        wgt[k] = ((k & 1) ? fx : 1.0f - fx) * ((k >> 1) ? fy : 1.0f - fy);
    }
}

/* The trilinear cell of the coarse grid around fine index q, for records
 * of n floats per node: returns the first corner's offset in floats and
 * fills the eight corner weights and offsets (a one-node axis repeats its
 * node). */
static inline size_t grid_corners(const sh_grid *g, volux_vec3 q, size_t n, float w[8], size_t o[8]) {
    const float inv = 1.0f / (float)g->ratio;
    float x = q.x * inv, y = q.y * inv, z = q.z * inv;
    int i = (int)x, j = (int)y, k = (int)z;
    i = i > g->dims[0] - 2 ? (g->dims[0] > 1 ? g->dims[0] - 2 : 0) : i;
    j = j > g->dims[1] - 2 ? (g->dims[1] > 1 ? g->dims[1] - 2 : 0) : j;
    k = k > g->dims[2] - 2 ? (g->dims[2] > 1 ? g->dims[2] - 2 : 0) : k;
    float fx = x - (float)i, fy = y - (float)j, fz = z - (float)k;
    fx = fx < 0.0f ? 0.0f : fx > 1.0f ? 1.0f : fx;
    fy = fy < 0.0f ? 0.0f : fy > 1.0f ? 1.0f : fy;
    fz = fz < 0.0f ? 0.0f : fz > 1.0f ? 1.0f : fz;
    const size_t sx = g->dims[0] > 1 ? n : 0, sy = g->dims[1] > 1 ? n * (size_t)g->dims[0] : 0,
                 sz = g->dims[2] > 1 ? n * (size_t)g->dims[0] * g->dims[1] : 0;
    const float gx = 1.0f - fx, gy = 1.0f - fy, gz = 1.0f - fz;
    w[0] = gx * gy * gz, w[1] = fx * gy * gz, w[2] = gx * fy * gz, w[3] = fx * fy * gz;
    w[4] = gx * gy * fz, w[5] = fx * gy * fz, w[6] = gx * fy * fz, w[7] = fx * fy * fz;
    o[0] = 0, o[1] = sx, o[2] = sy, o[3] = sx + sy, o[4] = sz, o[5] = sx + sz, o[6] = sy + sz, o[7] = sx + sy + sz;
    return n * (((size_t)k * g->dims[1] + j) * g->dims[0] + i);
}

/* Trilinear S at fine index q: eight weights, then one pass over the
 * four floats of each corner (vectorises). */
static inline void shade_lookup(const sh_state *st, volux_vec3 q, float S[4]) {
    float w[8];
    size_t o[8];
    const float *p = st->shade + grid_corners(&st->grid, q, 4, w, o);
    float acc[4] = {0, 0, 0, 0};
    for (int n = 0; n < 8; n++)
        for (int c = 0; c < 4; c++) acc[c] += w[n] * p[o[n] + c];
    for (int c = 0; c < 4; c++) S[c] = acc[c];
}

/* Trilinear (L_env·L'_mi) at fine index q: 3 × 16 coefficients. */
static inline void prod_lookup(const sh_state *st, volux_vec3 q, float P[3 * SH_MAX_COEFFS]) {
    const size_t n = 3 * SH_MAX_COEFFS;
    float w[8];
    size_t o[8];
    const float *p = st->prod + grid_corners(&st->grid, q, n, w, o);
    for (size_t c = 0; c < n; c++) P[c] = 0.0f;
    for (int m = 0; m < 8; m++)
        for (size_t c = 0; c < n; c++) P[c] += w[m] * p[o[m] + c];
}

enum { SH_MATERIALS = 1, SH_PREINT = 2, SH_PRODUCT = 32 };

/* ∫σt from fine index q along dq (index units per world unit) over dist
 * world units, by the trapezoid rule: fine near q (the light lives in the
 * first voxel of a dense surface), a voxel apart beyond; it stops where
 * σt falls to 0 (the medium ends). */
static inline __attribute__((always_inline)) float depth_out(const sh_state *st, volux_vec3 q, volux_vec3 dq,
                                                             float dist, volux_storage storage) {
    const float h = st->rc.min_spacing;
    float D = 0.0f, t0 = 0.0f, s_prev = sh_sigma_q(st, q.x, q.y, q.z, storage);
    for (float t = 0.25f * h; t0 < dist && s_prev > 0.0f; t = t0 < h ? 2.0f * t : t + h) {
        if (t > dist) t = dist;
        float sv = sh_sigma_q(st, q.x + dq.x * t, q.y + dq.y * t, q.z + dq.z * t, storage);
        D += 0.5f * (s_prev + sv) * (t - t0);
        s_prev = sv, t0 = t;
    }
    return D;
}

/* The point of the segment [q − seg, q] its light leaves from on
 * average: the march shades a segment at its end, in a dense surface its
 * deepest point, while the light leaves from an exponential distribution
 * of depths from its start. With τ ≈ σt(q)·ℓ the segment's optical depth,
 * the emission-weighted mean sits at E[u]/τ of it, E[u] = (1 − (1 + τ)
 * e^{−τ})/(1 − e^{−τ}); *back is the fraction of seg behind q. */
static inline __attribute__((always_inline)) volux_vec3 emission_point(const sh_state *st, volux_vec3 q,
                                                                       volux_vec3 seg, volux_storage storage,
                                                                       float *tau, float *back) {
    *tau = sh_sigma_q(st, q.x, q.y, q.z, storage) * st->rc.step;
    *back = 0.5f;
    if (*tau > 1e-3f) {
        float e = expf(-*tau);
        *back = 1.0f - (1.0f - (1.0f + *tau) * e) / ((1.0f - e) * *tau);
    }
    return v3_madd(q, seg, -*back);
}

/* Issue 28, delta_shadows: transmittance from fine index q towards true
 * delta light i (n: its grid): the first near_field cells marched at the
 * volume's resolution, the per-node grid (deltavis.c) read beyond — read
 * at q itself, nodes on the lit side of a thin plate would light q. */
static inline __attribute__((always_inline)) float delta_transmittance(const sh_state *st, volux_vec3 q, int i,
                                                                       int n) {
    const volux_prepared_light *l = &st->rc.lights.all[st->delta_light[i]];
    const volux_volume *v = st->rc.volume;
    volux_vec3 w = v3_scale(l->travel, -1.0f);
    float dist = INFINITY, fall = 1.0f;
    if (l->positional) {
        volux_vec3 p = v3(v->origin.x + q.x * (float)v->spacing[0], v->origin.y + q.y * (float)v->spacing[1],
                          v->origin.z + q.z * (float)v->spacing[2]);
        volux_vec3 to = v3_sub(l->pos, p);
        dist = v3_length(to);
        if (!(dist > 0.0f)) return 1.0f;
        w = v3_scale(to, 1.0f / dist);
        /* the light's weights are its probe's, seen from the volume's
         * centre: the 1/d² (and spot) falloff to this sample relative to
         * the centre's (the engine's point light behind it is 220 units
         * from the centre, the block's back 100) */
        if (st->delta_e0[i] > 0.0f) {
            volux_vec3 tr, e = volux_light_irradiance(l, p, &tr);
            fall = (e.x + e.y + e.z) / st->delta_e0[i];
        }
    }
    const volux_vec3 dq = v3(w.x * st->sp_inv[0], w.y * st->sp_inv[1], w.z * st->sp_inv[2]);
    float L = st->near_field * st->hc, exit = INFINITY;
    const float qa[3] = {q.x, q.y, q.z}, da[3] = {dq.x, dq.y, dq.z};
    for (int a = 0; a < 3; a++) {
        if (da[a] > 1e-12f) exit = fminf(exit, ((float)(v->dims[a] - 1) - qa[a]) / da[a]);
        else if (da[a] < -1e-12f) exit = fminf(exit, -qa[a] / da[a]);
    }
    if (exit < 0.0f) exit = 0.0f;
    const int far = L < dist && L < exit;
    if (!far) L = fminf(dist, exit);
    float T = fall * expf(-sh_tau_segment(st, q, dq, L));
    if (!far || !(T > 1e-6f)) return T;
    float wg[8];
    size_t o[8];
    const float *g = st->dvis + (size_t)n * st->grid.nodes;
    g += grid_corners(&st->grid, v3_madd(q, dq, L), 1, wg, o);
    float tg = 0.0f;
    for (int c = 0; c < 8; c++) tg += wg[c] * g[o[c]];
    return T * tg;
}

/* Issue 28. On a surface (a jump of σt across a coefficient cell) the
 * sample at q reads the grid at qr = q + w·surface_offset·h_c·n, n the
 * outward normal (−∇σt), w = min(1, |∇σt|·h_c²)·(1 − e^{−max σt·h})²
 * (h: a voxel) — where the nodes around
 * qr cast their rays from the empty side and hold the surface's far
 * visibility — and the light between q and qr is taken from the fine
 * volume: D = ∫σt along the offset, and per light direction ω the
 * half-space transmittance K_D(ω·n) = e^{−D/(ω·n)}, 1 − w into the
 * material (on a surface the material below blocks; the grid's nodes hold
 * 1 there, project.c, so their 4 bands carry the smooth far field and the
 * terminator is exact for delta lights). Ad: the weighted K of the lights S stands
 * for (delta lights exactly; environments without the triple product by
 * Funk–Hecke); Ae: the environments' (triple product). Returns 0 (qr = q,
 * Ad = Ae = 1) off surfaces. */
static inline __attribute__((always_inline)) int near_surface(const sh_state *st, volux_vec3 q, volux_vec3 seg,
                                                              volux_storage storage, volux_vec3 *qr, float Ad[3],
                                                              float Ae[3]) {
    const int *dm = st->rc.volume->dims;
    /* The march shades a segment [q − seg, q] at its end; in a dense
     * surface that is its deepest point, while the light leaves from an
     * exponential distribution of depths from its start. With τ ≈ σt(q)·ℓ
     * the segment's optical depth, the emission-weighted mean sits at
     * E[u]/τ of it, E[u] = (1 − (1 + τ)e^{−τ})/(1 − e^{−τ}); the delta
     * lights below average K over that distribution exactly. */
    const volux_vec3 qb = q, qa = v3_sub(q, seg);
    float tau, back;
    q = emission_point(st, q, seg, storage, &tau, &back);
    /* central differences half a coefficient cell either side: a sample
     * up to that deep below a sharp surface still sees it (a one-voxel
     * stencil reads 0 just inside, where the light is) */
    const float rs = 0.5f * (float)st->grid.ratio;
    float g[3], smax = 0.0f;
    for (int a = 0; a < 3; a++) {
        float lo[3] = {q.x, q.y, q.z}, hi[3] = {q.x, q.y, q.z};
        lo[a] -= rs, hi[a] += rs;
        float sh = sh_sigma_q(st, hi[0], hi[1], hi[2], storage), sl = sh_sigma_q(st, lo[0], lo[1], lo[2], storage);
        g[a] = (sh - sl) * st->sp_inv[a] / (2.0f * rs);
        smax = sh > smax ? sh : smax;
        smax = sl > smax ? sl : smax;
    }
    float gl = sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    /* w: a jump of σt·h_c across a cell into a medium that is opaque
     * within a voxel (a translucent cloud keeps the grid's own
     * below-surface light: its half-space model would darken it) */
    float wgt = gl * st->hc * st->hc;
    if (wgt > 1.0f) wgt = 1.0f;
    const float oh = 1.0f - expf(-smax * st->rc.min_spacing);
    wgt *= oh * oh;
    if (!(wgt > 1e-3f)) return 0;
    volux_vec3 n = v3(-g[0] / gl, -g[1] / gl, -g[2] / gl); /* world, out of the material */
    const float dist = wgt * st->surface_offset * st->hc;
    volux_vec3 dq = v3(n.x * st->sp_inv[0], n.y * st->sp_inv[1], n.z * st->sp_inv[2]); /* per world unit */
    /* optical depth along n out of the medium from the segment's ends */
    const float Da = depth_out(st, qa, dq, dist, storage), Db = depth_out(st, qb, dq, dist, storage);
    const float D = Da + (1.0f - back) * (Db - Da); /* at the mean */
    volux_vec3 r = v3_madd(q, dq, dist);
    r.x = r.x < 0.0f ? 0.0f : r.x > (float)(dm[0] - 1) ? (float)(dm[0] - 1) : r.x;
    r.y = r.y < 0.0f ? 0.0f : r.y > (float)(dm[1] - 1) ? (float)(dm[1] - 1) : r.y;
    r.z = r.z < 0.0f ? 0.0f : r.z > (float)(dm[2] - 1) ? (float)(dm[2] - 1) : r.z;
    *qr = r;
    /* delta lights: K_D(μ) = e^{−D/μ} averaged over the emission along the
     * segment, D = Da + u·ΔD/τ, u ~ e^{−u} on [0, τ]:
     * e^{−Da/μ}·(1 − e^{−τ(1+ρ)})/((1 + ρ)(1 − e^{−τ})), ρ = ΔD/(τμ) */
    const float dD = Db > Da ? Db - Da : 0.0f, eT = expf(-tau);
    float kd[3] = {0, 0, 0};
    for (int i = 0; i < st->n_delta; i++) {
        if (st->dvis_on && st->delta_exact[i]) continue; /* shadowed by delta_transmittance */
        float mu = v3_dot(n, st->delta_dir[i]), K = 1.0f - wgt;
        if (mu > 0.0f) {
            float im = 1.0f / mu;
            if (tau > 1e-3f) {
                float rho = dD * im / tau;
                K = expf(-Da * im) * (1.0f - eT * expf(-tau * rho)) / ((1.0f + rho) * (1.0f - eT));
            } else
                K = expf(-D * im);
        }
        for (int k = 0; k < 3; k++) kd[k] += st->delta_w[i][k] * K;
    }
    /* environments: Funk–Hecke with λ_l(D) */
    float ke[3] = {0, 0, 0};
    if (st->env_sum[0] > 0.0f || st->env_sum[1] > 0.0f || st->env_sum[2] > 0.0f) {
        float u = D * ((float)(SH_KD_N - 1) / SH_KD_MAX), y[SH_MAX_COEFFS], lam[SH_MAX_BANDS];
        int i0 = u >= (float)(SH_KD_N - 1) ? SH_KD_N - 2 : (int)u;
        float f = u - (float)i0;
        if (f > 1.0f) f = 1.0f;
        /* 2π ∫_{−1}^0 P_l */
        static const float lower[SH_MAX_BANDS] = {6.2831853f, -3.1415927f, 0.0f, 0.78539816f};
        for (int l = 0; l < SH_MAX_BANDS; l++)
            lam[l] = st->kdepth[i0][l] + f * (st->kdepth[i0 + 1][l] - st->kdepth[i0][l]) + (1.0f - wgt) * lower[l];
        sh_eval(4, n, y);
        for (int k = 0; k < 3; k++) {
            float acc = 0.0f;
            for (int l = 0; l < SH_MAX_BANDS; l++) {
                float b = 0.0f;
                for (int j = l * l; j < (l + 1) * (l + 1); j++) b += st->le[k][j] * y[j];
                acc += lam[l] * b;
            }
            ke[k] = acc > 0.0f ? acc : 0.0f;
        }
    }
    for (int k = 0; k < 3; k++) {
        const float ds = st->dvis_on ? st->rest_sum[k] : st->delta_sum[k];
        float de = st->product_on ? ds : ds + st->env_sum[k];
        float nu = st->product_on ? kd[k] : kd[k] + ke[k];
        Ad[k] = de > 1e-20f ? nu / de : 1.0f;
        Ae[k] = st->env_sum[k] > 1e-20f ? ke[k] / st->env_sum[k] : 1.0f;
    }
    return 1;
}

/* storage in bits 2–4 */
#define SH_VARIANT(mat, preint, storage, product)                                                                  \
    ((mat) | (preint) << 1 | (int)(storage) << 2 | ((product) ? SH_PRODUCT : 0))
#define SH_STORAGE(variant) ((volux_storage)(((variant) >> 2) & 7))

static inline __attribute__((always_inline)) float sample_at(const void *tech, const volux_ray *r, float t,
                                                              int variant) {
    const sh_ray *ry = tech;
    return volux_volume_sample_bricked(ry->st->rc.volume, r->q0.x + r->dq.x * t, r->q0.y + r->dq.y * t,
                                       r->q0.z + r->dq.z * t, SH_STORAGE(variant));
}

static inline __attribute__((always_inline)) void shade_at(const void *tech, const volux_ray *ray, float t,
                                                            float c[3], int variant) {
    const sh_ray *ry = tech;
    const sh_state *st = ry->st;
    volux_vec3 q = v3_madd(ray->q0, ray->dq, t), qr = q;
    float S[4] = {0, 0, 0, 0}, P[3 * SH_MAX_COEFFS], Ad[3] = {1, 1, 1}, Ae[3] = {1, 1, 1};
    const volux_vec3 seg = v3_scale(ray->dq, st->rc.step);
    if (st->grid_lights) {
        if (st->surface_offset > 0.0f) near_surface(st, q, seg, SH_STORAGE(variant), &qr, Ad, Ae);
        shade_lookup(st, qr, S);
        for (int k = 0; k < 3; k++) S[k] *= Ad[k];
    }
    if (st->n_dvis) {
        /* the segment [q − seg, q] is shaded at its end, in a dense surface
         * its deepest point; its light leaves from depths u ~ e^{−u} on
         * [0, τ]. With the optical depths D_a, D_b towards the light from
         * its ends (linear between), the mean transmittance is
         * e^{−D_a}·(1 − e^{−τ(1+ρ)})/((1 + ρ)(1 − e^{−τ})), ρ = (D_b − D_a)/τ
         * (as near_surface's half-space term) */
        const volux_vec3 qa = v3_sub(q, seg);
        const float tau = sh_sigma_q(st, q.x, q.y, q.z, SH_STORAGE(variant)) * st->rc.step, eT = expf(-tau);
        for (int n = 0; n < st->n_dvis; n++) {
            const int i = st->dvis_light[n];
            const float Ta = delta_transmittance(st, qa, i, n), Tb = delta_transmittance(st, q, i, n);
            float T = 0.5f * (Ta + Tb);
            if (tau > 1e-3f && Ta > 0.0f) {
                const float dD = Tb < Ta ? logf(Ta / fmaxf(Tb, 1e-30f)) : 0.0f, rho = dD / tau;
                T = Ta * (1.0f - eT * expf(-tau * rho)) / ((1.0f + rho) * (1.0f - eT));
            }
            for (int k = 0; k < 3; k++) S[k] += st->dvis_w[i][k] * T;
        }
    }
    if (variant & SH_PRODUCT) {
        prod_lookup(st, qr, P);
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < SH_MAX_COEFFS; j++) P[k * SH_MAX_COEFFS + j] *= Ae[k];
    }
    const float *a = ry->a_def, *h = ry->h_def;
    if (variant & SH_MATERIALS) {
        float sv = volux_volume_sample_bricked(st->rc.volume, q.x, q.y, q.z, SH_STORAGE(variant));
        const volux_transfer_lut *lut = st->rc.lut;
        float u = (sv - lut->s_min) * lut->inv_ds;
        int e = u <= 0.0f ? 0 : u >= 4095.0f ? 4095 : (int)(u + 0.5f);
        int mi = st->mat_index[e];
        if (mi != 255) {
            const sh_material *m = &st->mat[mi];
            if (!m->brdf) a = ry->a_mat[mi], h = ry->h_mat[mi];
            else {
                volux_vec3 n;
                float f = volux_shading_normal(volux_gradient_cache_sample(&st->grad, st->rc.volume, q), st->grad_ref,
                                               ray->d, &n);
                if (f > 0.0f) {
                    int nc[4];
                    float nw[4], F[6] = {0, 0, 0, 0, 0, 0};
                    octa_cells(n, nc, nw);
                    for (int p = 0; p < 4; p++)
                        for (int o = 0; o < 4; o++) {
                            const float *tb =
                                m->light_table + 6 * ((size_t)nc[p] * SH_OCTA * SH_OCTA + (size_t)ry->wo_cell[o]);
                            float wgt = nw[p] * ry->wo_w[o];
                            for (int k = 0; k < 6; k++) F[k] += wgt * tb[k];
                        }
                    for (int k = 0; k < 3; k++) {
                        float Sk = S[k];
                        if (variant & SH_PRODUCT) {
                            /* the split over every light: S of all of them
                             * from S of the delta lights and ∫ L_env L'_mi =
                             * √(4π)·(L_env L'_mi)_00 */
                            const float *ld = st->li[k];
                            float Ed = 3.5449077f * (ld[0] - st->le[k][0]), Et = 3.5449077f * ld[0];
                            Sk = Et > 1e-12f ? (Ed * S[k] + 3.5449077f * P[k * SH_MAX_COEFFS]) / Et : 0.0f;
                        }
                        float lit = f * (c[k] * F[k] + F[3 + k]) + (1.0f - f) * c[k] * ry->a_tot[k];
                        c[k] = fmaxf(lit * Sk, 0.0f);
                    }
                    return;
                }
            }
        }
    }
    if (variant & SH_PRODUCT) {
        for (int k = 0; k < 3; k++) {
            float e = 0.0f;
            for (int j = 0; j < SH_MAX_COEFFS; j++) e += h[j] * P[k * SH_MAX_COEFFS + j];
            c[k] = fmaxf(c[k] * (a[k] * S[k] + e), 0.0f);
        }
        return;
    }
    for (int k = 0; k < 3; k++) c[k] = fmaxf(c[k] * a[k] * S[k], 0.0f);
}

static inline __attribute__((always_inline)) volux_vec3 integrate(const void *tech, const volux_ray *ray,
                                                                   float jitter, float *T, uint64_t *samples,
                                                                   int variant) {
    const sh_state *st = tech;
    sh_ray ry;
    ry.st = st;
    float b[3][SH_MAX_BANDS], y[SH_MAX_COEFFS];
    sh_eval(4, ray->d, y);
    if (variant & SH_PRODUCT) {
        float ld[3][SH_MAX_COEFFS];
        delta_lights(st, ld);
        band_sums((const float(*)[SH_MAX_COEFFS])ld, y, b);
        phase_kernel(st->rc.albedo, st->rc.g, y, ry.h_def);
    } else {
        band_sums((const float(*)[SH_MAX_COEFFS])st->li, y, b);
    }
    phase_factor(st->rc.albedo, st->rc.g, b, ry.a_def);
    phase_delta_exact(st, st->rc.albedo, st->rc.g, ray->d, ry.a_def);
    if (variant & SH_MATERIALS) {
        for (int i = 0; i < st->n_materials; i++)
            if (!st->mat[i].brdf) {
                phase_factor(st->rc.albedo, st->mat[i].g, b, ry.a_mat[i]);
                phase_delta_exact(st, st->rc.albedo, st->mat[i].g, ray->d, ry.a_mat[i]);
                if (variant & SH_PRODUCT) phase_kernel(st->rc.albedo, st->mat[i].g, y, ry.h_mat[i]);
            }
        if (variant & SH_PRODUCT) {
            float bt[3][SH_MAX_BANDS];
            band_sums((const float(*)[SH_MAX_COEFFS])st->li, y, bt);
            phase_factor(st->rc.albedo, st->rc.g, bt, ry.a_tot);
            phase_delta_exact(st, st->rc.albedo, st->rc.g, ray->d, ry.a_tot);
        } else {
            for (int k = 0; k < 3; k++) ry.a_tot[k] = ry.a_def[k];
        }
        octa_cells(v3_scale(ray->d, -1.0f), ry.wo_cell, ry.wo_w);
    }
    const volux_ea_march_desc m = {st->rc.lut, st->skip_empty ? &st->rc.grid : NULL, st->rc.step, st->t_min};
    return volux_ea_march(&m, &ry, ray, jitter, T, samples, (variant & SH_PREINT) != 0, sample_at, shade_at, variant);
}

static inline __attribute__((always_inline)) void tile_as(const sh_state *st, const volux_scene *scene,
                                                           const volux_tile *tile, float *rgb,
                                                           volux_tile_stats *stats, int mat, int preint, int prod) {
    switch (st->rc.volume->storage) {
    case VOLUX_STORE_U8:
        volux_raycaster_tile(&st->rc, st, scene, tile, rgb, stats, integrate,
                             SH_VARIANT(mat, preint, VOLUX_STORE_U8, prod));
        break;
    case VOLUX_STORE_U16:
        volux_raycaster_tile(&st->rc, st, scene, tile, rgb, stats, integrate,
                             SH_VARIANT(mat, preint, VOLUX_STORE_U16, prod));
        break;
    default:
        volux_raycaster_tile(&st->rc, st, scene, tile, rgb, stats, integrate,
                             SH_VARIANT(mat, preint, VOLUX_STORE_F32, prod));
        break;
    }
}

static void sh_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                           volux_tile_stats *stats) {
    const sh_state *st = state;
    int mat = st->n_materials > 0, prod = st->product_on && st->prod;
    if (prod) {
        if (mat && st->preintegrate) tile_as(st, scene, tile, rgb, stats, 1, 1, 1);
        else if (mat) tile_as(st, scene, tile, rgb, stats, 1, 0, 1);
        else if (st->preintegrate) tile_as(st, scene, tile, rgb, stats, 0, 1, 1);
        else tile_as(st, scene, tile, rgb, stats, 0, 0, 1);
    } else if (mat && st->preintegrate) tile_as(st, scene, tile, rgb, stats, 1, 1, 0);
    else if (mat) tile_as(st, scene, tile, rgb, stats, 1, 0, 0);
    else if (st->preintegrate) tile_as(st, scene, tile, rgb, stats, 0, 1, 0);
    else tile_as(st, scene, tile, rgb, stats, 0, 0, 0);
}

const volux_technique_class volux_sh_class = {
    {"sh", "light-material interaction with spherical harmonics (Lindemann & Ropinski 2010)", sh_params, 0},
    sizeof(sh_state), 0, 0,
    NULL, sh_update, sh_render_tile, sh_memory_bytes, sh_release, sh_refine,
    NULL, NULL, /* no pending-work measure, no statistics */
    NULL, /* no bricks: its light leaves the camera ray (scattering, shadows) */
    NULL, /* no per-frame budget (volux_technique_set_budget) */
    volux_sh_estimate_bytes,
    NULL, /* nothing per pass */
};
