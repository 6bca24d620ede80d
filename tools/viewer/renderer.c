/*
 * tools/viewer/renderer.c — the render thread: after every edit a preview
 * (reduced resolution, one sample per pixel; with a preview budget the first
 * one may be smaller still, and the --preview size follows at once), then,
 * once the scene has been quiet for `idle_ms`, refinement: the technique's
 * deferred work (volux_technique_refine) and full-resolution waves of one
 * sample each up to the scene's render.spp. The last wave is the "final"
 * frame: the image `volux render` writes for the same scene.
 *
 * A refinement frame (or the --preview size after a reduced first frame) in
 * flight is cancelled through the context's progress callback as soon as an
 * edit waits for the lock; the first frame after an edit only once an edit
 * has waited FIRST_FRAME_EDIT_WAIT_MS for it (it is the cheap immediate
 * answer: cancelled at once, a drag would show nothing at all; never
 * cancelled, 70 000 lights in `shaded` held the next edit for seconds).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "tools/cli/cli.h"
#include "viewer.h"

#define PUBLISH_EVERY_MS 200.0

double viewer_now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

double viewer_cpu_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* ------------------------------------------------------------------ lock */

void viewer_lock_edit(viewer *v) {
    atomic_fetch_add(&v->edit_waiters, 1);
    atomic_fetch_add(&v->waiters, 1);
    pthread_mutex_lock(&v->lock);
    atomic_fetch_sub(&v->waiters, 1);
    atomic_fetch_sub(&v->edit_waiters, 1);
}

void viewer_lock_read(viewer *v) {
    atomic_fetch_add(&v->waiters, 1);
    pthread_mutex_lock(&v->lock);
    atomic_fetch_sub(&v->waiters, 1);
}

void viewer_unlock(viewer *v, int edited) {
    if (edited) pthread_cond_signal(&v->work);
    pthread_cond_broadcast(&v->turn);
    pthread_mutex_unlock(&v->lock);
}

/* Busy indicator: a preparation's progress is published at most every
 * BUSY_EVERY_MS (and on a change of task) to the event streams. */
#define BUSY_EVERY_MS 100.0

static void set_busy(viewer *v, const char *task, double fraction) {
    pthread_mutex_lock(&v->frame_lock);
    viewer_busy *b = &v->busy;
    double now = viewer_now_ms();
    if (strcmp(b->task, task) || (now - b->last_ms >= BUSY_EVERY_MS && fraction != b->fraction)) {
        snprintf(b->task, sizeof b->task, "%s", task);
        b->fraction = fraction;
        b->last_ms = now;
        b->seq++;
        if (task[0]) snprintf(v->stats.last_preparation, sizeof v->stats.last_preparation, "%s", task);
        pthread_cond_broadcast(&v->frame_cv);
    }
    pthread_mutex_unlock(&v->frame_lock);
}

/* How long an edit may wait for the first frame of the previous one
 * before that frame is cancelled. A first frame that is done sooner is
 * shown (dragging then shows every other state); a slow one (a technique
 * that prepares for seconds, 70 000 lights in `shaded`) never holds an
 * edit longer than this plus the library's polling (≤ ~10 ms a check). */
#define FIRST_FRAME_EDIT_WAIT_MS 50.0

/* The library asks between tiles, between rays (volux_tile_cancelled) and
 * in its long preparation loops; nonzero cancels. A refinement frame is
 * cancelled by any waiting edit, the first frame after an edit by one that
 * has waited FIRST_FRAME_EDIT_WAIT_MS, anything by shutdown. A technique's
 * preparation reports here too (any task but "render"): the busy
 * indicator. Never called concurrently (volux_progress_fn). */
static int on_progress(void *user, const char *task, double fraction) {
    viewer *v = user;
    if (strcmp(task, "render")) set_busy(v, fraction >= 1.0 ? "" : task, fraction);
    if (atomic_load(&v->quit)) return 1;
    if (atomic_load(&v->edit_waiters) <= 0) {
        v->edit_wait_seen_ms = 0;
        return 0;
    }
    if (atomic_load(&v->cancellable)) return 1;
    /* an edit's own work (a volume it loads) is never cancelled by the
     * next edit: only the render thread's first frame */
    if (!atomic_load(&v->first_frame)) return 0;
    double now = viewer_now_ms();
    if (v->edit_wait_seen_ms <= 0) v->edit_wait_seen_ms = now;
    return now - v->edit_wait_seen_ms >= FIRST_FRAME_EDIT_WAIT_MS;
}

/* ------------------------------------------------------------------ frames */

static void render_failed(viewer *v, const char *what, volux_status st) {
    char msg[512];
    snprintf(msg, sizeof msg, "%s: %s", what, *volux_context_error(v->ctx) ? volux_context_error(v->ctx)
                                                                          : volux_status_name(st));
    pthread_mutex_lock(&v->frame_lock);
    snprintf(v->stats.error, sizeof v->stats.error, "%s", msg);
    v->frame.id++; /* wakes the streams, which then report the error */
    pthread_cond_broadcast(&v->frame_cv);
    pthread_mutex_unlock(&v->frame_lock);
    if (!v->opt.quiet) cli_eprintf("volux serve: %s\n", msg); /* may quote a file name an edit gave */
}

void viewer_png_meta(volux_image_meta *meta, float exposure) {
    char ev[32];
    memset(meta, 0, sizeof *meta);
    volux_image_meta_set(meta, "Software", "volux " VOLUX_VERSION " (viewer)");
    snprintf(ev, sizeof ev, "%.2f", (double)exposure);
    volux_image_meta_set(meta, "volux.exposure", ev); /* the ×2^EV applied to these pixels */
}

