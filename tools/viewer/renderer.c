/*
 * tools/viewer/renderer.c — the render thread: after every edit a preview
 * (reduced resolution, one sample per pixel), then, once the scene has been
 * quiet for `idle_ms`, refinement: the technique's deferred work
 * (volux_technique_refine) and full-resolution waves of one sample each up
 * to the scene's render.spp. The last wave is the "final" frame: the image
 * `volux render` writes for the same scene.
 *
 * A refinement frame in flight is cancelled through the context's progress
 * callback as soon as an edit waits for the lock; a preview is not (it is
 * the cheap immediate answer, and cancelling it while the user drags would
 * show nothing at all).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

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

/* The frame loop asks between tiles; nonzero cancels. */
static int on_progress(void *user, const char *task, double fraction) {
    (void)task;
    (void)fraction;
    viewer *v = user;
    return atomic_load(&v->quit) || (atomic_load(&v->cancellable) && atomic_load(&v->edit_waiters) > 0);
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
    if (!v->opt.quiet) fprintf(stderr, "volux serve: %s\n", msg);
}

/* Encodes `img` (ownership passes to the frame) and publishes it. Runs
 * without `lock`. `since_edit_ms` < 0: no latency to report. */
static void publish(viewer *v, volux_image *img, frame_kind kind, uint64_t version, uint32_t spp, float exposure,
                    double update_ms, double render_ms, double since_edit_t0, double since_edit_cpu) {
    double t0 = viewer_now_ms();
    unsigned char *data = NULL;
    size_t size = 0;
    const char *format = "png";
    int ok;
    pthread_mutex_lock(&v->frame_lock);
    if (kind != FRAME_FINAL && !v->opt.preview_png) {
        format = "jpeg";
        ok = viewer_encode_jpeg(img, exposure, v->opt.jpeg_quality, &data, &size);
    } else {
        unsigned char *enc = NULL;
        volux_context_clear_error(v->enc_ctx);
        ok = volux_image_encode(v->enc_ctx, img, "png", exposure, &enc, &size) == VOLUX_OK;
        if (ok) {
            data = malloc(size);
            if (data) memcpy(data, enc, size);
            else ok = 0;
            volux_encoded_free(v->enc_ctx, enc, size);
        }
    }
    double t1 = viewer_now_ms();
    if (!ok) {
        pthread_mutex_unlock(&v->frame_lock);
        volux_image_free(v->ctx, img);
        free(data);
        render_failed(v, "encoding a frame", VOLUX_ERR_NOMEM);
        return;
    }
    viewer_frame *f = &v->frame;
    free(f->data);
    volux_image_free(v->ctx, &f->image);
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
    f->update_ms = update_ms;
    f->render_ms = render_ms;
    f->encode_ms = t1 - t0;
    f->latency_ms = since_edit_t0 > 0 ? t1 - since_edit_t0 : -1;
    f->cpu_ms = since_edit_t0 > 0 ? viewer_cpu_ms() - since_edit_cpu : -1;
    memset(img, 0, sizeof *img);
    viewer_stats *s = &v->stats;
    s->frames++;
    s->last_encode_ms = f->encode_ms;
    s->last_render_ms = render_ms;
    s->error[0] = 0;
    if (kind == FRAME_PREVIEW && f->latency_ms >= 0) {
        s->last_latency_ms = f->latency_ms;
        s->last_latency_cpu_ms = f->cpu_ms;
    }
    if (kind == FRAME_FINAL && f->latency_ms >= 0) s->last_final_ms = f->latency_ms;
    pthread_cond_broadcast(&v->frame_cv);
    pthread_mutex_unlock(&v->frame_lock);
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
    return volux_framebuffer_create(v->ctx, w, h, fb);
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

/* The first frame after an edit. Called and returns with `lock` held. */
static void do_preview(viewer *v, uint64_t version) {
    volux_scene *scene = volux_scene_doc_scene(v->doc);
    volux_context_clear_error(v->ctx);
    v->shown_version = version;
    v->refined = 1; /* unless the preview succeeds */
    v->refine_steps_done = 0;
    const volux_render_settings full = *volux_scene_render(scene);
    double t0 = viewer_now_ms();
    volux_status st = ensure_technique(v, scene);
    if (st) {
        render_failed(v, "technique", st);
        return;
    }
    /* The preview renders the same scene at a smaller size: only the
     * camera of the ray-caster base follows a size change (RENDER), the
     * technique's caches do not. The full size is restored before the
     * lock is released, so clients never see the preview size. */
    volux_render_settings small = full;
    preview_size(v, full.width, full.height, &small.width, &small.height);
    volux_image img = {0};
    volux_render_report rep = {0};
    volux_change_set changed;
    memset(&changed, 0, sizeof changed);
    if (!(st = ensure_fb(v, &v->fb_preview, small.width, small.height)) &&
        !(st = volux_scene_set_render(scene, &small))) {
        volux_framebuffer_reset(v->fb_preview);
        st = volux_technique_update(v->tech, scene, &changed);
        double t1 = viewer_now_ms();
        volux_render_limits one = {1, 0, 0};
        if (!st) st = volux_render(v->tech, scene, v->fb_preview, &one, &rep);
        if (!st) st = volux_framebuffer_resolve(v->fb_preview, &img);
        volux_scene_set_render(scene, &full); /* cannot fail: the settings were valid */
        pthread_mutex_lock(&v->frame_lock);
        v->stats.last_update_ms = t1 - t0;
        /* The edit's own changes (the size switch adds RENDER). */
        v->stats.last_changes = changed.what & ~(full.width != small.width || full.height != small.height
                                                     ? (uint32_t)VOLUX_CHANGE_RENDER
                                                     : 0u);
        int lights = 0;
        for (int i = 0; i < VOLUX_MAX_LIGHTS; i++) lights += volux_change_light(&changed, i);
        v->stats.last_lights_changed = lights;
        snprintf(v->stats.technique, sizeof v->stats.technique, "%s", full.technique);
        v->stats.technique_bytes = volux_technique_memory_bytes(v->tech);
        pthread_mutex_unlock(&v->frame_lock);
        if (!st) {
            double edit_t0 = v->need_latency ? v->last_edit_ms : -1;
            v->need_latency = 0;
            v->refined = 0;
            if (v->fb_full) volux_framebuffer_reset(v->fb_full);
            pthread_mutex_unlock(&v->lock);
            publish(v, &img, FRAME_PREVIEW, version, 1, full.exposure, t1 - t0, viewer_now_ms() - t1, edit_t0,
                    v->last_edit_cpu_ms);
            pthread_mutex_lock(&v->lock);
            return;
        }
    }
    volux_image_free(v->ctx, &img);
    render_failed(v, "preview", st);
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
    int final = spp >= target || (rs->target_error > 0 && spp >= 2 && rep.rel_error <= rs->target_error);
    double now = viewer_now_ms();
    if (!final && now - last_publish < PUBLISH_EVERY_MS) return;
    last_publish = now;
    volux_image img = {0};
    if ((st = volux_framebuffer_resolve(v->fb_full, &img))) {
        v->refined = 1;
        render_failed(v, "refinement", st);
        return;
    }
    if (final) v->refined = 1;
    double edit_t0 = final && v->need_final_latency ? v->last_edit_ms : -1;
    if (final) v->need_final_latency = 0;
    uint64_t version = v->shown_version;
    float exposure = rs->exposure;
    pthread_mutex_unlock(&v->lock);
    publish(v, &img, final ? FRAME_FINAL : FRAME_REFINE, version, spp, exposure, 0, now - t0, edit_t0,
            v->last_edit_cpu_ms);
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
    volux_framebuffer_destroy(v->fb_preview);
    volux_framebuffer_destroy(v->fb_full);
    v->tech = v->spare = NULL;
    v->fb_preview = v->fb_full = NULL;
}
