/*
 * volux/ambient.h — the preintegration table of the `ambient` technique
 * (ambient volume scattering, Ament, Sadlo & Weiskopf 2013, §4.1), as a
 * file: build one, or read the header and noise of one.
 *
 * The table holds the radiance L̃o(θ, σ̃t, g) leaving a homogeneous unit
 * sphere lit by a parallel light front, for every polar angle θ, ambient
 * extinction σ̃t in [0, Σ̃t] and HG anisotropy g. It depends only on the
 * description below, never on a data set, so it is built once and shared:
 * the technique loads `techniques.ambient.table_file`, or keeps tables in the
 * context's cache folder (volux_context_set_cache_dir). File format and
 * estimator: docs/techniques/ambient.md.
 *
 * A table may carry an albedo axis: one (θ, σ̃t, g) block per albedo of a
 * list, interpolated linearly in between, so that an albedo edit costs a
 * re-sum of the radiance caches instead of a new table. The library ships
 * one such table (volux_ambient_table_desc_builtin, 64 × 64 × 10 × 12,
 * compiled in from src/techniques/ambient/builtin_table.vxat, built by
 * `volux ambient-table --builtin`): the technique's default, so that no
 * first use waits for a build.
 *
 * DOES NOT: render, or expose the table's values (the technique reads them).
 *
 * STEP BY STEP
 *     volux_ambient_table_desc d;
 *     volux_ambient_table_desc_defaults(&d);     // 256×256×19, Σ̃t = 20
 *     d.albedo = 0.5;
 *     volux_ambient_table_summary s;
 *     if (volux_ambient_table_write(ctx, &d, "table.vxat", &s) == VOLUX_OK)
 *         printf("built in %.0f ms, median error %g\n", s.build_ms, s.noise.median);
 */
#ifndef VOLUX_AMBIENT_PUBLIC_H
#define VOLUX_AMBIENT_PUBLIC_H

#include "base.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VOLUX_AMBIENT_TABLE_MAX_DIM 4096
#define VOLUX_AMBIENT_TABLE_MAX_ALBEDO 16

/* Entry (it, is, ig, ia) sits at θ = π·it/(nθ−1), σ̃t = Σ̃t·is/(nσ−1),
 * g = g_min + (g_max − g_min)·ig/(ng−1), albedo[ia]. */
typedef struct volux_ambient_table_desc {
    int n_theta, n_sigma, n_g; /* each in [2, VOLUX_AMBIENT_TABLE_MAX_DIM]  */
    double sigma_max;          /* Σ̃t: optical radius range [0, Σ̃t]        */
    double g_min, g_max;       /* within (−1, 1), g_min < g_max            */
    int n_albedo;              /* [1, VOLUX_AMBIENT_TABLE_MAX_ALBEDO]       */
    double albedo[VOLUX_AMBIENT_TABLE_MAX_ALBEDO]; /* the first n_albedo:
                                  strictly increasing, in [0, 1]           */
    uint64_t paths;            /* random walks per (σ̃t, g, albedo) column;
                                  every walk scores every θ entry (≥ 1)    */
    uint64_t seed;
} volux_ambient_table_desc;

/* The paper's table: 256 × 256 × 19, Σ̃t = 20, g ∈ [−0.9, 0.9], one albedo
 * 0.9; `paths` is our default budget (see docs/techniques/ambient.md). */
VOLUX_API void volux_ambient_table_desc_defaults(volux_ambient_table_desc *d);
/* The albedo axis of the built-in table: 0, 0.1, …, 0.9, 0.95, 1 (denser
 * near 1, where multiple scattering grows fastest). Sets n_albedo and
 * albedo[] of d, nothing else. */
VOLUX_API void volux_ambient_table_desc_albedo_set(volux_ambient_table_desc *d);
/* The table compiled into the library: 64 × 64 × 10 (g ∈ [−0.9, 0.9]),
 * Σ̃t = 20, the albedo set above, 4096 walks per column. A table with
 * this description is read from the library, never built. */
VOLUX_API void volux_ambient_table_desc_builtin(volux_ambient_table_desc *d);

/* Statistics of the per-entry relative standard errors. */
typedef struct volux_ambient_table_noise {
    double median, p90, p99, max, mean;
    uint64_t entries; /* entries counted */
} volux_ambient_table_noise;

/* What a table file says about itself. */
typedef struct volux_ambient_table_summary {
    volux_ambient_table_desc desc;
    double build_ms;                 /* wall time of the build (0: unknown) */
    /* 1 if the file stores per-entry errors and some entry exceeds
     * VOLUX_AMBIENT_TABLE_NOISE_FLOOR; `noise` counts only those entries. */
    int has_noise;
    volux_ambient_table_noise noise;
} volux_ambient_table_summary;

/* Entries at or below this radiance lie deep in the forward tail of g < 0
 * columns; their relative error says nothing about image quality. */
#define VOLUX_AMBIENT_TABLE_NOISE_FLOOR 1e-6

/* Builds the table by Monte-Carlo path tracing on the context's threads and
 * writes it to `path` atomically (temp file + rename). Deterministic: the
 * file's table is bit-identical for any thread count. Reports progress as
 * task "ambient table"; a cancel returns VOLUX_ERR_CANCELLED. Errors:
 * VOLUX_ERR_INVALID naming the field ("ambient table: albedo: ..."),
 * VOLUX_ERR_WRITE naming the file. `out` may be NULL. */
VOLUX_API volux_status volux_ambient_table_write(volux_context *ctx, const volux_ambient_table_desc *d,
                                                 const char *path, volux_ambient_table_summary *out);
/* Rewrites the table file `in` as `out` without its per-entry error block
 * (half the size; the values are unchanged): how the built-in table is
 * made small. Errors as for inspect, VOLUX_ERR_WRITE naming `out`. */
VOLUX_API volux_status volux_ambient_table_strip(volux_context *ctx, const char *in, const char *out);
/* Reads and verifies a table file (magic, version, sizes, ranges, values,
 * checksum) and summarises it: VOLUX_ERR_IO if unreadable, VOLUX_ERR_FORMAT
 * naming the file otherwise. */
VOLUX_API volux_status volux_ambient_table_inspect(volux_context *ctx, const char *path,
                                                   volux_ambient_table_summary *out);

/* One (g, albedo) slice of a table (Ament et al. 2013, Fig. 5): out[is·n_theta
 * + it] = L̃o(θ, σ̃t, g, albedo) at θ = π·it/(n_theta − 1) and σ̃t =
 * Σ̃t·is/(n_sigma − 1), read from the table file `path` (NULL: the built-in
 * table) as the technique reads it (linear in θ, σ̃t and albedo, log-linear
 * in g). With reference_paths > 0 the same points are instead estimated by
 * the paper's estimator (§4.1.2: that many random walks per entry from
 * x_o(θ), no symmetry or variance reduction; slow), on the context's
 * threads, deterministic. VOLUX_ERR_INVALID naming g, albedo or the size;
 * load errors as for inspect. */
VOLUX_API volux_status volux_ambient_table_slice(volux_context *ctx, const char *path, double g, double albedo,
                                                 int n_theta, int n_sigma, uint64_t reference_paths, float *out);

#ifdef __cplusplus
}
#endif
#endif