/* What a published frame is, for the statistics. */
enum {
    PUB_FIRST = 1,       /* the first frame after an edit                    */
    PUB_FULL_PREVIEW = 2 /* the first frame at the --preview size after an edit */
};

/* Encodes `img` (ownership passes to the frame) and publishes it. Runs
 * without `lock`. `since_edit_t0` <= 0: no latency to report. */
static void publish(viewer *v, volux_image *img, frame_kind kind, uint64_t version, uint32_t spp, float exposure,
                    float step_scale, double update_ms, double render_ms, double since_edit_t0, double since_edit_cpu,
                    unsigned flags, const char *stand_in) {
    double t0 = viewer_now_ms();
    unsigned char *data = NULL;
    size_t size = 0;
    const char *format = "png";
    int ok;
    /* encoded before the frame lock is taken: readers of the latest frame
     * (/api/stats, downloads, events) never wait for an encode */
    if (kind != FRAME_FINAL && !v->opt.preview_png) {
        format = "jpeg";
        ok = viewer_encode_jpeg(img, exposure, v->opt.jpeg_quality, &data, &size);
    } else {
        unsigned char *enc = NULL;
        volux_image_meta meta;
        viewer_png_meta(&meta, exposure);
        volux_context_clear_error(v->enc_ctx);
        ok = volux_image_encode_meta(v->enc_ctx, img, "png", exposure, &meta, &enc, &size) == VOLUX_OK;
        if (ok) {
            data = malloc(size);
            if (data) memcpy(data, enc, size);
            else ok = 0;
            volux_encoded_free(v->enc_ctx, enc, size);
        }
    }
    viewer_pixels *px = ok ? calloc(1, sizeof *px) : NULL;
    double t1 = viewer_now_ms();
    if (!px) {
        volux_image_free(v->ctx, img);
        free(data);
        render_failed(v, "encoding a frame", VOLUX_ERR_NOMEM);
        return;
    }
    atomic_init(&px->refs, 1);
    px->ctx = v->ctx;
    px->image = *img;
    px->data = data;
    px->size = size;
    pthread_mutex_lock(&v->frame_lock);
    viewer_frame *f = &v->frame;
    viewer_pixels *old = f->px;
    f->px = px;
    f->id++;
    f->version = version;
    f->kind = kind;
    f->spp = spp;
    f->width = img->width;
    f->height = img->height;
    f->format = format;
    f->data = data;
    f->size = size;
    f->image = *img;
    f->exposure = exposure;
    f->step_scale = step_scale;
    snprintf(f->stand_in, sizeof f->stand_in, "%s", stand_in ? stand_in : "");
    f->update_ms = update_ms;
    f->render_ms = render_ms;
    f->encode_ms = t1 - t0;
    f->latency_ms = since_edit_t0 > 0 ? t1 - since_edit_t0 : -1;
    f->cpu_ms = since_edit_t0 > 0 ? viewer_cpu_ms() - since_edit_cpu : -1;
    memset(img, 0, sizeof *img);
    viewer_stats *s = &v->stats;
    s->frames++;
    if (f->stand_in[0]) s->stand_in_frames++;
    s->last_encode_ms = f->encode_ms;
    s->last_render_ms = render_ms;
    s->error[0] = 0;
    if ((flags & PUB_FIRST) && f->latency_ms >= 0) {
        s->last_latency_ms = f->latency_ms;
        s->last_latency_cpu_ms = f->cpu_ms;
        s->last_first_w = f->width;
        s->last_first_h = f->height;
        s->last_first_step_scale = step_scale;
    }
    if ((flags & PUB_FULL_PREVIEW) && f->latency_ms >= 0) {
        s->last_full_preview_ms = f->latency_ms;
        s->last_full_preview_cpu_ms = f->cpu_ms;
    }
    if (kind == FRAME_FINAL && f->latency_ms >= 0) s->last_final_ms = f->latency_ms;
    pthread_cond_broadcast(&v->frame_cv);
    pthread_mutex_unlock(&v->frame_lock);
    viewer_pixels_release(old); /* freed here unless a download still reads it */
}

/* ------------------------------------------------------------------ work */

/* The instance for the scene's technique: the current one, the previous
 * one (switching back and forth costs an incremental update, not a
 * rebuild), or a new one. */
static volux_status ensure_technique(viewer *v, const volux_scene *scene) {
    const char *name = volux_scene_render(scene)->technique;
    if (v->tech && !strcmp(volux_technique_info_of(v->tech)->name, name)) return VOLUX_OK;
    if (v->spare && !strcmp(volux_technique_info_of(v->spare)->name, name)) {
        volux_technique *t = v->tech;
        v->tech = v->spare;
        v->spare = t;
        return VOLUX_OK;
    }
    volux_technique *t = NULL;
    /* Drop the older instance first: two big caches plus a third being
     * built could exceed what the machine has. */
    volux_technique_destroy(v->spare);
    v->spare = NULL;
    volux_status st = volux_technique_create(v->ctx, name, scene, &t);
    if (st) return st;
    v->spare = v->tech;
    v->tech = t;
    return VOLUX_OK;
}

