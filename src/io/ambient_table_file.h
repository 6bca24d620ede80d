/*
 * io/ambient_table_file.h — the preintegration table of ambient volume
 * scattering (Ament et al. 2013, §4.1) as data: its type, its file format
 * and its place in the cache folder. The estimator that fills it lives in
 * src/techniques/ambient/table.c.
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
 * with p_g the HG density per steradian, and the walks inside the sphere
 * absorbed with the single-scattering albedo. Entry (it, is, ig, ia) sits at
 * θ = π·it/(nθ−1), σ̃t = Σ̃t·is/(nσ−1), g = g_min + (g_max − g_min)·ig/(ng−1),
 * albedo[ia]; data[((ia·ng + ig)·nσ + is)·nθ + it].
 *
 * File format (little-endian; docs/techniques/ambient.md). Version 1 holds
 * one albedo; version 2 (written when there are several) an albedo axis:
 *
 *     off  size  field
 *       0     8  magic "VXAMBTAB"
 *       8     4  version (1 or 2)
 *      12     4  header bytes (128)
 *      16     4  n_theta          20  4  n_sigma       24  4  n_g
 *      28     4  flags (bit 0: a per-entry relative-error block follows)
 *      32     8  theta_min (0)    40  8  theta_max (π)
 *      48     8  sigma_min (0)    56  8  sigma_max (Σ̃t)
 *      64     8  g_min            72  8  g_max
 *      80     8  albedo (v1; v2: 0)  88  8  paths per column
 *      96     8  seed            104  4  estimator id
 *     108     4  v2: n_albedo (v1: 0)
 *     112     8  reserved (0)    120  8  build time (ms, informative)
 *     128     …  v2 only: n_albedo float64 albedos, strictly increasing
 *       …     …  float32 data, n_albedo·n_g·n_sigma·n_theta values
 *       …     …  float32 relative standard errors (if flags bit 0)
 *       …     8  FNV-1a 64 checksum of every preceding byte
 *
 * Cache: the file for description d is "<cache folder>/ambient-v<version>-e3-t…
 * -s…-g…-S…-G…_…-a…[_…]-p…-r….vxat", a name made of every parameter; cache
 * reads and writes never record an error on the context.
 */
#ifndef VOLUX_IO_AMBIENT_TABLE_FILE_H
#define VOLUX_IO_AMBIENT_TABLE_FILE_H

#include "volux/ambient.h"

#define VOLUX_AMBIENT_TABLE_VERSION 1        /* one albedo           */
#define VOLUX_AMBIENT_TABLE_VERSION_ALBEDO 2 /* with an albedo axis  */
/* Which estimator filled the table (file header and cache name). 3: escape
 * scoring with MIS against boundary-lobe sampling for |g| ≥ 0.6. The
 * estimator bumps it whenever its results change, which retires every file
 * and cache entry it wrote before. */
#define VOLUX_AMBIENT_TABLE_ESTIMATOR 3u

typedef struct volux_ambient_table {
    volux_ambient_table_desc desc;
    float *data;      /* n_g·n_sigma·n_theta radiances (layout above)       */
    float *rel_error; /* same layout: relative standard error of each entry,
                         or NULL when unknown                              */
    double build_ms;  /* wall time of the build (0 if unknown)              */
} volux_ambient_table;

static inline size_t volux_ambient_table_values(const volux_ambient_table_desc *d) {
    return (size_t)d->n_theta * (size_t)d->n_sigma * (size_t)d->n_g * (size_t)d->n_albedo;
}
/* Index of the value at (it, is, ig) of albedo ia. */
static inline size_t volux_ambient_table_index4(const volux_ambient_table_desc *d, int it, int is, int ig, int ia) {
    return (((size_t)ia * (size_t)d->n_g + (size_t)ig) * (size_t)d->n_sigma + (size_t)is) * (size_t)d->n_theta +
           (size_t)it;
}
/* Index of the value at (it, is, ig) of the first albedo. */
static inline size_t volux_ambient_table_index(const volux_ambient_table_desc *d, int it, int is, int ig) {
    return volux_ambient_table_index4(d, it, is, ig, 0);
}
/* 1 if a and b describe the same table. */
int volux_ambient_table_desc_equal(const volux_ambient_table_desc *a, const volux_ambient_table_desc *b);

/* VOLUX_ERR_INVALID naming the field ("ambient table: n_theta: ..."). */
volux_status volux_ambient_table_desc_validate(volux_context *ctx, const volux_ambient_table_desc *d);

/* Allocates t's arrays for d (rel_error only if with_errors), contents
 * undefined. 0 on out of memory, with nothing allocated and no message
 * recorded (callers say what they were doing). */
int volux_ambient_table_alloc(volux_context *ctx, const volux_ambient_table_desc *d, int with_errors,
                              volux_ambient_table *t);
void volux_ambient_table_free(volux_context *ctx, volux_ambient_table *t);

/* Writes the file atomically (temp file + rename): VOLUX_ERR_WRITE naming it. */
volux_status volux_ambient_table_save(volux_context *ctx, const volux_ambient_table *t, const char *path);
/* Reads and verifies a file (magic, version, sizes, ranges, finite values,
 * checksum, no trailing bytes): VOLUX_ERR_IO if unreadable,
 * VOLUX_ERR_FORMAT naming the file otherwise. */
volux_status volux_ambient_table_load(volux_context *ctx, const char *path, volux_ambient_table *out);
/* The same for a file's bytes in memory (`name` in messages; the built-in
 * table, the fuzzer). */
volux_status volux_ambient_table_load_memory(volux_context *ctx, const void *bytes, size_t size, const char *name,
                                             volux_ambient_table *out);

/* Reads the built-in table's bytes: 1 on success, 0 otherwise (recording
 * no error: the caller then builds the table). */
int volux_ambient_table_builtin_load(volux_context *ctx, const void *bytes, size_t size, volux_ambient_table *out);

/* The cache file for d in the context's cache folder; 0 if the disk cache
 * is off or the path does not fit. */
int volux_ambient_table_cache_path(const volux_context *ctx, const volux_ambient_table_desc *d, char *buf,
                                   size_t size);
/* Loads the cached table for d: 1 on success; 0 if there is none, or it is
 * stale or corrupt (the caller then builds it). Records no error. */
int volux_ambient_table_cache_load(volux_context *ctx, const volux_ambient_table_desc *d, volux_ambient_table *out);
/* Stores t in the cache folder (created if missing): 1 on success; 0 if the
 * disk cache is off or cannot be written (not an error: the table then lives
 * in memory only). Records no error. */
int volux_ambient_table_cache_store(volux_context *ctx, const volux_ambient_table *t);

#endif
