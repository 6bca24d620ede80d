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
/* Drops all accumulated samples. */
VOLUX_API void volux_framebuffer_reset(volux_framebuffer *fb);
VOLUX_API uint32_t volux_framebuffer_spp(const volux_framebuffer *fb);
VOLUX_API int volux_framebuffer_width(const volux_framebuffer *fb);
VOLUX_API int volux_framebuffer_height(const volux_framebuffer *fb);
/* Mean radiance per pixel into `out` (allocated by this call; free with
 * volux_image_free). */
VOLUX_API volux_status volux_framebuffer_resolve(const volux_framebuffer *fb, volux_image *out);
/* Relative standard error of the mean: sqrt(Σ var_p/n) / (mean luminance),
 * from per-pixel sample variances of luminance; 0 with < 2 samples. */
VOLUX_API double volux_framebuffer_rel_error(const volux_framebuffer *fb);

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
    double rel_error;      /* framebuffer rel. standard error               */
    uint64_t samples;      /* volume samples taken (if the technique counts)*/
    uint64_t vertices;     /* path vertices (if the technique counts)       */
    int truncated;         /* 1: the time budget ran out inside the first
                              sample, whose paths were then cut short (the
                              image is darker than it should be); later
                              waves that run out are dropped instead       */
} volux_render_report;

/* Adds samples to fb until a limit is met (limits NULL = the scene's
 * render settings). Brings the technique up to date with the scene first
 * (volux_technique_update; its failure is returned), and drops fb's samples
 * when they were rendered from another technique or an earlier state, so
 * after an edit accumulation restarts by itself. fb must have the scene's
 * image size (else VOLUX_ERR_INVALID). CANCELLED if the progress callback
 * asked to stop (fb keeps the complete waves). A wave is accumulated only
 * once all its tiles are done, so a cancelled or overrun wave leaves fb as
 * it was. report may be NULL. */
VOLUX_API volux_status volux_render(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                                    const volux_render_limits *limits, volux_render_report *report);

#ifdef __cplusplus
}
#endif
#endif