static volux_status ensure_fb(viewer *v, volux_framebuffer **fb, int w, int h) {
    if (*fb && volux_framebuffer_width(*fb) == w && volux_framebuffer_height(*fb) == h) return VOLUX_OK;
    volux_framebuffer_destroy(*fb);
    *fb = NULL;
    volux_status st = volux_framebuffer_create(v->ctx, w, h, fb);
    /* First-hit features guide the denoiser; without them (memory limit)
     * it still filters by colour and variance. */
    if (!st && !atomic_load(&v->no_denoise) && volux_framebuffer_set_features(*fb, 1)) volux_context_clear_error(v->ctx);
    return st;
}

/* The frame shown: for the progressive Monte-Carlo techniques (their
 * 1–16 spp frames are noisy) denoised unless --no-denoise (volux/
 * denoise.h: blended back to the raw accumulation as its error falls, so
 * the final frame converges to the unbiased image); else the raw mean. */
static volux_status resolve_shown(viewer *v, const volux_framebuffer *fb, volux_image *img) {
    const char *name = v->tech ? volux_technique_info_of(v->tech)->name : "";
    if (!atomic_load(&v->no_denoise) &&
        (!strcmp(name, "pathtrace") || !strcmp(name, "guided") || !strcmp(name, "manylights")))
        return volux_framebuffer_denoise(fb, NULL, img);
    return volux_framebuffer_resolve(fb, img);
}

static void preview_size(const viewer *v, int w, int h, int *pw, int *ph) {
    int longest = w > h ? w : h;
    if (longest <= v->opt.preview_max) {
        *pw = w, *ph = h;
        return;
    }
    double s = (double)v->opt.preview_max / longest;
    *pw = (int)lround(w * s);
    *ph = (int)lround(h * s);
    if (*pw < 1) *pw = 1;
    if (*ph < 1) *ph = 1;
}

/* Smallest longest side of an adaptive first frame, and its granularity
 * (sizes are rounded down to it so the framebuffer is not reallocated for
 * every small change of the estimate). */
#define MIN_FIRST_SIDE 64
#define FIRST_SIDE_STEP 16
/* Time kept back for the encode and the event (a 256² JPEG takes ~2 ms). */
#define PUBLISH_MARGIN_MS 5.0
/* The share of what is left of the budget a first frame's estimated render
 * may take: the estimate is a running mean (about every other frame is
 * slower than it), the page adds the event's delivery and the decode, and
 * a coarser step saves less than the 1/step the estimate assumes (misses
 * per voxel crossed stay) — aimed at the budget itself, the step would
 * settle where every other frame is late. */
#define RENDER_FILL 0.8

/* The running cost estimate of a technique's preview render (ms/pixel;
 * 0 until measured). */
static int cost_index(viewer *v, const char *technique) {
    int n = (int)(sizeof v->cost / sizeof v->cost[0]), free_slot = -1;
    for (int i = 0; i < n; i++) {
        if (!strcmp(v->cost[i].technique, technique)) return i;
        if (free_slot < 0 && !v->cost[i].technique[0]) free_slot = i;
    }
    if (free_slot < 0) free_slot = 0; /* more techniques than slots: forget one */
    snprintf(v->cost[free_slot].technique, sizeof v->cost[free_slot].technique, "%s", technique);
    v->cost[free_slot].ms_per_pixel = 0;
    v->cost[free_slot].update_ms[0] = v->cost[free_slot].update_ms[1] = 0;
    return free_slot;
}

static double *cost_of(viewer *v, const char *technique) { return &v->cost[cost_index(v, technique)].ms_per_pixel; }

/* Edits that may reach a technique's caches (VOLUX_DOC_* sections: all but
 * a camera-only edit, which costs most techniques nothing). */
#define HEAVY_CHANGES (VOLUX_DOC_VOLUME | VOLUX_DOC_TRANSFER | VOLUX_DOC_LIGHTS | VOLUX_DOC_OTHER)

/* The last update time of a technique for edits of this kind (`changes`),
 * ms (0: not yet). */
static double *update_of(viewer *v, const char *technique, uint32_t changes) {
    return &v->cost[cost_index(v, technique)].update_ms[(changes & HEAVY_CHANGES) != 0];
}

/* The size of the first frame after an edit: the --preview size (pw, ph on
 * entry) shrunk, keeping the aspect, to what the technique's measured cost
 * per pixel says renders in `left_ms`, but not below MIN_FIRST_SIDE on the
 * longest side. Without a budget or an estimate: unchanged. */
static void budget_size(const viewer *v, double ms_per_pixel, double left_ms, int *pw, int *ph) {
    if (v->opt.preview_budget_ms <= 0 || ms_per_pixel <= 0) return;
    double pixels = (double)*pw * *ph, fits = left_ms > 0 ? left_ms / ms_per_pixel : 0;
    if (fits >= pixels) return;
    int longest = *pw > *ph ? *pw : *ph;
    int side = (int)(sqrt(fits / pixels) * longest) / FIRST_SIDE_STEP * FIRST_SIDE_STEP;
    int floor_side = longest < MIN_FIRST_SIDE ? longest : MIN_FIRST_SIDE;
    if (side < floor_side) side = floor_side;
    if (side >= longest) return;
    double scale = (double)side / longest;
    *pw = (int)lround(*pw * scale);
    *ph = (int)lround(*ph * scale);
    if (*pw < 1) *pw = 1;
    if (*ph < 1) *ph = 1;
}

