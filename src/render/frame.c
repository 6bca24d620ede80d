/*
 * render/frame.c — the frame loop: tiles × sample waves, accumulation,
 * limits, progress and cancel (pbrt's ImageTileIntegrator role).
 *
 * Each wave renders one sample index for every tile in parallel; a pixel is
 * written by exactly one tile per wave and waves run in order, so the sums
 * are accumulated in the same order for any thread count (bit-identical
 * images).
 */
#include <math.h>
#include <string.h>
#include <time.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "features.h"
#include "memory_model.h"
#include "raycaster.h"
#include "technique_class.h"
#include "volux/denoise.h"
#include "volux/render.h"

struct volux_framebuffer {
    volux_context *ctx;
    int width, height;
    uint32_t spp;   /* complete waves: every tile has at least this many */
    double *sum;    /* 3 per pixel: Σ radiance               */
    double *sum_sq; /* 1 per pixel: Σ luminance²             */
    /* Samples per tile: a wave cancelled half-way leaves some tiles one
     * sample ahead; each pixel's mean divides by its own tile's count, so
     * the image so far is consistent, and the next render fills in the
     * missing tiles first. */
    uint32_t *tile_spp;
    int tiles_x, tiles;
    uint64_t generation; /* technique generation the samples came from (0: none) */
    /* First-hit features (volux_framebuffer_set_features; NULL: off):
     * VOLUX_FEATURE_FLOATS sums per pixel over its first
     * min(spp, VOLUX_FEATURE_SAMPLES) samples (render/features.h). */
    double *feat;
    int feat_written; /* the technique wrote them (else they stay 0) */
};

static uint32_t pixel_spp(const volux_framebuffer *fb, size_t p) {
    size_t x = p % (size_t)fb->width, y = p / (size_t)fb->width;
    return fb->tile_spp[(y / VOLUX_TILE_SIZE) * (size_t)fb->tiles_x + x / VOLUX_TILE_SIZE];
}

