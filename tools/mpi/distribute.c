/* tools/mpi/distribute.c — MPI front end (see distribute.h). */
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <fcntl.h>
#include <unistd.h>

#include "tools/cli/cli.h"
#include "distribute.h"

static int started, rank, size = 1, saved_stderr = -1;

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
    restore_stderr();
    if (!requested && !dist_launched()) return DIST_NONE;
    int provided = 0;
    /* Threads render tiles but only the main thread calls MPI. */
    if (MPI_Init_thread(NULL, NULL, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        fprintf(stderr, "volux %s: MPI could not start\n", cmd);
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
        if (rc) fprintf(stderr, "volux %s: %s\n", cmd, msg);
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
        if (first) fprintf(stderr, "volux %s: rank %d: %s\n", cmd, first, text);
        else fprintf(stderr, "volux %s: %s\n", cmd, text);
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

volux_status dist_render_image(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                               dist_timing *timing) {
    memset(timing, 0, sizeof *timing);
    if (!started) {
        volux_render_report rep = {0};
        volux_status st = volux_render(t, scene, fb, NULL, &rep);
        timing->render_ms = timing->rank_render_ms_min = timing->rank_render_ms_max = rep.ms;
        timing->tiles = volux_framebuffer_tile_count(fb);
        return st;
    }
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

    volux_status st = VOLUX_OK;
    double start = now_ms();
    const int add = chunk;
    for (;;) {
        int first = 0;
        MPI_Win_lock(MPI_LOCK_SHARED, 0, 0, win);
        MPI_Fetch_and_op(&add, &first, MPI_INT, 0, 0, MPI_SUM, win);
        MPI_Win_unlock(0, win);
        if (first >= total) break;
        int count = total - first < chunk ? total - first : chunk;
        if (rank == 0 && !st) cli_progress("render", (double)first / total);
        st = volux_render_tiles(t, scene, fb, first, count, spp, NULL);
        if (st) break; /* the others take the rest; dist_agree reports it */
        timing->tiles += count;
    }
    timing->render_ms = now_ms() - start;
    if (rank == 0) cli_progress("render", 1.0);

    /* Sum the frames: every pixel is non-zero on one rank at most, so the
     * sum is exact and independent of the reduction order. */
    size_t n = (size_t)volux_framebuffer_width(fb) * (size_t)volux_framebuffer_height(fb);
    double *mine = malloc(4 * n * sizeof(double)), *all = rank == 0 ? malloc(4 * n * sizeof(double)) : NULL;
    int ok = mine && (rank || all), all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    double wait_start = now_ms();
    MPI_Barrier(MPI_COMM_WORLD);
    timing->wait_ms = now_ms() - wait_start;
    if (all_ok) {
        volux_framebuffer_get_sums(fb, mine, mine + 3 * n);
        double t0 = now_ms();
        /* In pieces: an MPI count is an int. */
        for (size_t at = 0, piece = (size_t)1 << 26; at < 4 * n; at += piece) {
            size_t m = 4 * n - at < piece ? 4 * n - at : piece;
            MPI_Reduce(mine + at, all ? all + at : NULL, (int)m, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
        }
        timing->composite_ms = now_ms() - t0;
        if (rank == 0 && !st) volux_framebuffer_set_sums(fb, all, all + 3 * n, spp);
    } else if (!st) {
        st = VOLUX_ERR_NOMEM;
    }
    free(mine);
    free(all);
    MPI_Win_free(&win);

    double r[2] = {-timing->render_ms, timing->render_ms}, ext[2];
    MPI_Reduce(r, ext, 2, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    timing->rank_render_ms_min = -ext[0];
    timing->rank_render_ms_max = ext[1];
    return st;
}