/* Techniques that can spread an update over frames (lightvol's §7.3
 * propagation budget, volux_technique_set_budget) get, before a first
 * frame, what the preview budget leaves after the estimated render of the
 * --preview size, but at most half of what is left (the technique turns ms
 * into work at a measured rate: room for its error and the render's), and
 * at least MIN_UPDATE_BUDGET_MS so that the light keeps arriving when the
 * render alone fills the budget. Refinement steps then finish the update
 * in REFINE_BUDGET_MS pieces: an edit waits at most about one piece. The
 * scene is not touched: `volux render` of the saved scene builds the
 * converged state at once, the final frame's state. */
#define MIN_UPDATE_BUDGET_MS 10.0
#define REFINE_BUDGET_MS 25.0

static double update_budget(const viewer *v, double ms_per_pixel, int w, int h) {
    double left = v->opt.preview_budget_ms - PUBLISH_MARGIN_MS;
    if (v->need_latency) left -= viewer_now_ms() - v->last_edit_ms;
    double b = 0.5 * left;
    if (ms_per_pixel > 0 && left - ms_per_pixel * w * h < b) b = left - ms_per_pixel * w * h;
    return b > MIN_UPDATE_BUDGET_MS ? b : MIN_UPDATE_BUDGET_MS;
}

/* A render's cost at k × the scene's step relative to k = 1: a share that
 * does not fall with the step (rays, misses per voxel crossed) and the
 * rest ∝ 1/k. Measured on bonsai 256², 2 threads: 2× the step costs 0.65×
 * for lightvol and ambient (share 0.3; ea's 0.84× would be 0.68 — the
 * running estimate absorbs the difference). */
#define STEP_FIXED_SHARE 0.3
static double step_cost(double k) { return STEP_FIXED_SHARE + (1.0 - STEP_FIXED_SHARE) / k; }

/* The march step factor of a first frame: 1 when the --preview size
 * (`pixels`) fits in `left_ms` at the scene's step, else what step_cost
 * says it takes to fit, rounded up to a quarter, at most --preview-step
 * (the estimate is per pixel at the scene's step). Fewer samples per ray
 * lose thin features and opacity detail that the size keeps, but the
 * preview keeps its resolution; only the first frame after an edit is
 * coarsened — the --preview size at the scene's step follows at once, then
 * refinement. */
static double step_scale_for(const viewer *v, double ms_per_pixel, double left_ms, double pixels) {
    const double kmax = v->opt.preview_step_max;
    if (v->opt.preview_budget_ms <= 0 || kmax <= 1 || ms_per_pixel <= 0) return 1;
    double need = ms_per_pixel * pixels;
    if (need <= left_ms) return 1;
    double share = left_ms / need; /* step_cost(k) must not exceed it */
    if (share <= step_cost(kmax)) return kmax;
    double k = ceil((1.0 - STEP_FIXED_SHARE) / (share - STEP_FIXED_SHARE) * 4) / 4;
    return k < kmax ? k : kmax;
}

/* Folds one measured render into the estimate (a running mean that follows
 * changes of the scene — TF, camera, technique parameters — within a few
 * frames). */
static void learn_cost(viewer *v, const char *technique, double render_ms, int w, int h, double step_scale) {
    double *c = cost_of(v, technique), now = render_ms / (step_cost(step_scale) * w * h);
    *c = *c > 0 ? 0.5 * *c + 0.5 * now : now;
}

/* Automatic exposure (exposure.c): from the technique's own first frame
 * of a state it is due for (a technique switch, the page's button, the
 * quick look's first frame), written to the scene as render.exposure —
 * an edit like any other, so the saved scene renders the same with
 * `volux render` — and held until it is due again (no pumping while the
 * user edits). The background colour is scaled by the inverse factor, so
 * that it stays on screen what it was (at +3.5 EV the quick look's dark
 * blue would turn light grey); it is also what escaping paths see, so
 * this is part of the scene, not a display trick. Called with `lock`
 * held. Returns 1 when the frame must be rendered again (the background
 * changed), else 0 with *exposure and *version those of the scene now (the
 * pixels are the same: exposure changes no technique state). `recheck`:
 * the final frame of this state checks it once more (do_refine). */
#define AUTO_RECHECK_EV 0.3f
static int apply_auto_exposure(viewer *v, const volux_image *img, uint64_t *version, float *exposure, int recheck) {
    atomic_store(&v->auto_due, 0);
    v->auto_check = recheck;
    volux_scene *scene = volux_scene_doc_scene(v->doc);
    const volux_vec3 bg = volux_scene_background(scene);
    float ev;
    if (!viewer_auto_exposure(img, bg, &ev)) return 0;
    if (ev < -64.0f) ev = -64.0f;
    if (ev > 64.0f) ev = 64.0f;
    pthread_mutex_lock(&v->frame_lock);
    v->stats.auto_exposure = ev;
    v->stats.auto_exposures++;
    pthread_mutex_unlock(&v->frame_lock);
    if (ev == *exposure) return 0;
    const int scale_bg = bg.x != 0 || bg.y != 0 || bg.z != 0;
    const float k = exp2f(*exposure - ev);
    char set_ev[64], set_bg[160];
    snprintf(set_ev, sizeof set_ev, "render.exposure=%.2f", (double)ev);
    snprintf(set_bg, sizeof set_bg, "background=[%.6g,%.6g,%.6g]", (double)(bg.x * k), (double)(bg.y * k),
             (double)(bg.z * k));
    const char *sets[2] = {set_ev, set_bg};
    volux_context_clear_error(v->ctx);
    if (volux_scene_doc_edit(v->doc, sets, scale_bg ? 2 : 1, NULL)) {
        volux_context_clear_error(v->ctx);
        return 0;
    }
    if (!viewer_snapshot(v)) volux_context_clear_error(v->ctx);
    if (scale_bg) return 1;
    *version = volux_scene_doc_version(v->doc);
    v->shown_version = *version;
    *exposure = ev;
    return 0;
}