volux_status volux_framebuffer_create(volux_context *ctx, int width, int height, volux_framebuffer **out) {
    if (width < 1 || height < 1 || width > VOLUX_MAX_IMAGE_DIM || height > VOLUX_MAX_IMAGE_DIM)
        return volux_error(ctx, VOLUX_ERR_INVALID, "framebuffer size %dx%d is outside [1, %d]", width, height,
                           VOLUX_MAX_IMAGE_DIM);
    size_t n = (size_t)width * (size_t)height;
    /* The memory budget (docs/SCALE.md): what the context holds already
     * (volume, technique caches) plus this framebuffer and the image it
     * resolves to. */
    uint64_t held = volux_context_bytes_in_use(ctx),
             need = (uint64_t)n * (VOLUX_MM_FRAMEBUFFER_PER_PIXEL + VOLUX_MM_IMAGE_PER_PIXEL),
             limit = volux_context_memory_limit(ctx);
    if (held + need > limit) {
        char a[32], b[32], l[32];
        volux_format_bytes(need, a, sizeof a);
        volux_format_bytes(held, b, sizeof b);
        volux_format_bytes(limit, l, sizeof l);
        return volux_error(ctx, VOLUX_ERR_LIMIT,
                           "framebuffer %dx%d: it and its image need an estimated %s, with the %s already allocated "
                           "more than the memory limit of %s (%llu bytes%s); lower the image size or raise the limit",
                           width, height, a, b, l, (unsigned long long)limit,
                           volux_context_memory_limit_is_default(ctx) ? ", 80% of physical memory" : "");
    }
    volux_framebuffer *fb = volux_calloc(ctx, 1, sizeof *fb);
    if (!fb) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a framebuffer");
    fb->ctx = ctx;
    fb->width = width;
    fb->height = height;
    fb->tiles_x = (width + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE;
    fb->tiles = fb->tiles_x * ((height + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE);
    fb->sum = volux_calloc(ctx, 3 * n, sizeof(double));
    fb->sum_sq = volux_calloc(ctx, n, sizeof(double));
    fb->tile_spp = volux_calloc(ctx, (size_t)fb->tiles, sizeof(uint32_t));
    if (!fb->sum || !fb->sum_sq || !fb->tile_spp) {
        volux_framebuffer_destroy(fb);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a %dx%d framebuffer", width, height);
    }
    *out = fb;
    return VOLUX_OK;
}

void volux_framebuffer_destroy(volux_framebuffer *fb) {
    if (!fb) return;
    size_t n = (size_t)fb->width * (size_t)fb->height;
    volux_free(fb->ctx, fb->sum, 3 * n * sizeof(double));
    volux_free(fb->ctx, fb->sum_sq, n * sizeof(double));
    volux_free(fb->ctx, fb->tile_spp, (size_t)fb->tiles * sizeof(uint32_t));
    volux_free(fb->ctx, fb->feat, VOLUX_FEATURE_FLOATS * n * sizeof(double));
    volux_free(fb->ctx, fb, sizeof *fb);
}

void volux_framebuffer_reset(volux_framebuffer *fb) {
    size_t n = (size_t)fb->width * (size_t)fb->height;
    memset(fb->sum, 0, 3 * n * sizeof(double));
    memset(fb->sum_sq, 0, n * sizeof(double));
    memset(fb->tile_spp, 0, (size_t)fb->tiles * sizeof(uint32_t));
    if (fb->feat) memset(fb->feat, 0, VOLUX_FEATURE_FLOATS * n * sizeof(double));
    fb->feat_written = 0;
    fb->spp = 0;
    fb->generation = 0;
}

volux_status volux_framebuffer_set_features(volux_framebuffer *fb, int on) {
    size_t n = (size_t)fb->width * (size_t)fb->height, bytes = VOLUX_FEATURE_FLOATS * n * sizeof(double);
    if (!on) {
        volux_free(fb->ctx, fb->feat, bytes);
        fb->feat = NULL;
        fb->feat_written = 0;
        return VOLUX_OK;
    }
    if (fb->feat) return VOLUX_OK;
    uint64_t held = volux_context_bytes_in_use(fb->ctx), limit = volux_context_memory_limit(fb->ctx);
    if (held + bytes > limit)
        return volux_error(fb->ctx, VOLUX_ERR_LIMIT,
                           "framebuffer %dx%d: its first-hit features need %llu bytes more than the memory limit "
                           "of %llu bytes allows",
                           fb->width, fb->height, (unsigned long long)(held + bytes - limit),
                           (unsigned long long)limit);
    fb->feat = volux_calloc(fb->ctx, VOLUX_FEATURE_FLOATS * n, sizeof(double));
    if (!fb->feat) return volux_error(fb->ctx, VOLUX_ERR_NOMEM, "out of memory for %dx%d feature buffers", fb->width,
                                      fb->height);
    /* The features must cover the same samples as the colour. */
    volux_framebuffer_reset(fb);
    return VOLUX_OK;
}

int volux_framebuffer_has_features(const volux_framebuffer *fb) { return fb->feat && fb->feat_written; }

uint32_t volux_framebuffer_spp(const volux_framebuffer *fb) { return fb->spp; }
int volux_framebuffer_width(const volux_framebuffer *fb) { return fb->width; }
int volux_framebuffer_height(const volux_framebuffer *fb) { return fb->height; }

volux_status volux_framebuffer_resolve(const volux_framebuffer *fb, volux_image *out) {
    volux_status st = volux_image_create(fb->ctx, fb->width, fb->height, out);
    if (st) return st;
    size_t n = (size_t)fb->width * (size_t)fb->height;
    for (size_t p = 0; p < n; p++) {
        uint32_t k = pixel_spp(fb, p);
        double inv = k ? 1.0 / k : 0.0;
        for (int c = 0; c < 3; c++) out->rgb[3 * p + (size_t)c] = (float)(fb->sum[3 * p + (size_t)c] * inv);
    }
    return VOLUX_OK;
}

static void free_features(volux_context *ctx, volux_features *f) {
    size_t n = (size_t)f->width * (size_t)f->height;
    volux_free(ctx, f->coverage, n * sizeof(float));
    volux_free(ctx, f->depth, n * sizeof(float));
    volux_free(ctx, f->albedo, 3 * n * sizeof(float));
    volux_free(ctx, f->normal, 3 * n * sizeof(float));
    volux_free(ctx, f->density, n * sizeof(float));
    volux_free(ctx, f->variance, n * sizeof(float));
    memset(f, 0, sizeof *f);
}

void volux_features_free(volux_context *ctx, volux_features *f) {
    if (f) free_features(ctx, f);
}

volux_status volux_framebuffer_resolve_features(const volux_framebuffer *fb, volux_features *out) {
    memset(out, 0, sizeof *out);
    out->width = fb->width;
    out->height = fb->height;
    size_t n = (size_t)fb->width * (size_t)fb->height;
    int feat = volux_framebuffer_has_features(fb);
    out->variance = volux_malloc(fb->ctx, n * sizeof(float));
    if (feat) {
        out->coverage = volux_malloc(fb->ctx, n * sizeof(float));
        out->depth = volux_malloc(fb->ctx, n * sizeof(float));
        out->albedo = volux_malloc(fb->ctx, 3 * n * sizeof(float));
        out->normal = volux_malloc(fb->ctx, 3 * n * sizeof(float));
        out->density = volux_malloc(fb->ctx, n * sizeof(float));
    }
    if (!out->variance ||
        (feat && (!out->coverage || !out->depth || !out->albedo || !out->normal || !out->density))) {
        free_features(fb->ctx, out);
        return volux_error(fb->ctx, VOLUX_ERR_NOMEM, "out of memory for %dx%d feature images", fb->width, fb->height);
    }
    for (size_t p = 0; p < n; p++) {
        double k = pixel_spp(fb, p);
        const double *c = &fb->sum[3 * p];
        double mean = (0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]) / (k > 0 ? k : 1);
        double var = k >= 2 ? (fb->sum_sq[p] / k - mean * mean) * k / (k - 1.0) / k : -1.0;
        out->variance[p] = (float)(var < 0.0 && k >= 2 ? 0.0 : var);
        if (!feat) continue;
        const double *f = &fb->feat[VOLUX_FEATURE_FLOATS * p];
        double kf = k < VOLUX_FEATURE_SAMPLES ? k : VOLUX_FEATURE_SAMPLES, w = f[0];
        out->coverage[p] = kf > 0 ? (float)(w / kf) : 0.0f;
        double inv = w > 0.0 ? 1.0 / w : 0.0;
        out->depth[p] = w > 0.0 ? (float)(f[1] * inv) : INFINITY;
        for (int a = 0; a < 3; a++) {
            out->albedo[3 * p + (size_t)a] = (float)(f[2 + a] * inv);
            out->normal[3 * p + (size_t)a] = (float)(f[5 + a] * inv);
        }
        out->density[p] = (float)(f[8] * inv);
    }
    return VOLUX_OK;
}

volux_status volux_framebuffer_denoise(const volux_framebuffer *fb, const volux_denoise_settings *settings,
                                       volux_image *out) {
    volux_image raw = {0};
    volux_features f;
    volux_status st = volux_framebuffer_resolve(fb, &raw);
    if (st) return st;
    if ((st = volux_framebuffer_resolve_features(fb, &f))) {
        volux_image_free(fb->ctx, &raw);
        return st;
    }
    st = volux_denoise(fb->ctx, &raw, &f, fb->spp, settings, out);
    volux_features_free(fb->ctx, &f);
    volux_image_free(fb->ctx, &raw);
    return st;
}

static double luminance(const double *c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

double volux_framebuffer_rel_error(const volux_framebuffer *fb) {
    if (fb->spp < VOLUX_REL_ERROR_MIN_SPP) return -1.0;
    size_t n = (size_t)fb->width * (size_t)fb->height, noisy = 0;
    double var_sum = 0.0, mean_sum = 0.0;
    for (size_t i = 0; i < n; i++) {
        double k = pixel_spp(fb, i);
        if (k < 2.0) continue; /* a tile this process did not render (volux_render_tiles) */
        double mean = luminance(&fb->sum[3 * i]) / k;
        double var = (fb->sum_sq[i] / k - mean * mean) * k / (k - 1.0); /* sample variance */
        /* A pixel whose samples agree (background seen straight, empty
         * space) has nothing left to converge: counting its value in the
         * mean would dilute the error of the pixels that do. "Agree" is
         * one 8-bit level: a per-sample standard deviation under 1/256 of
         * the pixel's value, invisible even at 1 spp. It also absorbs the
         * rounding of the sums and the tiny spread of an environment map
         * seen through a jittered pixel, which is not noise anyone sees. */
        if (!(var > mean * mean * (1.0 / (256.0 * 256.0)))) continue;
        var_sum += var / k; /* variance of the pixel mean */
        mean_sum += mean;
        noisy++;
    }
    if (noisy == 0 || mean_sum <= 0.0) return 0.0;
    /* RMS standard error over the noisy pixels relative to their mean value. */
    return sqrt(var_sum / (double)noisy) / (mean_sum / (double)noisy);
}

typedef struct wave_job {
    const volux_technique_class *cls;
    const void *state;
    const volux_scene *scene;
    volux_framebuffer *fb;
    volux_context *ctx;
    int tiles_x, tile_first, tiles_total;
    uint32_t sample_index;
    volux_tile_stats *stats; /* per tile */
    int *done_tiles;
    int *progress_busy;
    int *cancelled;
    double progress_base, progress_span;
    volux_deadline *deadline; /* NULL: no time budget                      */
    int *truncated;           /* set when a tile's first sample was cut short */
    int64_t next_poll_us;     /* volux_tile_cancelled: next callback poll     */
} wave_job;

int volux_tile_expired(const volux_tile *t) { return volux_deadline_expired(t->deadline); }

static double now_ms(void);

int volux_tile_cancelled(const volux_tile *t) {
    wave_job *job = t->wave;
    if (!job) return 0;
    if (__atomic_load_n(job->cancelled, __ATOMIC_RELAXED)) return 1;
    int64_t now = (int64_t)(now_ms() * 1e3);
    if (now < __atomic_load_n(&job->next_poll_us, __ATOMIC_RELAXED)) return 0;
    /* The callback is never called concurrently: whoever holds the flag. */
    if (__atomic_exchange_n(job->progress_busy, 1, __ATOMIC_ACQUIRE)) return 0;
    __atomic_store_n(&job->next_poll_us, now + 10000, __ATOMIC_RELAXED);
    int done = __atomic_load_n(job->done_tiles, __ATOMIC_RELAXED);
    double f = job->progress_base + job->progress_span * (double)done / (double)job->tiles_total;
    int cancel = volux_progress(job->ctx, "render", f < 1.0 ? f : 0.999);
    if (cancel) __atomic_store_n(job->cancelled, 1, __ATOMIC_RELAXED);
    __atomic_store_n(job->progress_busy, 0, __ATOMIC_RELEASE);
    return cancel;
}

static int deadline_expired(const volux_deadline *d) { return d && __atomic_load_n(&d->expired, __ATOMIC_RELAXED); }

static void render_one_tile(void *user, int64_t slot, int thread) {
    (void)thread;
    wave_job *job = user;
    if (__atomic_load_n(job->cancelled, __ATOMIC_RELAXED)) return;
    volux_framebuffer *fb = job->fb;
    int64_t index = job->tile_first + slot;
    /* Already has this sample (from a wave that was cancelled or cut short
     * half-way). */
    if (fb->tile_spp[index] > job->sample_index) return;
    /* After the time budget ran out only tiles without any sample are
     * still rendered (their paths end at once: the image then covers the
     * whole frame, darker where the budget ran out). */
    if (fb->tile_spp[index] > 0 && deadline_expired(job->deadline)) return;
    volux_tile tile;
    tile.x0 = (int)(index % job->tiles_x) * VOLUX_TILE_SIZE;
    tile.y0 = (int)(index / job->tiles_x) * VOLUX_TILE_SIZE;
    tile.w = fb->width - tile.x0 < VOLUX_TILE_SIZE ? fb->width - tile.x0 : VOLUX_TILE_SIZE;
    tile.h = fb->height - tile.y0 < VOLUX_TILE_SIZE ? fb->height - tile.y0 : VOLUX_TILE_SIZE;
    tile.sample_index = job->sample_index;
    tile.deadline = job->deadline;
    tile.wave = job->ctx->progress ? job : NULL;
    float rgb[VOLUX_TILE_SIZE * VOLUX_TILE_SIZE * 3];
    memset(rgb, 0, sizeof rgb);
    float feat[VOLUX_TILE_SIZE * VOLUX_TILE_SIZE * VOLUX_FEATURE_FLOATS];
    tile.features = fb->feat && job->sample_index < VOLUX_FEATURE_SAMPLES ? feat : NULL;
    volux_tile_stats *stats = &job->stats[slot];
    job->cls->render_tile(job->state, job->scene, &tile, rgb, stats);
    /* cancelled inside the tile (volux_tile_cancelled): its pass may be
     * unfinished; dropped like the rest of the wave */
    if (__atomic_load_n(job->cancelled, __ATOMIC_RELAXED)) return;
    /* A pass is accumulated only when it finished: paths see the deadline
     * (volux_tile_expired, which sets the flag) and end early, so once it
     * has expired this tile's pass may be cut short and biased dark. It is
     * dropped — the tile keeps its count and sums, consistent — unless it
     * is the tile's first sample, kept (and reported) so there is an image. */
    if (deadline_expired(job->deadline)) {
        if (fb->tile_spp[index] > 0) return;
        __atomic_store_n(job->truncated, 1, __ATOMIC_RELAXED);
    }
    for (int y = 0; y < tile.h; y++)
        for (int x = 0; x < tile.w; x++) {
            size_t p = (size_t)(tile.y0 + y) * (size_t)fb->width + (size_t)(tile.x0 + x);
            const float *c = &rgb[3 * (y * tile.w + x)];
            double lum = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
            fb->sum[3 * p + 0] += c[0];
            fb->sum[3 * p + 1] += c[1];
            fb->sum[3 * p + 2] += c[2];
            fb->sum_sq[p] += lum * lum;
        }
    if (tile.features && stats->features) {
        for (int y = 0; y < tile.h; y++)
            for (int x = 0; x < tile.w; x++) {
                size_t p = (size_t)(tile.y0 + y) * (size_t)fb->width + (size_t)(tile.x0 + x);
                for (int k = 0; k < VOLUX_FEATURE_FLOATS; k++)
                    fb->feat[VOLUX_FEATURE_FLOATS * p + (size_t)k] += feat[VOLUX_FEATURE_FLOATS * (y * tile.w + x) + k];
            }
        __atomic_store_n(&fb->feat_written, 1, __ATOMIC_RELAXED);
    }
    fb->tile_spp[index] = job->sample_index + 1;
    int done = __atomic_add_fetch(job->done_tiles, 1, __ATOMIC_RELAXED);
    /* Progress from whichever thread gets the flag; never concurrently. */
    if (job->ctx->progress && !__atomic_exchange_n(job->progress_busy, 1, __ATOMIC_ACQUIRE)) {
        double f = job->progress_base + job->progress_span * (double)done / (double)job->tiles_total;
        if (volux_progress(job->ctx, "render", f < 1.0 ? f : 0.999)) __atomic_store_n(job->cancelled, 1, __ATOMIC_RELAXED);
        __atomic_store_n(job->progress_busy, 0, __ATOMIC_RELEASE);
    }
}

static double clock_ms(clockid_t id) {
    struct timespec ts;
    clock_gettime(id, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}
static double now_ms(void) { return clock_ms(CLOCK_MONOTONIC); }


/* Brings t up to date and drops fb's samples from another state. */
static volux_status prepare(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb) {
    const volux_render_settings *rs = volux_scene_render(scene);
    if (fb->width != rs->width || fb->height != rs->height)
        return volux_error(fb->ctx, VOLUX_ERR_INVALID, "framebuffer is %dx%d but the scene renders %dx%d", fb->width,
                           fb->height, rs->width, rs->height);
    /* A technique never renders a scene it is not up to date with, and a
     * framebuffer never mixes samples of two states. */
    volux_status st = volux_technique_update(t, scene, NULL);
    if (st) return st;
    if (fb->generation != volux_technique_generation(t)) {
        if (fb->spp) volux_framebuffer_reset(fb);
        fb->generation = volux_technique_generation(t);
    }
    return VOLUX_OK;
}

/* The wave loop of volux_render and volux_render_tiles over the tiles
 * [tile_first, tile_first + tile_count): waves fb->spp, fb->spp + 1, … until
 * lim says stop. Every pixel of a tile is accumulated in sample order, so a
 * tile's sums do not depend on which other tiles were rendered with it. */
static volux_status render_waves(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                                 int tile_first, int tile_count, volux_render_limits lim,
                                 volux_render_report *report) {
    volux_context *ctx = fb->ctx;
    const volux_render_settings *rs = volux_scene_render(scene);
    const volux_technique_class *cls = volux_technique_class_of(t);
    int tiles_x = (fb->width + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE;
    volux_tile_stats *stats = volux_calloc(ctx, (size_t)tile_count, sizeof *stats);
    if (!stats) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for tile statistics");
    int threads = rs->threads > 0 ? rs->threads : volux_context_threads(ctx);
    int done = 0, busy = 0, cancelled = 0, truncated = 0;
    double start = now_ms(), cpu_start = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
    volux_deadline deadline = {start + lim.time_ms, 0};
    wave_job job = {cls,   volux_technique_state(t), scene,      fb,  ctx, tiles_x, tile_first, tile_count, 0,
                    stats, &done,                    &busy,      &cancelled, 0.0, 1.0,
                    lim.time_ms > 0.0 ? &deadline : NULL,        &truncated, 0};
    volux_status st = VOLUX_OK;
    uint32_t start_spp = fb->spp;
    uint64_t samples = 0, vertices = 0;
    while (fb->spp < lim.spp) {
        job.sample_index = fb->spp;
        if ((st = volux_technique_begin_pass(t, scene, job.sample_index))) break;
        done = 0;
        uint32_t waves = lim.spp - start_spp;
        job.progress_base = waves ? (double)(fb->spp - start_spp) / waves : 0.0;
        job.progress_span = waves ? 1.0 / waves : 1.0;
        memset(stats, 0, (size_t)tile_count * sizeof *stats);
        volux_parallel_for(threads, tile_count, render_one_tile, &job);
        if (cancelled) {
            st = volux_error(ctx, VOLUX_ERR_CANCELLED, "render cancelled");
            break;
        }
        for (int i = 0; i < tile_count; i++) {
            samples += stats[i].samples;
            vertices += stats[i].vertices;
        }
        /* The wave is complete when every tile has its sample; a wave the
         * budget cut short leaves some tiles a sample ahead (as a cancel
         * does) and ends the render. */
        int complete = 1;
        for (int i = tile_first; i < tile_first + tile_count; i++)
            if (fb->tile_spp[i] <= job.sample_index) complete = 0;
        if (!complete) break;
        fb->spp++;
        if (lim.time_ms > 0.0 && now_ms() - start >= lim.time_ms) break;
        if (lim.target_error > 0.0 && fb->spp >= VOLUX_REL_ERROR_MIN_SPP) {
            double e = volux_framebuffer_rel_error(fb);
            if (e >= 0.0 && e <= lim.target_error) break;
        }
        /* A cancel asked for between waves (nothing left to skip in the
         * wave that just ended) still stops here. */
        if (ctx->progress && volux_progress(ctx, "render", fmin(0.999, waves ? (double)(fb->spp - start_spp) / waves : 0.0))) {
            st = volux_error(ctx, VOLUX_ERR_CANCELLED, "render cancelled");
            break;
        }
    }
    volux_progress(ctx, "render", 1.0);
    if (truncated)
        volux_warn(ctx,
                   "render: the time budget of %g ms ran out inside the first sample; its paths were cut short "
                   "(the image is darker than it should be)",
                   lim.time_ms);
    volux_free(ctx, stats, (size_t)tile_count * sizeof *stats);
    if (report) {
        report->truncated = truncated;
        report->spp = fb->spp;
        report->ms = now_ms() - start;
        report->cpu_ms = clock_ms(CLOCK_PROCESS_CPUTIME_ID) - cpu_start;
        report->rel_error = volux_framebuffer_rel_error(fb);
        report->samples = samples;
        report->vertices = vertices;
    }
    return st;
}

static int tile_count_of(const volux_framebuffer *fb) {
    return ((fb->width + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE) * ((fb->height + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE);
}

int volux_framebuffer_tile_count(const volux_framebuffer *fb) { return tile_count_of(fb); }

volux_status volux_render(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                          const volux_render_limits *limits, volux_render_report *report) {
    volux_status st = prepare(t, scene, fb);
    if (st) return st;
    const volux_render_settings *rs = volux_scene_render(scene);
    volux_render_limits lim = {(uint32_t)rs->spp, rs->time_ms, rs->target_error};
    if (limits) lim = *limits;
    if (lim.spp == 0) lim.spp = 1;
    if (!volux_technique_class_of(t)->info.progressive && lim.spp > 1 && lim.target_error > 0.0)
        lim.target_error = 0.0;
    return render_waves(t, scene, fb, 0, tile_count_of(fb), lim, report);
}

/* The pixels of tile `index` (row-major tiles of VOLUX_TILE_SIZE²). */
static void tile_rect(const volux_framebuffer *fb, int index, int *x0, int *y0, int *w, int *h) {
    int tiles_x = (fb->width + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE;
    *x0 = (index % tiles_x) * VOLUX_TILE_SIZE;
    *y0 = (index / tiles_x) * VOLUX_TILE_SIZE;
    *w = fb->width - *x0 < VOLUX_TILE_SIZE ? fb->width - *x0 : VOLUX_TILE_SIZE;
    *h = fb->height - *y0 < VOLUX_TILE_SIZE ? fb->height - *y0 : VOLUX_TILE_SIZE;
}

/* Copies the sums of tiles [first, first + count) to (to_packed) or from a
 * packed run of VOLUX_TILE_SUMS doubles per pixel, tile by tile, row by
 * row; returns the number of pixels. packed NULL: only counts. */
static size_t copy_tiles(volux_framebuffer *fb, int first, int count, double *packed, int to_packed) {
    size_t k = 0;
    for (int i = first; i < first + count; i++) {
        int x0, y0, w, h;
        tile_rect(fb, i, &x0, &y0, &w, &h);
        for (int y = y0; y < y0 + h; y++)
            for (int x = x0; x < x0 + w; x++, k++) {
                size_t p = (size_t)y * (size_t)fb->width + (size_t)x;
                if (!packed) continue;
                double *q = &packed[VOLUX_TILE_SUMS * k];
                if (to_packed) {
                    q[0] = fb->sum[3 * p];
                    q[1] = fb->sum[3 * p + 1];
                    q[2] = fb->sum[3 * p + 2];
                    q[3] = fb->sum_sq[p];
                } else {
                    fb->sum[3 * p] = q[0];
                    fb->sum[3 * p + 1] = q[1];
                    fb->sum[3 * p + 2] = q[2];
                    fb->sum_sq[p] = q[3];
                }
            }
    }
    return k;
}

static int tile_range_ok(const volux_framebuffer *fb, int first, int count) {
    int total = tile_count_of(fb);
    return first >= 0 && count >= 0 && first <= total - count;
}

volux_status volux_render_tiles(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb, int tile_first,
                                int tile_count, uint32_t spp, volux_render_report *report) {
    int total = tile_count_of(fb);
    if (tile_first < 0 || tile_count < 1 || tile_first > total - tile_count)
        return volux_error(fb->ctx, VOLUX_ERR_INVALID, "tiles %d..%d are outside the frame's %d tiles", tile_first,
                           tile_first + tile_count - 1, total);
    volux_status st = prepare(t, scene, fb);
    if (st) return st;
    /* Restart these tiles from zero samples; the frame's sample count is
     * the one every rendered tile has. */
    for (int i = tile_first; i < tile_first + tile_count; i++) {
        int x0, y0, w, h;
        tile_rect(fb, i, &x0, &y0, &w, &h);
        for (int y = y0; y < y0 + h; y++) {
            size_t p = (size_t)y * (size_t)fb->width + (size_t)x0;
            memset(&fb->sum[3 * p], 0, 3 * (size_t)w * sizeof(double));
            memset(&fb->sum_sq[p], 0, (size_t)w * sizeof(double));
            if (fb->feat) memset(&fb->feat[VOLUX_FEATURE_FLOATS * p], 0, VOLUX_FEATURE_FLOATS * (size_t)w * sizeof(double));
        }
        fb->tile_spp[i] = 0;
    }
    fb->spp = 0;
    volux_render_limits lim = {spp ? spp : 1, 0.0, 0.0};
    return render_waves(t, scene, fb, tile_first, tile_count, lim, report);
}

size_t volux_framebuffer_tile_pixels(const volux_framebuffer *fb, int first, int count) {
    if (!tile_range_ok(fb, first, count)) return 0;
    return copy_tiles((volux_framebuffer *)fb, first, count, NULL, 0);
}

size_t volux_framebuffer_read_tiles(const volux_framebuffer *fb, int first, int count, double *out) {
    if (!tile_range_ok(fb, first, count)) return 0;
    return copy_tiles((volux_framebuffer *)fb, first, count, out, 1);
}

size_t volux_framebuffer_write_tiles(volux_framebuffer *fb, int first, int count, const double *in, uint32_t spp) {
    if (!tile_range_ok(fb, first, count)) return 0;
    fb->spp = spp;
    /* Those tiles now hold spp samples (another process rendered them). */
    for (int i = first; i < first + count; i++) fb->tile_spp[i] = spp;
    return copy_tiles(fb, first, count, (double *)in, 0);
}

/* ------------------------------------------------------------ bricks */

typedef struct part_job {
    const volux_technique_class *cls;
    const void *state;
    const volux_scene *scene;
    int width, height, tiles_x, background;
    uint32_t sample_index;
    float *rgbt;
    volux_tile_stats *stats; /* per tile */
} part_job;

/* One sample of one tile. */
static void render_part_tile(void *user, int64_t index, int thread) {
    (void)thread;
    part_job *job = user;
    volux_tile tile;
    tile.x0 = (int)(index % job->tiles_x) * VOLUX_TILE_SIZE;
    tile.y0 = (int)(index / job->tiles_x) * VOLUX_TILE_SIZE;
    tile.w = job->width - tile.x0 < VOLUX_TILE_SIZE ? job->width - tile.x0 : VOLUX_TILE_SIZE;
    tile.h = job->height - tile.y0 < VOLUX_TILE_SIZE ? job->height - tile.y0 : VOLUX_TILE_SIZE;
    tile.sample_index = job->sample_index;
    tile.deadline = NULL;
    tile.wave = NULL;
    tile.features = NULL;
    float one[VOLUX_TILE_SIZE * VOLUX_TILE_SIZE * 4];
    job->cls->render_tile_part(job->state, job->scene, &tile, job->background, one, &job->stats[index]);
    for (int y = 0; y < tile.h; y++)
        memcpy(job->rgbt + 4 * ((size_t)(tile.y0 + y) * (size_t)job->width + (size_t)tile.x0), one + 4 * y * tile.w,
               4 * (size_t)tile.w * sizeof(float));
}

volux_status volux_render_part(volux_technique *t, const volux_scene *scene, uint32_t sample_index, float *rgbt,
                               int *position, volux_render_report *report) {
    const volux_technique_class *cls = volux_technique_class_of(t);
    const volux_raycaster *rc = volux_technique_state(t);
    volux_context *ctx = rc->ctx;
    if (!rgbt) return volux_error(ctx, VOLUX_ERR_INVALID, "render_part: the output buffer is NULL");
    if (!cls->render_tile_part)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                           "technique '%s' cannot render one brick of a volume (its light leaves the camera ray); "
                           "data-parallel rendering supports ea and shaded",
                           cls->info.name);
    volux_status st = volux_technique_update(t, scene, NULL);
    if (st) return st;
    const volux_render_settings *rs = volux_scene_render(scene);
    const volux_volume *v = rc->volume;
    int pos = 0, count = v->part_count ? v->part_count : 1;
    if (v->part_count) {
        /* The ghost layers must hold a segment's front sample, up to one
         * step before the owned box (and its trilinear corners). */
        int ghost = 1 << 20;
        for (int a = 0; a < 3; a++) {
            if (v->owned_lo[a] > 0 && v->owned_lo[a] - v->stored_lo[a] < ghost) ghost = v->owned_lo[a] - v->stored_lo[a];
            int stored_hi = v->stored_lo[a] + v->dims[a] - 1;
            if (v->owned_hi[a] < v->whole_dims[a] - 1 && stored_hi - v->owned_hi[a] < ghost)
                ghost = stored_hi - v->owned_hi[a];
        }
        if (rc->step > (float)ghost * rc->min_spacing)
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                               "render.step: %g world units is longer than the brick's %d ghost layers (%g); "
                               "a data-parallel render needs a step of at most that",
                               rc->step, ghost, ghost * rc->min_spacing);
    }
    if (v->part_count) {
        int *order = volux_malloc(ctx, (size_t)count * sizeof *order);
        if (!order) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the brick order");
        double o[3] = {v->whole_origin.x, v->whole_origin.y, v->whole_origin.z};
        volux_brick_visibility_order(v->whole_dims, count, o, v->spacing,
                                     rc->camera.projection == VOLUX_ORTHOGRAPHIC, rc->camera.eye,
                                     rc->camera.forward, order);
        for (int i = 0; i < count; i++)
            if (order[i] == v->part_index) pos = i;
        volux_free(ctx, order, (size_t)count * sizeof *order);
    }
    int tiles_x = (rs->width + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE;
    int tiles_y = (rs->height + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE;
    int64_t tiles = (int64_t)tiles_x * tiles_y;
    volux_tile_stats *stats = volux_calloc(ctx, (size_t)tiles, sizeof *stats);
    if (!stats) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for tile statistics");
    part_job job = {cls,      volux_technique_state(t), scene, rs->width, rs->height, tiles_x, pos == count - 1,
                    sample_index, rgbt, stats};
    int threads = rs->threads > 0 ? rs->threads : volux_context_threads(ctx);
    double start = now_ms(), cpu_start = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
    volux_parallel_for(threads, tiles, render_part_tile, &job);
    uint64_t samples = 0;
    for (int64_t i = 0; i < tiles; i++) samples += stats[i].samples;
    volux_free(ctx, stats, (size_t)tiles * sizeof *stats);
    if (position) *position = pos;
    if (report) {
        memset(report, 0, sizeof *report);
        report->spp = 1;
        report->ms = now_ms() - start;
        report->cpu_ms = clock_ms(CLOCK_PROCESS_CPUTIME_ID) - cpu_start;
        report->rel_error = -1.0;
        report->samples = samples;
    }
    return VOLUX_OK;
}
