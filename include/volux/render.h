/*
 * volux/render.h — the frame loop and the accumulation framebuffer.
 *
 * volux_render() splits the image into 16×16 tiles, renders them on the
 * context's threads (OpenMP) and accumulates one sample index at a time
 * ("waves") into a double-precision framebuffer, so progressive techniques converge and
 * every image is bit-identical for any thread count. It stops at a sample
 * count, a time budget or a target relative standard error, whichever comes
 * first, and reports progress through the context's callback.
 *
 * DOES NOT: know any technique's internals.
 */
#ifndef VOLUX_RENDER_H
#define VOLUX_RENDER_H

#include "base.h"
#include "image.h"
#include "scene.h"
#include "technique.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VOLUX_TILE_SIZE 16

typedef struct volux_framebuffer volux_framebuffer;

VOLUX_API volux_status volux_framebuffer_create(volux_context *ctx, int width, int height,
                                                volux_framebuffer **out);
VOLUX_API void volux_framebuffer_destroy(volux_framebuffer *fb);
/* Samples per pixel: the complete waves. A render cancelled in the middle
 * of a wave leaves some 16×16 tiles one sample ahead; resolve divides each
 * pixel by its own count, and the next volux_render completes that wave
 * first. */
/* Drops all accumulated samples. */
VOLUX_API void volux_framebuffer_reset(volux_framebuffer *fb);
VOLUX_API uint32_t volux_framebuffer_spp(const volux_framebuffer *fb);
VOLUX_API int volux_framebuffer_width(const volux_framebuffer *fb);
VOLUX_API int volux_framebuffer_height(const volux_framebuffer *fb);
/* Mean radiance per pixel into `out` (allocated by this call; free with
 * volux_image_free). */
VOLUX_API volux_status volux_framebuffer_resolve(const volux_framebuffer *fb, volux_image *out);
/* Relative standard error of the mean: sqrt(Σ var_p/n) / (mean luminance)
 * over the n pixels whose luminance samples vary (var_p the variance of
 * the pixel's mean). Pixels whose samples are all equal (background seen
 * straight, empty space) are left out: they would dilute the estimate
 * with values that have nothing left to converge. −1 (not available)
 * below VOLUX_REL_ERROR_MIN_SPP samples, where a variance estimate is too
 * noisy to act on; 0 when no pixel varies. */
#define VOLUX_REL_ERROR_MIN_SPP 4
VOLUX_API double volux_framebuffer_rel_error(const volux_framebuffer *fb);

/* ---- first-hit features (AOVs) ----
 *
 * Asked for with volux_framebuffer_set_features(fb, 1) before rendering,
 * the framebuffer also accumulates, per pixel, what the camera ray meets
 * first — the expectation over the first real collision of delta tracking
 * (a scattering or absorption event) of: its distance from the camera, the
 * scattering albedo there (scene albedo × TF colour), a shading normal
 * (−∇s/|∇s|, facing the camera) and the extinction σt; plus the coverage
 * (the probability that the ray collides at all, 1 − T of the camera ray).
 * Techniques that know them (`pathtrace`, `guided`) compute them by a
 * deterministic march of each sample's camera ray (render/features.h): it
 * takes no random number, so the colour image is bit-identical with or
 * without features. They are taken for the first VOLUX_FEATURE_SAMPLES
 * samples of a pixel only (the march depends only on the pixel jitter, so
 * more samples add little). Not carried by the distributed tile sums
 * (volux_framebuffer_read_tiles). */
#define VOLUX_FEATURE_SAMPLES 4
/* Turns feature accumulation on (allocating 9 doubles per pixel, checked
 * against the context's memory limit: VOLUX_ERR_LIMIT) or off (freeing
 * them). Turning it on drops the samples accumulated so far (the features
 * must cover the same samples). */
VOLUX_API volux_status volux_framebuffer_set_features(volux_framebuffer *fb, int on);
/* 1 when features are on and the technique of the samples wrote them. */
VOLUX_API int volux_framebuffer_has_features(const volux_framebuffer *fb);

/* Resolved features (caller-owned arrays of width·height, rows from the
 * top, freed with volux_features_free). Where no ray sample collided
 * (coverage 0) depth is +inf and albedo, normal, density are 0. */
typedef struct volux_features {
    int width, height;
    float *coverage; /* 1 per pixel: P(collision) ∈ [0, 1]                    */
    float *depth;    /* 1 per pixel: E[distance to the first collision | one] */
    float *albedo;   /* 3 per pixel                                          */
    float *normal;   /* 3 per pixel (mean of unit normals: shorter where they
                        disagree within the pixel)                          */
    float *density;  /* 1 per pixel: σt at the first collision (1/world unit) */
    float *variance; /* 1 per pixel: variance of the pixel's mean luminance
                        (sample variance / spp; −1 below 2 samples)          */
} volux_features;
/* variance is always filled; the feature arrays are NULL when the
 * framebuffer holds none (volux_framebuffer_has_features is 0). */
VOLUX_API volux_status volux_framebuffer_resolve_features(const volux_framebuffer *fb, volux_features *out);
VOLUX_API void volux_features_free(volux_context *ctx, volux_features *f);

typedef struct volux_render_limits {
    uint32_t spp;          /* samples per pixel to reach (total); 0 = 1     */
    double time_ms;        /* stop adding waves after this, and end a wave
                              that runs past it (see report.truncated);
                              0 = no limit                                  */
    double target_error;   /* stop at this rel. standard error; 0 = none    */
} volux_render_limits;