/* A stand-in comes first when the scene's technique has no instance yet
 * (its creation prepares everything) or its last update took longer than
 * this: a frame of the new state within the 150 ms the page aims at. */
#define STAND_IN_UPDATE_MS 100.0
#define STAND_IN_TECHNIQUE "shaded"

/* Before a slow update: the new state rendered by `shaded` (its caches
 * follow any edit in milliseconds) at the preview size, published as a
 * labelled stand-in; the scene's own technique then prepares (the busy
 * indicator shows its progress) and its frame follows. Best effort: a
 * failure just skips the stand-in. Called and returns with `lock` held. */
static void do_stand_in(viewer *v, uint64_t version, const volux_render_settings *full) {
    volux_scene *scene = volux_scene_doc_scene(v->doc);
    volux_render_settings small = *full;
    preview_size(v, full->width, full->height, &small.width, &small.height);
    double t0 = viewer_now_ms();
    /* sized like a first frame: what the stand-in's measured cost fits in
     * what is left of the preview budget */
    if (v->need_latency) {
        double left = RENDER_FILL * (v->opt.preview_budget_ms - (t0 - v->last_edit_ms) - PUBLISH_MARGIN_MS);
        budget_size(v, *cost_of(v, STAND_IN_TECHNIQUE), left, &small.width, &small.height);
    }
    volux_status st = VOLUX_OK;
    volux_image img = {0};
    volux_render_report rep = {0};
    volux_render_limits one = {1, 0, 0};
    if (!v->stand_in) st = volux_technique_create(v->ctx, STAND_IN_TECHNIQUE, scene, &v->stand_in);
    if (!st) st = volux_scene_set_render(scene, &small);
    if (!st) st = volux_technique_update(v->stand_in, scene, NULL);
    volux_framebuffer **slot = NULL;
    int w0 = 0, h0 = 0;
    preview_size(v, full->width, full->height, &w0, &h0);
    slot = small.width != w0 || small.height != h0 ? &v->fb_first : &v->fb_preview;
    if (!st) st = ensure_fb(v, slot, small.width, small.height);
    double t1 = viewer_now_ms();
    if (!st) {
        volux_framebuffer_reset(*slot);
        st = volux_render(v->stand_in, scene, *slot, &one, &rep);
    }
    if (!st) learn_cost(v, STAND_IN_TECHNIQUE, viewer_now_ms() - t1, small.width, small.height, 1);
    if (!st) st = volux_framebuffer_resolve(*slot, &img);
    volux_scene_set_render(scene, full);
    volux_context_clear_error(v->ctx);
    if (st) {
        volux_image_free(v->ctx, &img);
        return;
    }
    /* the edit's first frame; need_latency stays set, so the technique's
     * own frame after the update is sized to the budget too (a reduced
     * frame, then the --preview size), not rendered whole after a long
     * preparation */
    double edit_t0 = v->need_latency ? v->last_edit_ms : -1;
    v->stand_in_edit_t0 = edit_t0;
    atomic_store(&v->first_frame, 0); /* the lock is an editor's meanwhile */
    pthread_mutex_unlock(&v->lock);
    publish(v, &img, FRAME_PREVIEW, version, 1, full->exposure, 1.0f, 0, viewer_now_ms() - t0, edit_t0,
            v->last_edit_cpu_ms, PUB_FIRST, STAND_IN_TECHNIQUE);
    if (edit_t0 > 0) {
        pthread_mutex_lock(&v->frame_lock);
        v->stats.last_stand_in_ms = viewer_now_ms() - edit_t0;
        pthread_mutex_unlock(&v->frame_lock);
    }
    pthread_mutex_lock(&v->lock);
    atomic_store(&v->first_frame, 1);
}

/* 1 if the scene's technique has no instance (switching to it creates one). */
static int needs_instance(const viewer *v, const char *name) {
    return !(v->tech && !strcmp(volux_technique_info_of(v->tech)->name, name)) &&
           !(v->spare && !strcmp(volux_technique_info_of(v->spare)->name, name));
}

/* The first frame after an edit was cancelled (an edit waited, or
 * shutdown): nothing is published, the next loop renders a first frame
 * again (even when the waiting edit is refused and the version stays),
 * and the technique's update — whose stamp moves only on success — is
 * redone in full then. */
static void preview_cancelled(viewer *v, uint32_t changes) {
    v->shown_version = (uint64_t)-1;
    v->pending_changes |= changes;
    set_busy(v, "", 1.0);
    volux_context_clear_error(v->ctx);
    pthread_mutex_lock(&v->frame_lock);
    v->stats.cancelled++;
    v->stats.first_frames_cancelled++;
    pthread_mutex_unlock(&v->frame_lock);
}

/* The first frame after an edit. Called and returns with `lock` held;
 * cancelled by an edit that waits FIRST_FRAME_EDIT_WAIT_MS (on_progress). */
static void do_preview_body(viewer *v, uint64_t version);
static void do_preview(viewer *v, uint64_t version) {
    do_preview_body(v, version);
    atomic_store(&v->first_frame, 0);
}

