/*
 * tests/support/pt_util.h — small scenes and per-pixel statistics for the
 * path-tracer physics tests.
 *
 * pt_accumulate renders sample indices 0..spp−1 exactly as the frame loop
 * does (same tiles, same sample indices, so the same random streams), but
 * keeps per-pixel, per-channel sums of x and x², so tests can state
 * tolerances in standard errors of each pixel's mean.
 */
#ifndef VOLUX_PT_UTIL_H
#define VOLUX_PT_UTIL_H

#include "test_util.h"

typedef struct pt_stats {
    int width, height, spp;
    double *mean; /* 3 per pixel: mean of the samples                     */
    double *var;  /* 3 per pixel: sample variance of one sample            */
} pt_stats;

/* Renders spp samples of every pixel with technique t (single-threaded). */
void pt_accumulate(volux_technique *t, volux_scene *scene, int spp, pt_stats *out);
void pt_stats_free(pt_stats *s);
/* Standard error of pixel p's channel c mean. */
double pt_stats_se(const pt_stats *s, int p, int c);

/* Volume of nx·ny·nz float32 nodes from f(i,j,k) (spacing 1, centred). */
volux_volume *pt_volume_fn(volux_context *ctx, int nx, int ny, int nz, float (*f)(int i, int j, int k, void *u),
                           void *user);
volux_volume *pt_volume_constant(volux_context *ctx, int nx, int ny, int nz, float value);

/* Scene with volume v (retained), `extinction` TF points (σt per s), white
 * colour unless `color` is given, albedo, anisotropy; an orthographic
 * camera at +Z looking down −Z with view height `height`; image w×h; seed 1. */
volux_scene *pt_scene(volux_context *ctx, volux_volume *v, const volux_tf_scalar_point *ext, int n_ext,
                      const volux_tf_color_point *color, int n_color, float albedo, float g, float height, int w,
                      int h, int max_depth);
/* Adds a constant environment light of radiance rgb to slot 0. */
void pt_add_constant_env(volux_scene *s, volux_vec3 rgb, int visible);

#endif
