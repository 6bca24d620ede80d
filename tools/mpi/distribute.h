/*
 * tools/mpi/distribute.h — the MPI front end of `volux render` and
 * `volux bench` (issue 15), on the public API only.
 *
 * Image-parallel (sort-first): every rank loads the scene and builds its
 * technique's caches, then takes chunks of tiles from a shared counter
 * (MPI one-sided fetch-and-add on rank 0, so a rank that finishes early
 * takes more), renders all samples of its tiles with volux_render_tiles and
 * the per-pixel sums are added on rank 0 with MPI_Reduce. A pixel is
 * rendered by exactly one rank and the others contribute exact zeros, so
 * the image is bit-identical to a single-process render for any rank count.
 *
 * Built from distribute.c when MPI is found (-DVOLUX_MPI=ON, the default),
 * else from distribute_none.c, which runs one process and refuses
 * --distribute with a clear message.
 *
 * DOES NOT: print anything but rank 0's error/progress, or touch files.
 */
#ifndef VOLUX_TOOLS_DISTRIBUTE_H
#define VOLUX_TOOLS_DISTRIBUTE_H

#include "volux/volux.h"

typedef enum dist_mode { DIST_NONE = 0, DIST_IMAGE, DIST_DATA } dist_mode;

/* Parses a --distribute value ("image" | "data"); prints an error naming
 * the option and returns 0 on anything else. */
int dist_parse_mode(const char *cmd, const char *value, dist_mode *out);

/* Nonzero when this process was started by mpirun (or another PMI/PMIx
 * launcher), with or without MPI support in this build. */
int dist_launched(void);
/* Under mpirun, silences stderr on ranks other than 0 until dist_begin,
 * so a usage error is printed once (by rank 0). */
void dist_quiet_followers(void);
/* Starts MPI when `requested` is set or the process was launched by mpirun
 * (then the mode defaults to image). Returns the mode in effect (DIST_NONE:
 * one process, nothing distributed) or −1 after printing why it cannot
 * (e.g. built without MPI). */
int dist_begin(const char *cmd, dist_mode requested);
/* Ends MPI if dist_begin started it. */
void dist_end(void);
int dist_rank(void); /* 0 without MPI */
int dist_size(void); /* 1 without MPI */
/* Threads per rank when the user gave none: the cores of this node over
 * the ranks on it (0 = the library's default, when not distributed). */
int dist_default_threads(void);

/* Collective failure agreement. Every rank passes its status; when any
 * failed, rank 0 prints the lowest failing rank's message once
 * ("volux CMD: …", prefixed "rank K:" when K ≠ 0) and every rank returns
 * that rank's exit status. 0 when all succeeded. */
int dist_agree(const char *cmd, volux_context *ctx, volux_status st);
/* The same for an exit status and its message (rc 0: success). */
int dist_agree_msg(const char *cmd, int rc, const char *msg);
/* Rank 0's exit code, on every rank. */
int dist_share_exit(int rc);

/* Collectives for benchmarks (no-ops without MPI): a barrier, *v becomes
 * the maximum over ranks (on rank 0), and rank 0 receives every rank's two
 * values in out[2·rank], out[2·rank + 1]. */
void dist_barrier(void);
void dist_max(double *v);
void dist_gather2(const double v[2], double *out);

typedef struct dist_timing {
    double render_ms;       /* this rank: its tiles                          */
    double wait_ms;         /* this rank: from its last tile to the reduce   */
    double composite_ms;    /* the reduction of the sums onto rank 0         */
    double composite_bytes; /* data-parallel: bytes this rank sent compositing */
    int tiles;              /* tiles this rank rendered                      */
    double rank_render_ms_min, rank_render_ms_max; /* over ranks (rank 0)    */
    /* data-parallel: this rank's place in the visibility order (0 = front) */
    int position;
} dist_timing;

/* Collective: renders render.spp samples of the whole frame image-parallel;
 * afterwards rank 0's fb holds the frame (other ranks' fb: their tiles).
 * Without MPI it is volux_render with the scene's limits. Returns this
 * rank's status (pass it to dist_agree). */
volux_status dist_render_image(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                               dist_timing *timing);

/* ---- Data-parallel (sort-last), --distribute data ----
 *
 * Rank r loads brick r of the k-d split of the volume into dist_size()
 * bricks (dist_region, for cli_scene_args.region), the ranks agree on the
 * whole volume's statistics (dist_share_stats), and each renders its
 * brick with volux_render_part: premultiplied colour + transmittance
 * through its owned box, on the whole volume's sample lattice. The
 * partial images are composited on a communicator whose rank order is
 * the visibility order of the view, by binary swap (any rank count: others
 * fold to a power of two first), the pieces gathered on rank 0; or, with
 * VOLUX_COMPOSITE=reduce, by one MPI_Reduce with a non-commutative
 * user-defined "over" MPI_Op (MPI applies it in rank order).
 * VOLUX_COMPOSITE other than swap/reduce: dist_begin refuses it. */
void dist_region(volux_volume_region *out);
/* Collective: the whole volume's statistics (value range, largest
 * gradient component: min/max over the bricks' own) given to this rank's
 * brick, and the scene's volume set again so its transfer-function table
 * is baked over the whole range. */
volux_status dist_share_stats(volux_scene *scene);
/* Collective: renders render.spp samples of this rank's brick and
 * composites; afterwards rank 0's fb holds the frame (render.spp samples).
 * Returns this rank's status (pass it to dist_agree). */
volux_status dist_render_data(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                              dist_timing *timing);
/* Bytes of the scalar grid this process holds for the scene's volume, and
 * of the whole volume's grid at the same storage type. */
void dist_volume_bytes(const volux_scene *scene, double *held, double *whole);

/* One process: volux_render with the scene's limits, timings filled in
 * (mode.c; both front ends use it). */
volux_status dist_render_local(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                               dist_timing *timing);

#endif
