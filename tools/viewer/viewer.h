/*
 * tools/viewer/viewer.h — `volux serve`: one scene, one render thread, an
 * HTTP server (libmicrohttpd) with a page and a JSON API.
 *
 * Threads and locks:
 *   - `lock` guards the scene document (and the live scene in it), the
 *     technique instances, the framebuffers and the main context `ctx`.
 *     The render thread holds it while it updates and renders; an edit
 *     (POST /api/edit) takes it to apply the edit. An editor announces
 *     itself in `edit_waiters` first: the frame loop's progress callback
 *     then cancels a refinement frame in flight at once and a first frame
 *     once the edit has waited 50 ms (short previews run to the end, so
 *     dragging shows every other state), and the render thread yields the
 *     lock to every waiter (`waiters`, `turn`).
 *   - `snap_lock` guards the snapshot clients read without waiting for a
 *     frame: the scene JSON, the resolved TF, the volume's histogram.
 *   - `frame_lock` guards the latest frame and the statistics; `frame_cv`
 *     wakes the event streams when a frame is published. Nothing is
 *     encoded under it: the render thread encodes a frame (with `enc_ctx`,
 *     its own) before publishing it, a download or an event takes a
 *     reference to the frame's pixels (viewer_pixels) and encodes after
 *     releasing the lock (a download with a context of its own).
 *
 * DOES NOT: render anything itself (the library does), touch the scene
 * outside the document API, or trust a request: every size is bounded and
 * every file an edit names stays in the data root (volux/io.h).
 */
#ifndef VOLUX_VIEWER_H
#define VOLUX_VIEWER_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>

#include "volux/volux.h"

#define VIEWER_HISTOGRAM_BINS 256

typedef enum frame_kind { FRAME_PREVIEW, FRAME_REFINE, FRAME_FINAL } frame_kind;

/* A published frame's pixels and their encoding for the event stream,
 * shared by reference: a download or an event takes a reference under
 * `frame_lock` and encodes or copies without it; the last reference
 * frees (viewer_pixels_release). */
typedef struct viewer_pixels {
    atomic_int refs;
    volux_context *ctx; /* the image's allocator (thread-safe frees) */
    volux_image image;
    unsigned char *data; /* malloc'ed */
    size_t size;
} viewer_pixels;

static inline viewer_pixels *viewer_pixels_retain(viewer_pixels *p) {
    if (p) atomic_fetch_add(&p->refs, 1);
    return p;
}
static inline void viewer_pixels_release(viewer_pixels *p) {
    if (!p || atomic_fetch_sub(&p->refs, 1) != 1) return;
    volux_image_free(p->ctx, &p->image);
    free(p->data);
    free(p);
}

/* One published frame. `data` is the image encoded for the event stream
 * (JPEG or PNG); `image` keeps the linear pixels for other encodings; both
 * belong to `px` (views, valid while the frame is current). */
typedef struct viewer_frame {
    uint64_t id;       /* increases by one per published frame          */
    uint64_t version;  /* document version the frame shows              */
    frame_kind kind;
    uint32_t spp;
    int width, height;
    const char *format; /* "jpeg" or "png"                              */
    unsigned char *data;
    size_t size;
    volux_image image;
    viewer_pixels *px;
    float exposure;
    double render_ms, update_ms, encode_ms;
    float step_scale;  /* march step of this frame / the scene's render.step (> 1: a
                          first frame coarsened to meet the preview budget) */
    double latency_ms; /* edit received → this frame published (first frame after an edit) */
    double cpu_ms;     /* CPU time the process spent meanwhile (all threads): a
                          figure a loaded machine inflates far less than latency_ms */
    char stand_in[32]; /* "" or the cheaper technique that rendered this frame while
                          the scene's own one prepares (renderer.c, do_stand_in) */
} viewer_frame;

/* Preparation in progress (the context's progress callback during an
 * update: "preparing single", "sh projection", ...), for the page's busy
 * indicator; task "" when none. Under frame_lock. */
typedef struct viewer_busy {
    char task[64];
    double fraction;
    double last_ms; /* when it was last published */
    uint64_t seq;   /* increases on every published change */
} viewer_busy;