static void do_preview_body(viewer *v, uint64_t version) {
    volux_scene *scene = volux_scene_doc_scene(v->doc);
    volux_context_clear_error(v->ctx);
    v->shown_version = version;
    v->refined = 1; /* unless the preview succeeds */
    v->refine_steps_done = 0;
    const volux_render_settings full = *volux_scene_render(scene);
    /* a slow update ahead (a new instance — its creation prepares
     * everything — or the last update for edits of this kind was slow): a
     * cheap frame of the new state first (not for the cheap ones) */
    const int creating = needs_instance(v, full.technique);
    /* back to the previous instance: it catches up on every edit made
     * since it was current, which pending_changes does not record */
    const int switching = v->tech && strcmp(volux_technique_info_of(v->tech)->name, full.technique);
    const uint32_t changes = creating || switching ? (uint32_t)HEAVY_CHANGES : v->pending_changes;
    if (switching) atomic_store(&v->auto_due, 1); /* held until the new technique's own frame */
    v->pending_changes = 0;
    atomic_store(&v->first_frame, 1); /* until published: on_progress */
    if (strcmp(full.technique, "ea") && strcmp(full.technique, STAND_IN_TECHNIQUE) &&
        (creating || *update_of(v, full.technique, changes) > STAND_IN_UPDATE_MS))
        do_stand_in(v, version, &full);
    double t0 = viewer_now_ms();
    volux_status st = ensure_technique(v, scene);
    if (st == VOLUX_ERR_CANCELLED) {
        preview_cancelled(v, changes);
        return;
    }
    if (st) {
        set_busy(v, "", 1.0);
        render_failed(v, "technique", st);
        return;
    }
    /* The preview renders the same scene at a smaller size: only the
     * camera of the ray-caster base follows a size change (RENDER), the
     * technique's caches do not. The full size is restored before the
     * lock is released, so clients never see the preview size. */
    volux_render_settings small = full;
    preview_size(v, full.width, full.height, &small.width, &small.height);
    double budget = v->opt.preview_budget_ms > 0
                        ? update_budget(v, *cost_of(v, full.technique), small.width, small.height)
                        : 0; /* no preview budget: the scene's own setting */
    int budgeted = volux_technique_set_budget(v->tech, budget);
    volux_image img = {0};
    volux_render_report rep = {0};
    volux_change_set changed;
    memset(&changed, 0, sizeof changed);
    volux_render_settings first = small;
    volux_framebuffer *fb = NULL;
    if (!(st = volux_scene_set_render(scene, &small))) {
        st = volux_technique_update(v->tech, scene, &changed);
        double t1 = viewer_now_ms();
        set_busy(v, "", 1.0); /* preparation over (or failed) */
        /* a switch back records nothing: its catch-up says little about
         * the next edit of either kind */
        if ((creating || !switching) && st != VOLUX_ERR_CANCELLED) *update_of(v, full.technique, changes) = t1 - t0;
        /* With a budget, the first frame gets what is left of it after the
         * update (the edit's own cost, which a smaller frame cannot save):
         * the preview size the measured cost per pixel fits in. The render
         * then only brings the ray-caster's camera to the new size. */
        double step_scale = 1;
        if (!st && v->need_latency) {
            double left = RENDER_FILL * (v->opt.preview_budget_ms - (t1 - v->last_edit_ms) - PUBLISH_MARGIN_MS);
            double c = *cost_of(v, full.technique);
            step_scale = step_scale_for(v, c, left, (double)first.width * first.height);
            budget_size(v, c * step_cost(step_scale), left, &first.width, &first.height);
            first.step = (float)(full.step * step_scale);
            if (first.width != small.width || first.height != small.height || step_scale != 1)
                st = volux_scene_set_render(scene, &first);
        }
        int smaller = first.width != small.width || first.height != small.height;
        int reduced = smaller || step_scale != 1;
        volux_framebuffer **slot = smaller ? &v->fb_first : &v->fb_preview;
        if (!st && !(st = ensure_fb(v, slot, first.width, first.height))) {
            fb = *slot;
            volux_framebuffer_reset(fb);
        }
        volux_render_limits one = {1, 0, 0};
        double t2 = viewer_now_ms();
        if (!st) st = volux_render(v->tech, scene, fb, &one, &rep);
        if (!st) st = resolve_shown(v, fb, &img);
        if (!st) learn_cost(v, full.technique, viewer_now_ms() - t2, first.width, first.height, step_scale);
        volux_scene_set_render(scene, &full); /* cannot fail: the settings were valid */
        pthread_mutex_lock(&v->frame_lock);
        v->stats.last_update_ms = t1 - t0;
        /* The edit's own changes (the size switch adds RENDER). */
        v->stats.last_changes = changed.what & ~(full.width != small.width || full.height != small.height
                                                     ? (uint32_t)VOLUX_CHANGE_RENDER
                                                     : 0u);
        int lights = 0;
        if (changed.what & VOLUX_CHANGE_LIGHTS) lights = volux_change_light_count(&changed);
        v->stats.last_lights_changed = lights;
        snprintf(v->stats.technique, sizeof v->stats.technique, "%s", full.technique);
        v->stats.technique_bytes = volux_technique_memory_bytes(v->tech);
        v->stats.last_update_budget_ms = budgeted ? budget : -1;
        v->stats.pending = volux_technique_pending(v->tech);
        pthread_mutex_unlock(&v->frame_lock);
        if (!st) {
            /* a reduced first frame (coarser step: brighter or darker than
             * the scene's) leaves the exposure to the full preview after it */
            float exposure = full.exposure;
            if (!reduced && atomic_load(&v->auto_exposure) && atomic_load(&v->auto_due) &&
                apply_auto_exposure(v, &img, &version, &exposure, 1)) {
                volux_image_free(v->ctx, &img); /* the render loop draws the new version */
                return;
            }
            double edit_t0 = v->need_latency ? v->last_edit_ms : -1;
            v->need_latency = 0;
            unsigned first_flag = PUB_FIRST;
            if (v->stand_in_edit_t0 > 0) { /* the own frame after a stand-in: not the edit's first */
                pthread_mutex_lock(&v->frame_lock);
                v->stats.last_own_frame_ms = viewer_now_ms() - v->stand_in_edit_t0;
                pthread_mutex_unlock(&v->frame_lock);
                v->stand_in_edit_t0 = 0;
                first_flag = 0;
            }
            v->refined = 0;
            v->upgrade = reduced;
            v->upgrade_smaller = smaller;
            if (v->fb_full) volux_framebuffer_reset(v->fb_full);
            atomic_store(&v->first_frame, 0);
            pthread_mutex_unlock(&v->lock);
            publish(v, &img, FRAME_PREVIEW, version, 1, exposure, (float)step_scale, t1 - t0,
                    viewer_now_ms() - t2, edit_t0, v->last_edit_cpu_ms, first_flag | (smaller ? 0u : PUB_FULL_PREVIEW), NULL);
            pthread_mutex_lock(&v->lock);
            return;
        }
    }
    volux_image_free(v->ctx, &img);
    if (st == VOLUX_ERR_CANCELLED) preview_cancelled(v, changes);
    else render_failed(v, "preview", st);
}

