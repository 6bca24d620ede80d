/*
 * techniques/sh/material.c — material functions M (Lindemann & Ropinski
 * 2010, §4.3) projected into SH, and their product with the light probe.
 *
 * M(ω_i, ω_o) = f_r(ω_i, ω_o)·max(n·ω_i, 0) for the BRDFs (the paper
 * projects M over the hemisphere; the cosine makes it the reflected
 * radiance), split into a diffuse part, tinted by the TF colour, and a
 * specular part (white; measured MERL data carries its own colour):
 *
 *   lambert            f_d = kd/π
 *   blinn_phong        + ks·(n+8)/(8π)·(n·h)^n              (normalised)
 *   ashikhmin_shirley  Ashikhmin & Shirley 2000, isotropic (n_u = n_v =
 *                      shininess), R_d = kd, R_s = f0, specular × ks
 *   cook_torrance      f_d = kd/π, ks·D·F·G/(4 (n·ω_i)(n·ω_o)), Beckmann
 *                      D with slope `roughness`, Schlick F(f0), the
 *                      V-cavity G of Cook & Torrance 1982
 *   merl               the measured BRDF (io/merl.h)
 *
 * Tables: for SH_TABLE_THETA outgoing angles θ_o (φ_o = 0; the BRDFs are
 * isotropic, so another φ_o is a rotation about z), the SH of M(·, ω_o)
 * by midpoint quadrature over the hemisphere, 48 × 96 cells. The
 * material–light table then holds F(n, ω_o) = ∫ M L_i dω_i = m(ω_o)·L_i
 * in n's frame (the product integral, Eq. 3) on octahedral grids of
 * normals and outgoing directions, rebuilt when a light changes.
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "io/merl.h"
#include "sh.h"

#define PI_D 3.14159265358979323846
#define QU 48
#define QP 96

static double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

void sh_material_eval(const volux_tf_material *t, const void *merl, const double wi[3], const double wo[3],
                      double *diffuse, double spec[3]) {
    *diffuse = 0.0;
    spec[0] = spec[1] = spec[2] = 0.0;
    double ci = wi[2], co = wo[2];
    if (ci <= 0.0 || co <= 0.0) return;
    double h[3] = {wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]}, hl = sqrt(dot3(h, h));
    for (int a = 0; a < 3; a++) h[a] /= hl;
    double nh = h[2], kh = dot3(wi, h), s = 0.0;
    switch (t->kind) {
    case VOLUX_MATERIAL_LAMBERT: *diffuse = t->diffuse / PI_D; break;
    case VOLUX_MATERIAL_BLINN_PHONG:
        *diffuse = t->diffuse / PI_D;
        s = t->specular * (t->shininess + 8.0) / (8.0 * PI_D) * pow(nh, t->shininess);
        break;
    case VOLUX_MATERIAL_ASHIKHMIN_SHIRLEY: {
        double rs = t->f0;
        *diffuse = 28.0 * t->diffuse / (23.0 * PI_D) * (1.0 - rs) * (1.0 - pow(1.0 - ci / 2.0, 5.0)) *
                   (1.0 - pow(1.0 - co / 2.0, 5.0));
        double F = rs + (1.0 - rs) * pow(1.0 - kh, 5.0);
        s = t->specular * (t->shininess + 1.0) / (8.0 * PI_D) * pow(nh, t->shininess) / (kh * fmax(ci, co)) * F;
        break;
    }
    case VOLUX_MATERIAL_COOK_TORRANCE: {
        *diffuse = t->diffuse / PI_D;
        double m2 = (double)t->roughness * t->roughness, c2 = nh * nh;
        double D = exp((c2 - 1.0) / (c2 * m2)) / (PI_D * m2 * c2 * c2);
        double G = fmin(1.0, fmin(2.0 * nh * co / kh, 2.0 * nh * ci / kh));
        double F = t->f0 + (1.0 - t->f0) * pow(1.0 - kh, 5.0);
        s = t->specular * D * F * G / (4.0 * ci * co);
        break;
    }
    case VOLUX_MATERIAL_MERL:
        if (merl) volux_merl_eval(merl, wi, wo, spec);
        for (int c = 0; c < 3; c++) spec[c] *= ci;
        return;
    default: return;
    }
    *diffuse *= ci;
    spec[0] = spec[1] = spec[2] = s * ci;
}

volux_status sh_material_prepare(volux_context *ctx, const volux_tf_material *t, sh_material *m) {
    memset(m, 0, sizeof *m);
    m->kind = (int)t->kind;
    m->g = t->g;
    m->brdf = t->kind != VOLUX_MATERIAL_PHASE;
    if (!m->brdf) return VOLUX_OK;
    volux_merl merl = {{0, 0, 0}, NULL, 0};
    volux_status s;
    if (t->kind == VOLUX_MATERIAL_MERL && (s = volux_merl_load(ctx, t->file, &merl))) return s;
    size_t bytes = sizeof *m->table * SH_TABLE_THETA;
    m->table = volux_calloc(ctx, 1, bytes);
    if (!m->table) {
        volux_merl_free(ctx, &merl);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "sh: out of memory for a material table");
    }
    double cell = (1.0 / QU) * (2.0 * PI_D / QP);
    for (int k = 0; k < SH_TABLE_THETA; k++) {
        double th = 0.5 * PI_D * k / (SH_TABLE_THETA - 1);
        double wo[3] = {sin(th), 0.0, cos(th)};
        double acc[4][SH_MAX_COEFFS];
        memset(acc, 0, sizeof acc);
        for (int i = 0; i < QU; i++) {
            double u = (i + 0.5) / QU, sr = sqrt(1.0 - u * u);
            for (int p = 0; p < QP; p++) {
                double ph = (p + 0.5) * 2.0 * PI_D / QP;
                double wi[3] = {sr * cos(ph), sr * sin(ph), u}, d, sp[3];
                sh_material_eval(t, merl.rgb ? &merl : NULL, wi, wo, &d, sp);
                float y[SH_MAX_COEFFS];
                sh_eval(4, v3((float)wi[0], (float)wi[1], (float)wi[2]), y);
                for (int j = 0; j < SH_MAX_COEFFS; j++) {
                    acc[0][j] += d * y[j];
                    for (int c = 0; c < 3; c++) acc[1 + c][j] += sp[c] * y[j];
                }
            }
        }
        for (int q = 0; q < 4; q++)
            for (int j = 0; j < SH_MAX_COEFFS; j++) m->table[k][q][j] = (float)(acc[q][j] * cell);
    }
    volux_merl_free(ctx, &merl);
    return VOLUX_OK;
}

void sh_material_free(volux_context *ctx, sh_material *m) {
    if (m->table) volux_free(ctx, m->table, sizeof *m->table * SH_TABLE_THETA);
    if (m->light_table) volux_free(ctx, m->light_table, sizeof(float) * 6 * SH_OCTA * SH_OCTA * SH_OCTA * SH_OCTA);
    m->table = NULL;
    m->light_table = NULL;
}

/* Rotates SH coefficients about +z by φ (the function turns by +φ). */
static void rotate_z(float *c, float phi) {
    for (int l = 1; l < SH_MAX_BANDS; l++)
        for (int m = 1; m <= l; m++) {
            float cs = cosf((float)m * phi), sn = sinf((float)m * phi);
            float *p = &c[l * (l + 1) + m], *q = &c[l * (l + 1) - m];
            float a = *p, b = *q;
            *p = cs * a - sn * b;
            *q = sn * a + cs * b;
        }
}