typedef struct viewer_options {
    const char *scene_path;
    const char *scene_name; /* what messages and the page call it (volux view: the volume) */
    const char *const *overrides;
    int n_overrides;
    const char *bind;      /* address; default 127.0.0.1                */
    int port;              /* 0 = any free port                         */
    const char *token;     /* NULL = no authentication                  */
    const char *data_root; /* NULL = the scene's folder                 */
    const char *data_root_shown; /* what messages and the page call it
                                    (NULL: the resolved path; volux view:
                                    "the quick look's own files") */
    int preview_max;       /* longest side of a preview, pixels         */
    double preview_budget_ms; /* > 0: the first frame after an edit is sized to
                                 arrive within this time (then the preview_max
                                 size follows); 0: always preview_max      */
    double preview_step_max; /* with a budget: a first frame may march at up
                                to this multiple of render.step before it is
                                made smaller (1 = never)               */
    double idle_ms;        /* quiet time before refinement starts       */
    int max_image;         /* largest render.width/height an edit may set */
    int jpeg_quality;
    int preview_png;       /* 1: previews as PNG instead of JPEG         */
    int no_denoise;        /* 1: show pathtrace/guided/manylights raw (the page
                              toggles it at run time: viewer.no_denoise) */
    int auto_exposure;     /* 1: exposure.c sets render.exposure from the frame
                              on a technique switch (and on request)     */
    int auto_exposure_start; /* 1: also from the very first frame (the quick
                                look: its scene's exposure is nobody's choice) */
    int max_connections;
    int timeout_s;         /* idle connection timeout (slow clients)    */
    int quiet;
} viewer_options;

typedef struct viewer_stats {
    uint64_t edits, edits_rejected, frames, requests, requests_rejected, cancelled;
    uint64_t first_frames_cancelled; /* of `cancelled`: first frames after an edit */
    uint64_t downloads_refused;      /* 503: every large-download slot was busy    */
    double last_latency_ms;       /* edit → first preview published    */
    double last_latency_cpu_ms;   /* process CPU time over that interval */
    int last_first_w, last_first_h; /* size of that first preview          */
    double last_first_step_scale; /* and its step / render.step          */
    double last_full_preview_ms;  /* edit → preview at the --preview size  */
    double last_full_preview_cpu_ms;
    double last_final_ms;         /* edit → final frame published      */
    double last_update_ms, last_render_ms, last_encode_ms, last_refine_ms;
    uint32_t last_changes;        /* volux_change bits of the last update */
    double last_update_budget_ms; /* volux_technique_set_budget before it; -1:
                                     the technique defers nothing        */
    uint64_t pending;             /* volux_technique_pending after the last
                                     update or refine step               */
    int last_lights_changed;      /* light slots in the last update     */
    char technique[32];
    size_t technique_bytes;
    uint64_t stand_in_frames;     /* frames a stand-in rendered (do_stand_in) */
    double last_stand_in_ms;      /* edit → the stand-in frame published      */
    double last_own_frame_ms;     /* edit → the technique's own frame after a stand-in */
    char last_preparation[64];    /* the last preparation task reported ("preparing single") */
    double auto_exposure;         /* the last automatic exposure applied (EV) */
    uint64_t auto_exposures;      /* how many were applied              */
    char error[512];              /* last render failure, "" if none    */
} viewer_stats;

typedef struct viewer {
    viewer_options opt;
    volux_context *ctx;
    volux_context *enc_ctx;
    volux_scene_doc *doc;

    pthread_mutex_t lock;
    pthread_cond_t work; /* an edit happened / quit                   */
    pthread_cond_t turn; /* waiters went away                         */
    atomic_int waiters, edit_waiters, quit, cancellable;
    atomic_int auto_exposure; /* automatic exposure on (exposure.c)      */
    atomic_int auto_due;      /* the next own frame of the technique sets it */
    atomic_int no_denoise;    /* frames shown raw (--no-denoise; the page toggles) */
    atomic_int first_frame; /* the render thread is making an edit's first frame */
    double edit_wait_seen_ms; /* when the progress callback first saw an edit
                                 waiting (0: none); render thread only   */
    double last_edit_ms;    /* when the oldest edit not yet shown arrived */
    double last_edit_cpu_ms; /* process CPU time then                   */
    double last_change_ms;  /* when the latest edit arrived (idle time) */
    uint64_t edit_version;  /* document version of the last edit     */
    int need_latency;       /* the next preview reports latency      */
    int need_final_latency; /* the next final frame reports latency  */

    /* render thread state (under `lock`) */
    volux_technique *tech, *spare; /* current and previous instance   */
    volux_framebuffer *fb_preview, *fb_first, *fb_full; /* --preview size, adaptive first frame, full */
    int upgrade;             /* the first preview was smaller than --preview
                                or marched at a coarser step        */
    int upgrade_smaller;     /* ... smaller (the upgrade is then the first
                                frame at the --preview size)         */
    struct {
        char technique[32];
        double ms_per_pixel; /* running estimate of a preview render's cost */
        double update_ms[2]; /* its last update, ms: [0] camera-only edits, [1] the
                                others (volume, TF, lights, render settings,
                                parameters) or its creation             */
    } cost[16];
    int auto_check;            /* the final frame re-checks the automatic exposure */
    volux_technique *stand_in; /* `shaded`: frames of the new state while a slow update runs */
    double stand_in_edit_t0;   /* > 0: a stand-in showed the edit that arrived then */
    uint32_t pending_changes;  /* VOLUX_DOC_* sections of the edits not yet shown */
    uint64_t shown_version;  /* version of the last preview          */
    int refined;             /* final frame of shown_version published */
    double refine_t0;        /* when the first full-size wave of shown_version started
                                (render.time_ms counts from here)          */
    int refine_steps_done;   /* deferred technique work finished     */

    pthread_mutex_t snap_lock;
    char *scene_json, *scene_json_abs; /* malloc'ed                    */
    char *state_json;                  /* malloc'ed: /api/state        */
    uint64_t snap_version;
    struct cJSON *vol_info;       /* dims, range, histogram (under `lock`) */
    volux_scene_stamp vol_seen;   /* the scene when vol_info was made     */

    atomic_int large_downloads; /* http.c: large frames being encoded or sent */
    pthread_mutex_t frame_lock;
    pthread_cond_t frame_cv;
    viewer_frame frame;
    viewer_busy busy;
    viewer_stats stats;
    uint64_t start_rss_kb;

    pthread_t render_thread;
    struct MHD_Daemon *daemon;
    struct slow_clients *slow; /* http.c: the whole-request time limit */
    int port;
} viewer;