/* After a reduced first frame: the preview at the --preview size, at once
 * (no idle wait) but cancellable like refinement, so a drag that goes on
 * keeps getting first frames within the budget. Called and returns with
 * `lock` held. */
static void do_upgrade(viewer *v) {
    volux_scene *scene = volux_scene_doc_scene(v->doc);
    const volux_render_settings full = *volux_scene_render(scene);
    volux_render_settings small = full;
    preview_size(v, full.width, full.height, &small.width, &small.height);
    volux_context_clear_error(v->ctx);
    volux_status st;
    volux_image img = {0};
    volux_render_report rep = {0};
    volux_render_limits one = {1, 0, 0};
    if ((st = ensure_fb(v, &v->fb_preview, small.width, small.height)) ||
        (st = volux_scene_set_render(scene, &small))) {
        v->upgrade = 0;
        render_failed(v, "preview", st);
        return;
    }
    volux_framebuffer_reset(v->fb_preview);
    double t0 = viewer_now_ms();
    atomic_store(&v->cancellable, 1);
    st = volux_render(v->tech, scene, v->fb_preview, &one, &rep);
    atomic_store(&v->cancellable, 0);
    double render_ms = viewer_now_ms() - t0;
    if (!st) st = resolve_shown(v, v->fb_preview, &img);
    volux_scene_set_render(scene, &full);
    if (st == VOLUX_ERR_CANCELLED) { /* an edit came: its first frame is next */
        pthread_mutex_lock(&v->frame_lock);
        v->stats.cancelled++;
        pthread_mutex_unlock(&v->frame_lock);
        return;
    }
    v->upgrade = 0;
    if (st) {
        volux_image_free(v->ctx, &img);
        render_failed(v, "preview", st);
        return;
    }
    /* after a first frame at this size but a coarser step, the first one
     * at this size was that frame */
    const int smaller = v->upgrade_smaller;
    learn_cost(v, full.technique, render_ms, small.width, small.height, 1);
    uint64_t version = v->shown_version;
    float exposure = full.exposure;
    if (atomic_load(&v->auto_exposure) && atomic_load(&v->auto_due) &&
        apply_auto_exposure(v, &img, &version, &exposure, 1)) {
        volux_image_free(v->ctx, &img); /* the render loop draws the new version */
        return;
    }
    pthread_mutex_unlock(&v->lock);
    publish(v, &img, FRAME_PREVIEW, version, 1, exposure, 1.0f, 0, render_ms, v->last_edit_ms,
            v->last_edit_cpu_ms, smaller ? PUB_FULL_PREVIEW : 0u, NULL);
    pthread_mutex_lock(&v->lock);
}

/* One unit of refinement (a deferred technique step or one full-size
 * wave). Called and returns with `lock` held; cancellable. */