volux_status sh_material_light_table(volux_context *ctx, sh_material *m, const float li[3][SH_MAX_COEFFS]) {
    if (!m->brdf) return VOLUX_OK;
    enum { G = SH_OCTA };
    size_t bytes = sizeof(float) * 6 * G * G * G * G;
    if (!m->light_table && !(m->light_table = volux_malloc(ctx, bytes)))
        return volux_error(ctx, VOLUX_ERR_NOMEM, "sh: out of memory for a material–light table");
    for (int a = 0; a < G * G; a++) {
        volux_vec3 n = sh_octa_decode(((a % G) + 0.5f) / G, ((a / G) + 0.5f) / G), t, b;
        v3_basis(n, &t, &b);
        double r[9] = {t.x, t.y, t.z, b.x, b.y, b.z, n.x, n.y, n.z};
        sh_rotation rot;
        sh_rotation_from_matrix(r, 4, &rot);
        float loc[3][SH_MAX_COEFFS];
        for (int c = 0; c < 3; c++) sh_rotate(&rot, li[c], loc[c]);
        for (int o = 0; o < G * G; o++) {
            float *F = m->light_table + 6 * ((size_t)a * G * G + o);
            volux_vec3 wo = sh_octa_decode(((o % G) + 0.5f) / G, ((o / G) + 0.5f) / G);
            volux_vec3 wl = v3(v3_dot(t, wo), v3_dot(b, wo), v3_dot(n, wo));
            memset(F, 0, 6 * sizeof(float));
            if (wl.z <= 0.0f) continue;
            float th = acosf(fminf(wl.z, 1.0f)) / (0.5f * VOLUX_PI) * (SH_TABLE_THETA - 1);
            int k0 = (int)th;
            if (k0 > SH_TABLE_THETA - 2) k0 = SH_TABLE_THETA - 2;
            float f = th - (float)k0, coef[4][SH_MAX_COEFFS];
            for (int q = 0; q < 4; q++) {
                for (int j = 0; j < SH_MAX_COEFFS; j++)
                    coef[q][j] = m->table[k0][q][j] + (m->table[k0 + 1][q][j] - m->table[k0][q][j]) * f;
                rotate_z(coef[q], atan2f(wl.y, wl.x));
            }
            for (int c = 0; c < 3; c++) {
                F[c] = sh_dot(4, coef[0], loc[c]);
                F[3 + c] = sh_dot(4, coef[1 + c], loc[c]);
            }
        }
    }
    return VOLUX_OK;
}
