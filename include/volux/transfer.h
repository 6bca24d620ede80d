/*
 * volux/transfer.h — transfer functions: scalar → extinction, colour, albedo.
 *
 * Control points are piecewise linear in the scalar s (file units) and clamp
 * to their end values outside, as in ParaView/VTK. Opacity α is per
 * `opacity_unit_distance` u world units and becomes extinction
 * σt = −ln(1 − min(α, 0.9999)) / u; or extinction is given directly
 * (DESIGN §2). `density_scale` multiplies σt; scattering σs = albedo·c·σt.
 *
 * volux_transfer_bake() turns a description into lookup tables over the
 * volume's value range: σt(s), c(s), and their running integrals for
 * pre-integrated segments (Engel et al. 2001, with the 1-D integral tables of
 * Lum et al. 2004), so a narrow opacity peak crossed between two samples is
 * still accounted for.
 *
 * DOES NOT: own a volume, shade, or know cameras.
 */
#ifndef VOLUX_TRANSFER_H
#define VOLUX_TRANSFER_H

#include "base.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VOLUX_TF_MAX_POINTS 65536
/* Largest extinction a baked table holds (1/world unit): σt·density_scale
 * is clamped to it, so optical depths, their running integrals and every
 * product with a length stay finite (a free path of 1e-30 units is opaque
 * at any scale a volume has). */
#define VOLUX_SIGMA_T_MAX 1e30f

typedef struct volux_tf_color_point {
    float s, r, g, b;
} volux_tf_color_point;

typedef struct volux_tf_scalar_point {
    float s, v;
} volux_tf_scalar_point;

/* Blinn–Phong material for gradient shading (same keys as the peers' TF
 * JSON: ambient, diffuse, specular, specular_power). */
typedef struct volux_material {
    float ambient, diffuse, specular, specular_power;
} volux_material;

/* The material channel (read by `sh`): the reflectance or phase function
 * of the scalars in [s0, s1] (file units, inclusive; the first range that
 * contains a scalar wins, scalars in no range keep the TF's own phase
 * function). BRDFs act where the field looks like a surface (its gradient),
 * phase functions everywhere (Lindemann & Ropinski 2010, §4.3). */
typedef enum volux_material_kind {
    VOLUX_MATERIAL_PHASE,             /* Henyey–Greenstein, anisotropy g     */
    VOLUX_MATERIAL_LAMBERT,           /* diffuse                             */
    VOLUX_MATERIAL_BLINN_PHONG,       /* normalised Blinn–Phong lobe         */
    VOLUX_MATERIAL_ASHIKHMIN_SHIRLEY, /* Ashikhmin & Shirley 2000, isotropic */
    VOLUX_MATERIAL_COOK_TORRANCE,     /* Beckmann, Schlick Fresnel           */
    VOLUX_MATERIAL_MERL               /* measured (Matusik et al. 2003)      */
} volux_material_kind;

#define VOLUX_TF_MAX_MATERIALS 16
#define VOLUX_MATERIAL_PATH_MAX 1024

typedef struct volux_tf_material {
    float s0, s1;           /* scalar range, s0 <= s1                       */
    volux_material_kind kind;
    float g;                /* phase: HG anisotropy in (−1, 1)              */
    float diffuse;          /* BRDFs: diffuse weight kd (× TF colour)      */
    float specular;         /* BRDFs: specular weight ks (white)           */
    float shininess;        /* Blinn–Phong, Ashikhmin–Shirley exponent     */
    float roughness;        /* Cook–Torrance RMS slope m in (0, 1]         */
    float f0;               /* Fresnel reflectance at normal incidence     */
    char file[VOLUX_MATERIAL_PATH_MAX]; /* MERL: the .binary file          */
} volux_tf_material;

/* Defaults for a kind: range [0, 0], g 0, kd 0.7, ks 0.3, shininess 32,
 * roughness 0.3, f0 0.04, no file. */
VOLUX_API void volux_tf_material_defaults(volux_tf_material *m, volux_material_kind kind);
/* "phase", "lambert", "blinn_phong", "ashikhmin_shirley", "cook_torrance", "merl". */
VOLUX_API const char *volux_material_kind_name(volux_material_kind k);
/* 1 if a and b describe the same material. */
VOLUX_API int volux_tf_material_equal(const volux_tf_material *a, const volux_tf_material *b);

typedef struct volux_transfer_desc {
    const volux_tf_color_point *color; /* borrowed; sorted by s          */
    int n_color;                       /* 0 = white                       */
    const volux_tf_scalar_point *opacity; /* borrowed; sorted by s; α or σt */
    int n_opacity;                     /* ≥ 1                             */
    int extinction;                    /* 1: opacity[] holds σt (1/world) */
    float opacity_unit_distance;       /* u; 0 = smallest spacing         */
    float density_scale;               /* multiplies σt (≥ 0)             */
    float albedo;                      /* in [0,1]                        */
    float anisotropy;                  /* HG g in (−1,1)                  */
    volux_material material;
    const volux_tf_material *materials; /* borrowed; the material channel */
    int n_materials;                   /* 0..VOLUX_TF_MAX_MATERIALS      */
} volux_transfer_desc;