static void do_refine(viewer *v) {
    volux_scene *scene = volux_scene_doc_scene(v->doc);
    const volux_render_settings *rs = volux_scene_render(scene);
    volux_context_clear_error(v->ctx);
    double t0 = viewer_now_ms();
    volux_status st;
    atomic_store(&v->cancellable, 1);
    if (!v->refine_steps_done) {
        int more = 0;
        volux_technique_set_budget(v->tech, v->opt.preview_budget_ms > 0 ? REFINE_BUDGET_MS : 0);
        st = volux_technique_refine(v->tech, scene, NULL, &more);
        atomic_store(&v->cancellable, 0);
        if (st == VOLUX_ERR_CANCELLED) return;
        if (st) {
            v->refined = 1;
            render_failed(v, "refinement", st);
            return;
        }
        v->refine_steps_done = !more;
        pthread_mutex_lock(&v->frame_lock);
        v->stats.last_refine_ms = viewer_now_ms() - t0;
        v->stats.pending = volux_technique_pending(v->tech);
        pthread_mutex_unlock(&v->frame_lock);
        return;
    }
    if ((st = ensure_fb(v, &v->fb_full, rs->width, rs->height))) {
        atomic_store(&v->cancellable, 0);
        v->refined = 1;
        render_failed(v, "refinement", st);
        return;
    }
    uint32_t target = (uint32_t)rs->spp;
    if (volux_framebuffer_spp(v->fb_full) == 0) v->refine_t0 = viewer_now_ms();
    volux_render_limits wave = {volux_framebuffer_spp(v->fb_full) + 1, 0, 0};
    volux_render_report rep = {0};
    static double last_publish;
    st = volux_render(v->tech, scene, v->fb_full, &wave, &rep);
    atomic_store(&v->cancellable, 0);
    if (st == VOLUX_ERR_CANCELLED) {
        pthread_mutex_lock(&v->frame_lock);
        v->stats.cancelled++;
        pthread_mutex_unlock(&v->frame_lock);
        return;
    }
    if (st) {
        v->refined = 1;
        render_failed(v, "refinement", st);
        return;
    }
    uint32_t spp = volux_framebuffer_spp(v->fb_full);
    double now = viewer_now_ms();
    /* The limits `volux render` applies: spp, the target relative error
     * and the time budget (render.time_ms, from the first full wave). */
    int final = spp >= target || (rs->target_error > 0 && spp >= 2 && rep.rel_error <= rs->target_error) ||
                (rs->time_ms > 0 && now - v->refine_t0 >= rs->time_ms);
    if (!final && now - last_publish < PUBLISH_EVERY_MS) return;
    last_publish = now;
    volux_image img = {0};
    if ((st = resolve_shown(v, v->fb_full, &img))) {
        v->refined = 1;
        render_failed(v, "refinement", st);
        return;
    }
    uint64_t version = v->shown_version;
    float exposure = rs->exposure;
    /* the final frame checks the exposure set from the first one once: a
     * technique whose first frames differ from its converged image (single
     * on the bonsai: 1.7x brighter) is corrected once, not followed */
    if (final && v->auto_check) {
        float ev;
        v->auto_check = 0;
        if (viewer_auto_exposure(&img, volux_scene_background(scene), &ev) && fabsf(ev - exposure) > AUTO_RECHECK_EV)
            atomic_store(&v->auto_due, 1);
    }
    if (atomic_load(&v->auto_exposure) && atomic_load(&v->auto_due) &&
        apply_auto_exposure(v, &img, &version, &exposure, !final)) {
        volux_image_free(v->ctx, &img); /* the render loop draws the new version */
        return;
    }
    if (final) v->refined = 1;
    double edit_t0 = final && v->need_final_latency ? v->last_edit_ms : -1;
    if (final) v->need_final_latency = 0;
    pthread_mutex_unlock(&v->lock);
    publish(v, &img, final ? FRAME_FINAL : FRAME_REFINE, version, spp, exposure, 1.0f, 0, now - t0, edit_t0,
            v->last_edit_cpu_ms, 0, NULL);
    pthread_mutex_lock(&v->lock);
}

static void wait_ms(viewer *v, double ms) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    long long ns = (long long)ts.tv_nsec + (long long)(ms * 1e6);
    ts.tv_sec += (time_t)(ns / 1000000000LL);
    ts.tv_nsec = (long)(ns % 1000000000LL);
    pthread_cond_timedwait(&v->work, &v->lock, &ts);
}

static void *render_main(void *arg) {
    viewer *v = arg;
    pthread_mutex_lock(&v->lock);
    while (!atomic_load(&v->quit)) {
        /* Editors and readers first: they wait at most one unit of work. */
        while (atomic_load(&v->waiters) > 0 && !atomic_load(&v->quit)) pthread_cond_wait(&v->turn, &v->lock);
        if (atomic_load(&v->quit)) break;
        uint64_t version = volux_scene_doc_version(v->doc);
        if (version != v->shown_version || !v->tech) {
            do_preview(v, version);
        } else if (v->upgrade) {
            do_upgrade(v);
        } else if (!v->refined) {
            double wait = v->last_change_ms + v->opt.idle_ms - viewer_now_ms();
            if (wait > 0) wait_ms(v, wait);
            else do_refine(v);
        } else {
            pthread_cond_wait(&v->work, &v->lock);
        }
    }
    pthread_mutex_unlock(&v->lock);
    return NULL;
}

int viewer_render_start(viewer *v) {
    volux_context_set_progress(v->ctx, on_progress, v);
    v->shown_version = (uint64_t)-1;
    v->need_latency = v->need_final_latency = 0;
    atomic_store(&v->auto_exposure, v->opt.auto_exposure);
    atomic_store(&v->auto_due, v->opt.auto_exposure_start);
    atomic_store(&v->no_denoise, v->opt.no_denoise);
    return pthread_create(&v->render_thread, NULL, render_main, v) == 0;
}

void viewer_render_stop(viewer *v) {
    pthread_mutex_lock(&v->lock);
    atomic_store(&v->quit, 1);
    pthread_cond_broadcast(&v->work);
    pthread_cond_broadcast(&v->turn);
    pthread_mutex_unlock(&v->lock);
    pthread_join(v->render_thread, NULL);
    volux_technique_destroy(v->tech);
    volux_technique_destroy(v->spare);
    volux_technique_destroy(v->stand_in);
    v->stand_in = NULL;
    volux_framebuffer_destroy(v->fb_preview);
    volux_framebuffer_destroy(v->fb_first);
    volux_framebuffer_destroy(v->fb_full);
    v->tech = v->spare = NULL;
    v->fb_preview = v->fb_first = v->fb_full = NULL;
}
