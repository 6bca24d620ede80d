/*
 * volux/ambient_table.h — the preintegration table of ambient volume
 * scattering (Ament, Sadlo & Weiskopf 2013, §4.1).
 *
 * The table holds L̃o(θ, σ̃t, g): the radiance leaving a homogeneous unit
 * sphere radially at polar angle θ (0 = the side facing away from the light),
 * for ambient extinction σ̃t (optical radius, 1/radius units) and HG
 * anisotropy g, when the sphere is lit by a parallel light front of value
 * L̃f = 1 travelling along +z with the boundary condition of Eq. 11:
 *
 *     L̃s(x_s, ω) = e^{−d σ̃t} · p_g(ω·z),   d = path length of the front
 *                                             inside the sphere up to x_s
 *
 * with p_g the HG density per steradian. The table depends only on its
 * resolution, ranges, the albedo and the Monte-Carlo budget — never on a
 * data set — so it is built once, stored, and shared.
 *
 * Entry (it, is, ig) sits at θ = π·it/(nθ−1), σ̃t = Σ̃t·is/(nσ−1),
 * g = g_min + (g_max − g_min)·ig/(ng−1); data[(ig·nσ + is)·nθ + it].
 *
 * File format (version 1, little-endian; docs/techniques/ambient.md):
 *
 *     off  size  field
 *       0     8  magic "VXAMBTAB"
 *       8     4  version (1)
 *      12     4  header bytes (128)
 *      16     4  n_theta          20  4  n_sigma       24  4  n_g
 *      28     4  flags (bit 0: a per-entry relative-error block follows)
 *      32     8  theta_min (0)    40  8  theta_max (π)
 *      48     8  sigma_min (0)    56  8  sigma_max (Σ̃t)
 *      64     8  g_min            72  8  g_max
 *      80     8  albedo           88  8  paths per entry
 *      96     8  seed            104  4  estimator id (3)
 *     108    12  reserved (0)    120  8  build time (ms, informative)
 *     128     …  float32 data, n_g·n_sigma·n_theta values
 *       …     …  float32 relative standard errors (if flags bit 0)
 *       …     8  FNV-1a 64 checksum of every preceding byte
 *
 * DOES NOT: render. The `ambient` technique loads or builds a table
 * through volux_ambient_table_get().
 *
 * STEP BY STEP
 *     volux_ambient_table_desc d;
 *     volux_ambient_table_desc_defaults(&d);     // 256×256×19, Σ̃t = 20
 *     d.albedo = 0.9;
 *     volux_ambient_table t;
 *     if (volux_ambient_table_build(ctx, &d, &t) == VOLUX_OK) {
 *         volux_ambient_table_save(ctx, &t, "table.vxat");
 *         volux_ambient_table_free(ctx, &t);
 *     }
 */
#ifndef VOLUX_AMBIENT_TABLE_H
#define VOLUX_AMBIENT_TABLE_H

#include "base.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VOLUX_AMBIENT_TABLE_VERSION 1
#define VOLUX_AMBIENT_TABLE_MAX_DIM 4096

typedef struct volux_ambient_table_desc {
    int n_theta, n_sigma, n_g; /* each in [2, VOLUX_AMBIENT_TABLE_MAX_DIM]  */
    double sigma_max;          /* Σ̃t: optical radius range [0, Σ̃t]        */
    double g_min, g_max;       /* within (−1, 1), g_min < g_max            */
    double albedo;             /* [0, 1]                                   */
    uint64_t paths;            /* random walks per (σ̃t, g) column; every
                                  walk scores every θ entry (≥ 1)          */
    uint64_t seed;
} volux_ambient_table_desc;

/* The paper's table: 256 × 256 × 19, Σ̃t = 20, g ∈ [−0.9, 0.9], albedo 0.9;
 * `paths` is our default budget (see docs/techniques/ambient.md). */
VOLUX_API void volux_ambient_table_desc_defaults(volux_ambient_table_desc *d);
/* VOLUX_ERR_INVALID naming the field ("ambient table: n_theta: ..."). */
VOLUX_API volux_status volux_ambient_table_desc_validate(volux_context *ctx, const volux_ambient_table_desc *d);

typedef struct volux_ambient_table {
    volux_ambient_table_desc desc;
    float *data;      /* n_g·n_sigma·n_theta radiances (layout above)       */
    float *rel_error; /* same layout: relative standard error of each entry,
                         or NULL when unknown                              */
    double build_ms;  /* wall time of the build (0 if unknown)              */
} volux_ambient_table;

/* Builds the table by Monte-Carlo path tracing on the context's threads.
 * Deterministic: the result is bit-identical for any thread count (random
 * numbers are keyed by column and walk index). Reports progress as task
 * "ambient table"; a cancel returns VOLUX_ERR_CANCELLED. Caller frees. */
VOLUX_API volux_status volux_ambient_table_build(volux_context *ctx, const volux_ambient_table_desc *d,
                                                 volux_ambient_table *out);
/* Writes the file atomically (temp file + rename). */
VOLUX_API volux_status volux_ambient_table_save(volux_context *ctx, const volux_ambient_table *t, const char *path);
/* Reads and verifies a file (magic, version, sizes, ranges, checksum):
 * VOLUX_ERR_IO if unreadable, VOLUX_ERR_FORMAT naming the file otherwise. */
VOLUX_API volux_status volux_ambient_table_load(volux_context *ctx, const char *path, volux_ambient_table *out);
VOLUX_API void volux_ambient_table_free(volux_context *ctx, volux_ambient_table *t);

/* The cache file for a description: $XDG_CACHE_HOME/volux/ (or
 * ~/.cache/volux/) + a name made of every parameter. Returns 0 if no cache
 * folder is known or the path does not fit. */
VOLUX_API int volux_ambient_table_cache_path(const volux_ambient_table_desc *d, char *buf, size_t size);
/* Loads the cached table for d, or builds it and tries to cache it (a
 * folder that cannot be written is not an error: the table then lives in
 * memory only). *built (may be NULL) tells which happened. */
VOLUX_API volux_status volux_ambient_table_get(volux_context *ctx, const volux_ambient_table_desc *d,
                                               volux_ambient_table *out, int *built);

/* Trilinear lookup at (θ radians, σ̃t, g), clamped to the ranges; linear in
 * θ and σ̃t, log-linear in g. */
VOLUX_API double volux_ambient_table_eval(const volux_ambient_table *t, double theta, double sigma, double g);

/* Summary of the per-entry relative standard errors (entries whose value is
 * below `floor` are skipped). Returns 0 if the table has none. */
typedef struct volux_ambient_table_noise {
    double median, p90, p99, max, mean;
    uint64_t entries;
} volux_ambient_table_noise;
VOLUX_API int volux_ambient_table_noise_summary(volux_context *ctx, const volux_ambient_table *t, double floor,
                                                volux_ambient_table_noise *out);

#ifdef __cplusplus
}
#endif
#endif