/* Milliseconds on the monotonic clock; CPU milliseconds of the process. */
double viewer_now_ms(void);
double viewer_cpu_ms(void);

/* renderer.c: the render thread. */
int viewer_render_start(viewer *v);
void viewer_render_stop(viewer *v);
/* Takes `lock` as an editor (cancels a refinement in flight) or as a
 * reader (waits for the current unit of work), and gives it back. */
void viewer_lock_edit(viewer *v);
void viewer_lock_read(viewer *v);
void viewer_unlock(viewer *v, int edited);

/* state.c: snapshots and JSON documents (cJSON, malloc'ed strings). */
int viewer_snapshot(viewer *v); /* under `lock`; 0 on NOMEM */
char *viewer_techniques_json(void);
char *viewer_stats_json(viewer *v);
/* Base64 of `n` bytes (malloc'ed, NUL-terminated). */
char *viewer_base64(const unsigned char *data, size_t n, size_t *out_len);
/* Names of the change bits ("volume, extinction, lights"...). */
void viewer_change_names(uint32_t bits, char *out, size_t n);

/* serve.c: what a forced stop (a second signal, or the orderly one taking
 * longer than 1.5 s) removes before _exit: `volux view`'s temporary scene
 * file and folder (NULL: nothing). */
void viewer_exit_cleanup(const char *file, const char *dir);

/* http.c: the server. */
int viewer_http_start(viewer *v);
void viewer_http_stop(viewer *v);

/* renderer.c: the text chunks of the viewer's PNG frames (Software,
 * volux.exposure: the EV the pixels were tone-mapped with). */
void viewer_png_meta(volux_image_meta *meta, float exposure);

/* encode.c: JPEG of a linear image (tone-mapped like PNG output). */
int viewer_encode_jpeg(const volux_image *img, float exposure, int quality, unsigned char **out, size_t *size);

/* exposure.c: automatic exposure. The EV that brings the mean displayed
 * luminance (sRGB, after ×2^EV and the clamp) of the frame's volume pixels
 * (those differing from `background`) to VIEWER_EXPOSURE_TARGET; 0 when the
 * frame is black (or NOMEM). viewer_displayed_mean is that mean at `ev`
 * (-1 on NOMEM). */
#define VIEWER_EXPOSURE_TARGET 0.4
int viewer_auto_exposure(const volux_image *img, volux_vec3 background, float *ev);
double viewer_displayed_mean(const volux_image *img, volux_vec3 background, float ev);

/* slice.c: an axis-aligned slice of the raw volume (GET /api/slice), one
 * pixel per voxel, into `out` (created through ctx). Returns the HTTP code:
 * 200, or 400/413/500 with `err` set. */
#define VIEWER_SLICE_MAX_PIXELS (2048 * 2048)
typedef struct viewer_slice_request {
    int axis;      /* 0 x (sagittal), 1 y (coronal), 2 z (axial)          */
    int index;     /* voxel index along it; -1: the middle                */
    int grey;      /* 1: window/level grey; 0: the TF's colour map        */
    double window; /* <= 0: the volume's range                            */
    double level;
    int has_level; /* 0: the middle of the range                         */
} viewer_slice_request;
int viewer_slice_image(viewer *v, const viewer_slice_request *rq, volux_context *ctx, volux_image *out, char *err,
                       size_t errn);

/* assets.c (generated from web/): the page. */
typedef struct viewer_asset {
    const char *path, *type;
    const unsigned char *data;
    size_t size;
} viewer_asset;
const viewer_asset *viewer_asset_find(const char *path);

#endif
