/* tools/mpi/distribute.c — MPI front end (see distribute.h). */
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <fcntl.h>
#include <limits.h>
#include <unistd.h>

#include "tools/cli/cli.h"
#include "distribute.h"

static int started, rank, size = 1, saved_stderr = -1;
/* Data-parallel compositing: binary swap (default) or one MPI_Reduce
 * (VOLUX_COMPOSITE=reduce, kept to compare against, see DISTRIBUTED.md). */
static int composite_reduce;

void dist_quiet_followers(void) {
    if (!dist_launched()) return;
    const char *r = getenv("OMPI_COMM_WORLD_RANK");
    if (!r) r = getenv("PMIX_RANK");
    if (!r) r = getenv("PMI_RANK");
    if (!r || !strcmp(r, "0") || saved_stderr >= 0) return;
    int null = open("/dev/null", O_WRONLY);
    if (null < 0) return;
    fflush(stderr);
    saved_stderr = dup(STDERR_FILENO);
    dup2(null, STDERR_FILENO);
    close(null);
}

/* Gives stderr back after dist_quiet_followers (crash reports stay
 * visible; normal messages come from rank 0 only). */
static void restore_stderr(void) {
    if (saved_stderr < 0) return;
    fflush(stderr);
    dup2(saved_stderr, STDERR_FILENO);
    close(saved_stderr);
    saved_stderr = -1;
}