/* Fills the defaults: white, density_scale 1, albedo 0.9 (DESIGN §3 example),
 * anisotropy 0, material (0.2, 0.7, 0.3, 30) as in the peers' TFs, no
 * material channel. */
VOLUX_API void volux_transfer_desc_defaults(volux_transfer_desc *d);

/* Validates a description: point counts, sorted s, finite values, α in
 * [0,1], σt ≥ 0, colours in [0,1], albedo in [0,1], |g| < 1, the material
 * channel's ranges and parameters. On failure sets
 * a message naming the field (e.g. "opacity[3]: s must not decrease"). */
VOLUX_API volux_status volux_transfer_desc_validate(volux_context *ctx, const volux_transfer_desc *d);

/* Piecewise-linear evaluation of the control points (clamped). */
VOLUX_API float volux_tf_eval_scalar(const volux_tf_scalar_point *p, int n, float s);
VOLUX_API void volux_tf_eval_color(const volux_tf_color_point *p, int n, float s, float rgb[3]);

/* A baked transfer function: tables of `n` entries over [s_min, s_max].
 * Entries are node samples: entry i is at s_min + i·(s_max−s_min)/(n−1).
 * Read-only after baking; safe to share between threads.
 * (The scene's internal representation, public for techniques and tests:
 * its layout may change in any 0.x MINOR release, docs/API.md.) */
typedef struct volux_transfer_lut {
    int n;
    float s_min, s_max;
    float inv_ds;          /* (n−1)/(s_max−s_min)                          */
    float *sigma_t;        /* [n] extinction, density scale applied        */
    float *rgba;           /* [4n] colour c(s) and σt(s) interleaved, for
                              cache-friendly marching                      */
    double *int_sigma;     /* [n] ∫ σt ds from s_min                       */
    double *int_sigma_c;   /* [3n] ∫ σt·c ds from s_min                    */
    float sigma_t_max;     /* max over the table                           */
} volux_transfer_lut;

/* Bakes d over [s_min, s_max] with n entries (n ≥ 2; 0 = default 4096).
 * `unit_default` is used when d->opacity_unit_distance is 0. Allocates
 * through ctx; free with volux_transfer_lut_free. */
VOLUX_API volux_status volux_transfer_bake(volux_context *ctx, const volux_transfer_desc *d,
                                           double s_min, double s_max, int n, float unit_default,
                                           volux_transfer_lut *out);
VOLUX_API void volux_transfer_lut_free(volux_context *ctx, volux_transfer_lut *lut);

/* Largest σt over the scalar interval [s0, s1] (for majorants); exact for
 * the piecewise-linear table (it looks at every entry and both ends). */
VOLUX_API float volux_transfer_lut_max_sigma(const volux_transfer_lut *lut, float s0, float s1);

/* ---- The quick-look transfer function (core/transfer_auto.c) ----
 * What `volux render VOLUME` and a scene without a transfer function use:
 * opacity 0 up to the end of the histogram's background peak (a narrow
 * peak holding ≥ 20 % of the voxels; see the file), then a linear ramp to α = 0.5
 * (per smallest spacing) at the 99.5th percentile of the values above it;
 * colours from ParaView's default "Cool to Warm" (Moreland 2009) over the
 * ramp, as linear RGB. */
#define VOLUX_TF_AUTO_COLORS 33

typedef struct volux_transfer_auto {
    volux_tf_color_point color[VOLUX_TF_AUTO_COLORS];
    int n_color;
    volux_tf_scalar_point opacity[2];
    int n_opacity;
    double ramp_start, ramp_end; /* file units                            */
    int has_background;          /* 1: a background peak was found       */
} volux_transfer_auto;

struct volux_volume;
VOLUX_API volux_status volux_transfer_auto_from_volume(volux_context *ctx, const struct volux_volume *v,
                                                       volux_transfer_auto *out);
/* Defaults (volux_transfer_desc_defaults) plus a's points; d borrows a. */
VOLUX_API void volux_transfer_auto_desc(const volux_transfer_auto *a, volux_transfer_desc *d);
/* The Cool to Warm map sampled at VOLUX_TF_AUTO_COLORS points over [s0, s1]. */
VOLUX_API void volux_transfer_auto_colors(double s0, double s1, volux_tf_color_point out[VOLUX_TF_AUTO_COLORS]);

#ifdef __cplusplus
}
#endif
#endif
