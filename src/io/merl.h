/*
 * io/merl.h — measured isotropic BRDFs in the MERL ".binary" format
 * (Matusik et al. 2003, "A Data-Driven Reflectance Model"), read by `sh`
 * as an optional material (transfer_function.materials[i].type "merl").
 *
 * FORMAT. Three little-endian int32 bin counts (θ_h, θ_d, φ_d; the MERL
 * database uses 90, 90, 180), then 3·n little-endian doubles, n the product
 * of the counts: the red, green and blue planes, φ_d fastest, then θ_d,
 * then θ_h, in Rusinkiewicz's half/difference angles. Values are scaled
 * by 1/1500, 1.15/1500, 1.66/1500 per channel (the database's
 * convention); negative values mark missing measurements and read as 0,
 * as do values that are not finite or exceed 1e30 after scaling (a float
 * cannot hold them; found by fuzz/fuzz_merl.c).
 * Bins: θ_h non-linearly (index = √(θ_h/(π/2))·n_h), θ_d and φ_d ∈ [0, π)
 * linearly (reciprocity folds φ_d into half a turn).
 *
 * LIMITS. Every count in [1, 1024], the byte size must equal exactly
 * 12 + 24·n, and 12·n bytes (the float copy) must fit the context's
 * memory cap; checked before allocating.
 *
 * DOES NOT: project or filter (techniques/sh does).
 */
#ifndef VOLUX_IO_MERL_H
#define VOLUX_IO_MERL_H

#include <stddef.h>
#include <stdint.h>

#include "volux/base.h"

typedef struct volux_merl {
    int dims[3];  /* θ_h, θ_d, φ_d bins                              */
    float *rgb;   /* 3 planes of n values, scaled, missing = 0       */
    size_t bytes;
} volux_merl;

/* Parses a .binary file held in memory. VOLUX_ERR_FORMAT for a bad size or
 * counts, VOLUX_ERR_LIMIT over the memory cap, NOMEM. `name` names the
 * file in messages. */
volux_status volux_merl_parse(volux_context *ctx, const uint8_t *data, size_t size, const char *name,
                              volux_merl *out);
/* Reads and parses a file (VOLUX_ERR_IO if it cannot be read). */
volux_status volux_merl_load(volux_context *ctx, const char *path, volux_merl *out);
void volux_merl_free(volux_context *ctx, volux_merl *m);

/* Reflectance f_r(ω_i, ω_o) (1/sr, per channel) for unit directions in the
 * local frame (z = normal); 0 when either lies below the surface. */
void volux_merl_eval(const volux_merl *m, const double wi[3], const double wo[3], double rgb[3]);

#endif