int dist_begin(const char *cmd, dist_mode requested) {
    /* Checked before MPI starts (and while the followers are still muted),
     * so a bad value is reported once and no rank is left in MPI. */
    const char *comp = requested == DIST_DATA ? getenv("VOLUX_COMPOSITE") : NULL;
    if (comp && strcmp(comp, "swap") && strcmp(comp, "reduce")) {
        cli_eprintf("volux %s: VOLUX_COMPOSITE: expected 'swap' or 'reduce', got '%s'\n", cmd, comp);
        restore_stderr();
        return -1;
    }
    composite_reduce = comp && !strcmp(comp, "reduce");
    restore_stderr();
    if (!requested && !dist_launched()) return DIST_NONE;
    int provided = 0;
    /* Threads render tiles but only the main thread calls MPI. */
    if (MPI_Init_thread(NULL, NULL, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        cli_eprintf("volux %s: MPI could not start\n", cmd);
        return -1;
    }
    started = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    return requested ? (int)requested : DIST_IMAGE;
}

void dist_end(void) {
    if (started) MPI_Finalize();
    started = 0;
}

int dist_rank(void) { return rank; }
int dist_size(void) { return size; }

int dist_default_threads(void) {
    if (!started) return 0;
    const char *local = getenv("OMPI_COMM_WORLD_LOCAL_SIZE");
    long ranks_here = local ? strtol(local, NULL, 10) : size;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    if (ranks_here < 1) ranks_here = 1;
    long t = cores / ranks_here;
    return t > 1 ? (int)t : 1;
}

int dist_agree_msg(const char *cmd, int rc, const char *msg) {
    if (!started) {
        if (rc) cli_eprintf("volux %s: %s\n", cmd, msg);
        return rc;
    }
    int mine = rc ? rank : size, first = size;
    MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (first == size) return 0;
    char text[1024] = "";
    if (rank == first) snprintf(text, sizeof text, "%s", msg);
    MPI_Bcast(text, (int)sizeof text, MPI_CHAR, first, MPI_COMM_WORLD);
    MPI_Bcast(&rc, 1, MPI_INT, first, MPI_COMM_WORLD);
    if (rank == 0) {
        if (first) cli_eprintf("volux %s: rank %d: %s\n", cmd, first, text);
        else cli_eprintf("volux %s: %s\n", cmd, text);
    }
    return rc;
}

int dist_agree(const char *cmd, volux_context *ctx, volux_status st) {
    const char *e = st && ctx ? volux_context_error(ctx) : "";
    return dist_agree_msg(cmd, cli_exit_status(st), e && *e ? e : volux_status_name(st));
}

int dist_share_exit(int rc) {
    if (started) MPI_Bcast(&rc, 1, MPI_INT, 0, MPI_COMM_WORLD);
    return rc;
}

void dist_barrier(void) {
    if (started) MPI_Barrier(MPI_COMM_WORLD);
}

void dist_max(double *v) {
    double m = *v;
    if (started) MPI_Reduce(v, &m, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    *v = m;
}

void dist_gather2(const double v[2], double *out) {
    if (started) MPI_Gather(v, 2, MPI_DOUBLE, out, 2, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    else memcpy(out, v, 2 * sizeof *v);
}

static double now_ms(void) { return cli_now_ms(); }

/* Tiles per chunk: about 8 chunks per rank, so a slow rank's last chunk
 * is a small part of the frame, and at least 2 tiles per thread so a
 * chunk keeps every thread of a rank busy. */
static int chunk_tiles(int total, int threads) {
    int c = total / (8 * size);
    if (c < 2 * threads) c = 2 * threads;
    return c < 1 ? 1 : c;
}

/* Collective: rank 0's fb receives every other rank's chunks (their
 * tile sums, packed by volux_framebuffer_read_tiles); rank 0's own tiles
 * are already in place. */
static volux_status gather_tiles(volux_framebuffer *fb, const int *chunks, int n_chunks, uint32_t spp) {
    const int S = VOLUX_TILE_SUMS;
    size_t my_px = 0;
    if (rank > 0)
        for (int c = 0; c < n_chunks; c++) my_px += volux_framebuffer_tile_pixels(fb, chunks[2 * c], chunks[2 * c + 1]);
    size_t frame_px = (size_t)volux_framebuffer_width(fb) * (size_t)volux_framebuffer_height(fb);
    double *packed = malloc((my_px ? my_px : 1) * S * sizeof(double));
    double *received = rank == 0 ? malloc((frame_px ? frame_px : 1) * S * sizeof(double)) : NULL;
    /* rank 0: (chunks, pixels) per rank, then their counts and offsets */
    int *meta = rank == 0 ? calloc(6 * (size_t)size, sizeof(int)) : NULL;
    int *all_chunks = rank == 0 ? malloc(2 * (size_t)(volux_framebuffer_tile_count(fb) + 1) * sizeof(int)) : NULL;
    int ok = packed && (rank || (received && meta && all_chunks)), all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (all_ok) {
        for (int c = 0, at = 0; rank > 0 && c < n_chunks; c++)
            at += (int)volux_framebuffer_read_tiles(fb, chunks[2 * c], chunks[2 * c + 1], packed + (size_t)S * at);
        int mine[2] = {rank > 0 ? n_chunks : 0, (int)my_px};
        MPI_Gather(mine, 2, MPI_INT, meta, 2, MPI_INT, 0, MPI_COMM_WORLD);
        int *chunk_n = NULL, *px_n = NULL, *chunk_at = NULL, *px_at = NULL;
        if (meta) {
            chunk_n = meta + 2 * size;
            px_n = meta + 3 * size;
            chunk_at = meta + 4 * size;
            px_at = meta + 5 * size;
            for (int r = 0, ca = 0, pa = 0; r < size; r++) {
                chunk_n[r] = meta[2 * r];
                px_n[r] = meta[2 * r + 1];
                chunk_at[r] = ca;
                px_at[r] = pa;
                ca += chunk_n[r];
                pa += px_n[r];
            }
        }
        /* Counts in whole pixels and chunk pairs: an MPI count is an int. */
        MPI_Datatype pair, pixel;
        MPI_Type_contiguous(2, MPI_INT, &pair);
        MPI_Type_contiguous(S, MPI_DOUBLE, &pixel);
        MPI_Type_commit(&pair);
        MPI_Type_commit(&pixel);
        MPI_Gatherv(chunks, mine[0], pair, all_chunks, chunk_n, chunk_at, pair, 0, MPI_COMM_WORLD);
        MPI_Gatherv(packed, (int)my_px, pixel, received, px_n, px_at, pixel, 0, MPI_COMM_WORLD);
        MPI_Type_free(&pair);
        MPI_Type_free(&pixel);
        if (rank == 0)
            for (int r = 1; r < size; r++) {
                const double *in = received + (size_t)S * px_at[r];
                for (int c = chunk_at[r]; c < chunk_at[r] + chunk_n[r]; c++)
                    in += (size_t)S * volux_framebuffer_write_tiles(fb, all_chunks[2 * c], all_chunks[2 * c + 1], in, spp);
            }
    }
    free(packed);
    free(received);
    free(meta);
    free(all_chunks);
    return all_ok ? VOLUX_OK : VOLUX_ERR_NOMEM;
}

volux_status dist_render_image(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                               dist_timing *timing) {
    if (!started) return dist_render_local(t, scene, fb, timing);
    memset(timing, 0, sizeof *timing);
    const volux_render_settings *rs = volux_scene_render(scene);
    int total = volux_framebuffer_tile_count(fb);
    int threads = rs->threads > 0 ? rs->threads : dist_default_threads();
    int chunk = chunk_tiles(total, threads > 0 ? threads : 1);
    uint32_t spp = rs->spp > 0 ? (uint32_t)rs->spp : 1;

    /* The shared tile counter lives in rank 0's window. */
    int *counter = NULL;
    MPI_Win win;
    MPI_Win_allocate(rank == 0 ? (MPI_Aint)sizeof(int) : 0, sizeof(int), MPI_INFO_NULL, MPI_COMM_WORLD, &counter,
                     &win);
    if (rank == 0) *counter = 0;
    MPI_Barrier(MPI_COMM_WORLD); /* the counter is 0 before anyone takes */

    /* The chunks this rank took: (first tile, count) pairs. */
    int max_chunks = total / chunk + 1, n_chunks = 0;
    int *chunks = malloc(2 * (size_t)max_chunks * sizeof *chunks);
    volux_status st = chunks ? VOLUX_OK : VOLUX_ERR_NOMEM;
    double start = now_ms();
    const int add = chunk;
    for (;;) {
        int first = 0;
        MPI_Win_lock(MPI_LOCK_SHARED, 0, 0, win);
        MPI_Fetch_and_op(&add, &first, MPI_INT, 0, 0, MPI_SUM, win);
        MPI_Win_unlock(0, win);
        if (first >= total || !chunks) break;
        int count = total - first < chunk ? total - first : chunk;
        if (rank == 0 && !st) cli_progress("render", (double)first / total);
        st = volux_render_tiles(t, scene, fb, first, count, spp, NULL);
        if (st) break; /* the others take the rest; dist_agree reports it */
        timing->tiles += count;
        chunks[2 * n_chunks] = first;
        chunks[2 * n_chunks + 1] = count;
        n_chunks++;
    }
    timing->render_ms = now_ms() - start;
    if (rank == 0) cli_progress("render", 1.0);

    /* Gather every rank's tiles onto rank 0 with MPI_Gatherv: each pixel
     * travels once, from the rank that rendered it, so the traffic is at
     * most one frame whatever the rank count, and the sums arrive
     * unchanged (bit-identical to one process). */
    double wait_start = now_ms();
    MPI_Barrier(MPI_COMM_WORLD);
    timing->wait_ms = now_ms() - wait_start;
    double t0 = now_ms();
    volux_status gst = gather_tiles(fb, chunks, n_chunks, spp);
    timing->composite_ms = now_ms() - t0;
    if (!st) st = gst;
    free(chunks);
    MPI_Win_free(&win);

    double r[2] = {-timing->render_ms, timing->render_ms}, ext[2];
    MPI_Reduce(r, ext, 2, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    timing->rank_render_ms_min = -ext[0];
    timing->rank_render_ms_max = ext[1];
    return st;
}

/* ------------------------------------------------------------ data-parallel */

void dist_region(volux_volume_region *out) {
    memset(out, 0, sizeof *out);
    out->count = size;
    out->index = rank;
    out->ghost = 0; /* VOLUX_BRICK_GHOST */
}

volux_status dist_share_stats(volux_scene *scene) {
    volux_volume *v = volux_scene_volume(scene);
    volux_volume_stats w;
    volux_volume_stats_of(v, &w);
    if (started) {
        double mine[3] = {-w.value_min, w.value_max, w.gradient_max}, all[3];
        MPI_Allreduce(mine, all, 3, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
        w.value_min = -all[0];
        w.value_max = all[1];
        w.gradient_max = all[2];
    }
    volux_status st = volux_volume_set_whole_stats(v, &w);
    /* again, so the scene bakes its table over the whole range */
    return st ? st : volux_scene_set_volume(scene, v);
}

/* "over" on premultiplied colour + transmittance, n pixels:
 * out = front over back = (C_f + T_f·C_b, T_f·T_b); out may be front or
 * back (each pixel is read before it is written). */
static void over(const float *front, const float *back, float *out, size_t n) {
    for (size_t i = 0; i < n; i++, front += 4, back += 4, out += 4) {
        float t = front[3], c0 = front[0] + t * back[0], c1 = front[1] + t * back[1], c2 = front[2] + t * back[2];
        out[0] = c0;
        out[1] = c1;
        out[2] = c2;
        out[3] = t * back[3];
    }
}

/* The MPI_Op: `in` is in front (MPI hands a non-commutative operation the
 * lower rank's data as invec), so inout = in over inout. */
static void over_op(void *in, void *inout, int *len, MPI_Datatype *type) {
    (void)type;
    over(in, inout, inout, (size_t)*len);
}

/* Collective on `vis` (rank order = visibility order, p = this rank's
 * place): the composite of every rank's `part` (n pixels of 4 floats)
 * into rank `root`'s `frame`, by binary swap (Ma et al. 1994): in round k
 * a rank and the rank 2^k away in the order exchange halves of the pixel
 * range they hold, each keeping one half composited in the right order, so
 * after log2 N rounds each holds 1/N of the image composited over all
 * ranks, and the pieces are gathered on the root. Every round composites
 * two groups of consecutive places (front group over back group), which
 * keeps the visibility order. A rank count that is not a power of two is
 * first folded to the largest power of two P ≤ N: places 2i and 2i + 1
 * (i < N − P) composite whole images onto 2i, which leaves P ranks, still
 * consecutive in the order. Traffic per rank ≈ 16·n·(1 − 1/P) bytes plus
 * the gather (the one MPI_Reduce moves the whole image through log2 N tree
 * levels or N − 1 steps). `part` is overwritten; *sent: bytes this rank
 * sent. */
static volux_status composite_swap(float *part, float *frame, size_t n, int root, MPI_Comm vis, MPI_Datatype pixel,
                                   double *sent) {
    int p, N;
    MPI_Comm_rank(vis, &p);
    MPI_Comm_size(vis, &N);
    int P = 1;
    while (2 * P <= N) P *= 2;
    int extra = N - P, active = 1, v = p; /* v: place among the P swapping ranks */
    if (p < 2 * extra) {
        active = p % 2 == 0;
        v = p / 2;
    } else {
        v = p - extra;
    }
    int receives_whole = active && p < 2 * extra;
    size_t tmp_px = receives_whole ? n : (n + 1) / 2;
    float *tmp = malloc((tmp_px ? tmp_px : 1) * 4 * sizeof *tmp);
    int ok = tmp != NULL, all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, vis);
    if (!all_ok) {
        free(tmp);
        return VOLUX_ERR_NOMEM;
    }
    *sent = 0;
    /* fold: the odd place sends its whole image to the even one in front */
    if (p < 2 * extra) {
        if (!active) {
            MPI_Send(part, (int)n, pixel, p - 1, 0, vis);
            *sent += 16.0 * (double)n;
        } else {
            MPI_Recv(tmp, (int)n, pixel, p + 1, 0, vis, MPI_STATUS_IGNORE);
            over(part, tmp, part, n);
        }
    }
    size_t lo = 0, len = active ? n : 0; /* the pixels this rank holds */
    for (int bit = 1; active && bit < P; bit *= 2) {
        /* the partner's place u among the swapping ranks, and its vis rank */
        int u = v ^ bit, partner = u < extra ? 2 * u : u + extra;
        size_t half = len / 2;
        /* the front rank of the pair keeps the low half */
        int front = v < u;
        size_t keep_lo = front ? lo : lo + half, keep_n = front ? half : len - half;
        size_t give_lo = front ? lo + half : lo, give_n = len - keep_n;
        MPI_Sendrecv(part + 4 * give_lo, (int)give_n, pixel, partner, bit, tmp, (int)keep_n, pixel, partner, bit, vis,
                     MPI_STATUS_IGNORE);
        *sent += 16.0 * (double)give_n;
        if (front) over(part + 4 * keep_lo, tmp, part + 4 * keep_lo, keep_n);
        else over(tmp, part + 4 * keep_lo, part + 4 * keep_lo, keep_n);
        lo = keep_lo;
        len = keep_n;
    }
    /* every piece to the root, where it lies in the image */
    int piece[2] = {(int)lo, (int)len}, *pieces = p == root ? malloc(2 * (size_t)N * sizeof *pieces) : NULL;
    int *counts = p == root ? malloc(2 * (size_t)N * sizeof *counts) : NULL;
    ok = p != root || (pieces && counts);
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, vis);
    if (all_ok) {
        MPI_Gather(piece, 2, MPI_INT, pieces, 2, MPI_INT, root, vis);
        if (p == root)
            for (int r = 0; r < N; r++) {
                counts[r] = pieces[2 * r + 1]; /* counts */
                counts[N + r] = pieces[2 * r]; /* displacements */
            }
        MPI_Gatherv(part + 4 * lo, (int)len, pixel, frame, counts, counts ? counts + N : NULL, pixel, root, vis);
        if (p != root) *sent += 16.0 * (double)len;
    }
    free(pieces);
    free(counts);
    free(tmp);
    return all_ok ? VOLUX_OK : VOLUX_ERR_NOMEM;
}

/* Rank 0: the composited samples (spp images of px pixels) into fb's sums
 * (tile order of volux_framebuffer_write_tiles). */
static volux_status put_frame(volux_framebuffer *fb, const float *rgbt, size_t px, uint32_t spp) {
    int w = volux_framebuffer_width(fb), h = volux_framebuffer_height(fb);
    int tiles_x = (w + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE, tiles = volux_framebuffer_tile_count(fb);
    double *buf = malloc((size_t)VOLUX_TILE_SIZE * VOLUX_TILE_SIZE * VOLUX_TILE_SUMS * sizeof *buf);
    if (!buf) return VOLUX_ERR_NOMEM;
    for (int t = 0; t < tiles; t++) {
        int x0 = (t % tiles_x) * VOLUX_TILE_SIZE, y0 = (t / tiles_x) * VOLUX_TILE_SIZE;
        int tw = w - x0 < VOLUX_TILE_SIZE ? w - x0 : VOLUX_TILE_SIZE;
        int th = h - y0 < VOLUX_TILE_SIZE ? h - y0 : VOLUX_TILE_SIZE;
        double *o = buf;
        for (int y = y0; y < y0 + th; y++)
            for (int x = x0; x < x0 + tw; x++, o += VOLUX_TILE_SUMS) {
                memset(o, 0, VOLUX_TILE_SUMS * sizeof *o);
                for (uint32_t s = 0; s < spp; s++) { /* in sample order, as volux_render adds them */
                    const float *c = rgbt + 4 * (px * s + (size_t)y * (size_t)w + (size_t)x);
                    double lum = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
                    o[0] += c[0];
                    o[1] += c[1];
                    o[2] += c[2];
                    o[3] += lum * lum;
                }
            }
        volux_framebuffer_write_tiles(fb, t, 1, buf, spp);
    }
    free(buf);
    return VOLUX_OK;
}

volux_status dist_render_data(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                              dist_timing *timing) {
    memset(timing, 0, sizeof *timing);
    const volux_render_settings *rs = volux_scene_render(scene);
    uint32_t spp = rs->spp > 0 ? (uint32_t)rs->spp : 1;
    size_t px = (size_t)rs->width * (size_t)rs->height;
    /* One partial image per sample, composited per sample ("over" does not
     * commute with the mean over a pixel's jittered samples) in one
     * reduction; rank 0 averages. */
    size_t n = px * spp;
    float *part = n <= (size_t)INT_MAX ? malloc(n * 4 * sizeof *part) : NULL;
    float *frame = rank == 0 && part ? malloc(n * 4 * sizeof *frame) : NULL;
    volux_status st = part && (rank || frame) ? VOLUX_OK : VOLUX_ERR_NOMEM;
    int pos = rank;
    volux_render_report rep = {0};
    for (uint32_t s = 0; !st && s < spp; s++) {
        volux_render_report one;
        st = volux_render_part(t, scene, s, part + 4 * px * s, &pos, &one);
        rep.ms += one.ms;
    }
    timing->render_ms = rep.ms;
    timing->position = pos;
    timing->tiles = volux_framebuffer_tile_count(fb);
    if (!started) { /* one process: the brick is the whole volume */
        if (!st) st = put_frame(fb, part, px, spp);
        timing->rank_render_ms_min = timing->rank_render_ms_max = rep.ms;
        free(part);
        free(frame);
        return st;
    }
    /* Everyone composites or no one does (the caller reports the failure). */
    int ok = st == VOLUX_OK, all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (all_ok) {
        double wait_start = now_ms();
        MPI_Barrier(MPI_COMM_WORLD);
        timing->wait_ms = now_ms() - wait_start;
        double t0 = now_ms();
        /* The ranks sorted by their place in the visibility order. */
        MPI_Comm vis;
        MPI_Comm_split(MPI_COMM_WORLD, 0, pos, &vis);
        int root = 0, vis_rank;
        MPI_Comm_rank(vis, &vis_rank);
        if (rank == 0) root = vis_rank;
        MPI_Bcast(&root, 1, MPI_INT, 0, MPI_COMM_WORLD);
        MPI_Datatype pixel;
        MPI_Type_contiguous(4, MPI_FLOAT, &pixel);
        MPI_Type_commit(&pixel);
        if (composite_reduce) {
            MPI_Op over_mpi;
            MPI_Op_create(over_op, 0 /* not commutative */, &over_mpi);
            MPI_Reduce(part, frame, (int)n, pixel, over_mpi, root, vis);
            /* whatever the tree, every rank but the root sends one image */
            timing->composite_bytes = vis_rank == root ? 0.0 : 16.0 * (double)n;
            MPI_Op_free(&over_mpi);
        } else {
            st = composite_swap(part, frame, n, root, vis, pixel, &timing->composite_bytes);
        }
        MPI_Type_free(&pixel);
        MPI_Comm_free(&vis);
        timing->composite_ms = now_ms() - t0;
        if (rank == 0 && !st) st = put_frame(fb, frame, px, spp);
    } /* else another rank failed: the caller's dist_agree reports it, once */
    free(part);
    free(frame);
    double r[2] = {-timing->render_ms, timing->render_ms}, ext[2];
    MPI_Reduce(r, ext, 2, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    timing->rank_render_ms_min = -ext[0];
    timing->rank_render_ms_max = ext[1];
    return st;
}