typedef struct volux_render_report {
    uint32_t spp;          /* samples per pixel in the framebuffer          */
    double ms;             /* wall time of this call                        */
    double cpu_ms;         /* process CPU time of this call (all threads)   */
    double rel_error;      /* framebuffer rel. standard error; −1: n/a      */
    uint64_t samples;      /* volume samples taken (if the technique counts)*/
    uint64_t vertices;     /* path vertices (if the technique counts)       */
    int truncated;         /* 1: the time budget ran out inside the first
                              sample of some tiles, whose paths were then
                              cut short (the image is darker than it should
                              be there); later passes that run out are
                              dropped instead                              */
} volux_render_report;

/* Adds samples to fb until a limit is met (limits NULL = the scene's
 * render settings). Brings the technique up to date with the scene first
 * (volux_technique_update; its failure is returned), and drops fb's samples
 * when they were rendered from another technique or an earlier state, so
 * after an edit accumulation restarts by itself. fb must have the scene's
 * image size (else VOLUX_ERR_INVALID). CANCELLED if the progress callback
 * asked to stop (asked per tile and after each wave; fb keeps every tile
 * rendered, see volux_framebuffer_spp). A tile's sample is accumulated only
 * when its pass finished: a pass cut short by the time budget is dropped
 * (the tile keeps its count), except a tile's first sample, kept and
 * reported as truncated. report may be NULL. */
VOLUX_API volux_status volux_render(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                                    const volux_render_limits *limits, volux_render_report *report);

/* ---- building blocks for distributed front ends (tools/mpi) ----
 *
 * A frame is cut into volux_framebuffer_tile_count() tiles of
 * VOLUX_TILE_SIZE², numbered row-major. volux_render_tiles renders samples
 * 0…spp−1 of tiles [tile_first, tile_first + tile_count) into fb from zero
 * (other tiles keep their sums; fb's sample count becomes spp), with exactly
 * the arithmetic of volux_render: a tile's sums are bit-identical to the
 * same tile of a whole-frame volux_render, whichever process rendered it.
 * It brings t up to date like volux_render; time and error limits do not
 * apply. INVALID for a tile range outside the frame.
 *
 *     // a worker: render some tiles, send their sums
 *     volux_render_tiles(t, scene, fb, first, count, spp, NULL);
 *     size_t px = volux_framebuffer_read_tiles(fb, first, count, buf);
 *     ... send buf (px · VOLUX_TILE_SUMS doubles) to the collector ...
 *     // the collector: put them into its frame, then resolve as usual
 *     volux_framebuffer_write_tiles(fb, first, count, buf, spp);
 */
#define VOLUX_TILE_SUMS 4 /* doubles per pixel: Σ R, Σ G, Σ B, Σ luminance² */
VOLUX_API int volux_framebuffer_tile_count(const volux_framebuffer *fb);
VOLUX_API volux_status volux_render_tiles(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                                          int tile_first, int tile_count, uint32_t spp,
                                          volux_render_report *report);
/* Pixels in tiles [first, first + count) (0 for a range outside the frame). */
VOLUX_API size_t volux_framebuffer_tile_pixels(const volux_framebuffer *fb, int first, int count);
/* Copies the sums of tiles [first, first + count) into out (caller-owned,
 * volux_framebuffer_tile_pixels · VOLUX_TILE_SUMS doubles), tile by tile,
 * rows top to bottom; returns the pixel count (0: range outside the frame,
 * nothing copied). */
VOLUX_API size_t volux_framebuffer_read_tiles(const volux_framebuffer *fb, int first, int count, double *out);
/* The reverse: replaces those tiles' sums with `in` and sets fb's sample
 * count to spp; returns the pixel count (0: range outside, nothing done). */
VOLUX_API size_t volux_framebuffer_write_tiles(volux_framebuffer *fb, int first, int count, const double *in,
                                               uint32_t spp);

/* ---- data-parallel (sort-last) rendering of one brick ----
 *
 * When the scene's volume is one brick of a whole grid (volux_volume_brick;
 * io.h: volux_volume_load_options.region), renders sample `sample_index`
 * of every pixel (the same camera ray and jitter as that sample of
 * volux_render) through the brick's owned box only, with the camera and
 * the sample lattice of the whole volume (each ray's samples at the whole
 * box's t0 + (k + jitter)·step, every segment integrated by exactly one
 * brick), into rgbt[(y·width + x)·4] (caller-owned, width·height·4 floats,
 * rows from the top): premultiplied radiance R, G, B and the transmittance
 * T through the brick. *position (may be NULL) is the brick's place in the
 * visibility order of this view (0 = front; the k-d tree's cut planes
 * ordered by the side of the eye, or by the view direction for an
 * orthographic camera). The back brick adds the background behind it
 * (C + T·L_bg), so compositing all bricks of one sample front to back with
 * "over", (C1, T1) over (C2, T2) = (C1 + T1·C2, T1·T2), gives that sample
 * of the image in R, G, B; the pixel is the mean over samples (composite
 * per sample: "over" does not commute with the mean). An ordinary volume
 * is one brick (position 0, the whole image). Brings t up to date like
 * volux_render. Only techniques whose light stays on the camera ray render
 * a brick (`ea`, `shaded`); others: VOLUX_ERR_UNSUPPORTED. Differences
 * from volux_render: always the scalar kernel; early termination acts per
 * brick (a brick behind an opaque one still adds its ≤ early_termination
 * share). */
VOLUX_API volux_status volux_render_part(volux_technique *t, const volux_scene *scene, uint32_t sample_index,
                                         float *rgbt, int *position, volux_render_report *report);

#ifdef __cplusplus
}
#endif
#endif
