/*
 * tools/viewer/http.c — the HTTP side of `volux serve` on libmicrohttpd:
 * the page, the JSON API (docs/VIEWER.md) and the event stream.
 *
 * One thread per connection (a stream blocks until the next frame), at
 * most `max_connections` of them; a connection idle for `timeout_s`
 * seconds is closed, and so is one whose request (headers and body) is not
 * complete `timeout_s` seconds after it connected: a client trickling one
 * byte every few seconds is never idle, but cannot hold a slot; headers are
 * bounded by the connection memory limit, bodies by MAX_BODY; nothing a
 * client sends can stop the server: every failure is a status code.
 *
 * Authentication (with --token): the token as "Authorization: Bearer T",
 * "X-Volux-Token: T", "?token=T" or the cookie the page response sets
 * (SameSite=Strict, HttpOnly), compared in constant time. Without a token,
 * a server bound to loopback still refuses requests whose Host is not a
 * loopback name (DNS rebinding) and cross-origin edits (an edit must be
 * application/json, which a foreign page cannot send without a preflight
 * this server never answers, and its Origin, if any, must be this host).
 */
#include <arpa/inet.h>
#include <math.h>
#include <cjson/cJSON.h>
#include <microhttpd.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "tools/cli/cli.h"
#include "viewer.h"

#define MAX_BODY (4u << 20)     /* an edit list (a 4096-point TF is ~150 KiB) */
#define KEEPALIVE_MS 4000.0     /* below the idle timeout                     */
#define MAX_WAIT_MS 120000.0    /* longest /api/frame long-poll               */

typedef struct request {
    char *body;
    size_t len, cap;
    int rejected;  /* a response was queued early */
    int too_large; /* the body passed MAX_BODY: discarded, 413 at its end */
    double t0, cpu0;
} request;

/* ------------------------------------------------------------------ slow clients */

/* MHD's timeout is an idle time. A watchdog thread shuts down the socket of
 * every connection whose request is still incomplete `timeout_s` seconds
 * after it connected (MHD then closes it as the peer's). Slots are indexed
 * by the connection's socket context; the lock orders a shutdown before
 * MHD's close of the same descriptor (MHD reports CLOSED first). */
#define SLOW_SLOTS 1024

typedef struct slow_slot {
    int fd;          /* −1: free */
    int complete;    /* the request is in: streams may last as they like */
    double start_ms;
} slow_slot;

struct slow_clients {
    pthread_mutex_t lock;
    pthread_cond_t wake;
    pthread_t thread;
    int quit;
    double limit_ms;
    slow_slot slot[SLOW_SLOTS];
};

static void *slow_watchdog(void *arg) {
    struct slow_clients *s = arg;
    pthread_mutex_lock(&s->lock);
    while (!s->quit) {
        double now = viewer_now_ms();
        for (int i = 0; i < SLOW_SLOTS; i++) {
            slow_slot *t = &s->slot[i];
            if (t->fd >= 0 && !t->complete && now - t->start_ms > s->limit_ms) {
                shutdown(t->fd, SHUT_RDWR);
                t->complete = 1; /* once */
            }
        }
        struct timespec until;
        clock_gettime(CLOCK_REALTIME, &until);
        until.tv_nsec += 200 * 1000 * 1000;
        if (until.tv_nsec >= 1000000000L) until.tv_sec++, until.tv_nsec -= 1000000000L;
        pthread_cond_timedwait(&s->wake, &s->lock, &until);
    }
    pthread_mutex_unlock(&s->lock);
    return NULL;
}

static void on_connection(void *cls, struct MHD_Connection *c, void **socket_context,
                          enum MHD_ConnectionNotificationCode code) {
    viewer *v = cls;
    struct slow_clients *s = v->slow;
    if (!s) return;
    pthread_mutex_lock(&s->lock);
    if (code == MHD_CONNECTION_NOTIFY_STARTED) {
        const union MHD_ConnectionInfo *info = MHD_get_connection_info(c, MHD_CONNECTION_INFO_CONNECTION_FD);
        *socket_context = NULL;
        for (int i = 0; info && i < SLOW_SLOTS; i++)
            if (s->slot[i].fd < 0) {
                s->slot[i].fd = info->connect_fd;
                s->slot[i].complete = 0;
                s->slot[i].start_ms = viewer_now_ms();
                *socket_context = &s->slot[i];
                break;
            }
    } else if (*socket_context) {
        ((slow_slot *)*socket_context)->fd = -1;
        *socket_context = NULL;
    }
    pthread_mutex_unlock(&s->lock);
}

/* The request on `c` is complete: its connection is no longer timed. */
static void request_complete(viewer *v, struct MHD_Connection *c) {
    struct slow_clients *s = v->slow;
    const union MHD_ConnectionInfo *info = MHD_get_connection_info(c, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
    if (!s || !info || !info->socket_context) return;
    pthread_mutex_lock(&s->lock);
    ((slow_slot *)info->socket_context)->complete = 1;
    pthread_mutex_unlock(&s->lock);
}

static struct slow_clients *slow_clients_start(double limit_ms) {
    struct slow_clients *s = calloc(1, sizeof *s);
    if (!s) return NULL;
    for (int i = 0; i < SLOW_SLOTS; i++) s->slot[i].fd = -1;
    s->limit_ms = limit_ms;
    pthread_mutex_init(&s->lock, NULL);
    pthread_cond_init(&s->wake, NULL);
    if (pthread_create(&s->thread, NULL, slow_watchdog, s) != 0) {
        pthread_cond_destroy(&s->wake);
        pthread_mutex_destroy(&s->lock);
        free(s);
        return NULL;
    }
    return s;
}

static void slow_clients_stop(struct slow_clients *s) {
    if (!s) return;
    pthread_mutex_lock(&s->lock);
    s->quit = 1;
    pthread_cond_signal(&s->wake);
    pthread_mutex_unlock(&s->lock);
    pthread_join(s->thread, NULL);
    pthread_cond_destroy(&s->wake);
    pthread_mutex_destroy(&s->lock);
    free(s);
}

/* ------------------------------------------------------------------ replies */

/* Every reply's headers; retry_after (seconds, may be NULL) for a 503. */
static enum MHD_Result reply_retry(struct MHD_Connection *c, unsigned code, const char *type, const void *data,
                                   size_t n, enum MHD_ResponseMemoryMode mode, const char *retry_after) {
    struct MHD_Response *r = MHD_create_response_from_buffer(n, (void *)data, mode);
    if (!r) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", type);
    MHD_add_response_header(r, "Cache-Control", "no-store");
    MHD_add_response_header(r, "X-Content-Type-Options", "nosniff");
    MHD_add_response_header(r, "Referrer-Policy", "no-referrer");
    if (retry_after) MHD_add_response_header(r, "Retry-After", retry_after);
    enum MHD_Result ok = MHD_queue_response(c, code, r);
    MHD_destroy_response(r);
    return ok;
}

static enum MHD_Result reply(struct MHD_Connection *c, unsigned code, const char *type, const void *data,
                             size_t n, enum MHD_ResponseMemoryMode mode) {
    return reply_retry(c, code, type, data, n, mode, NULL);
}

static enum MHD_Result reply_json(struct MHD_Connection *c, unsigned code, char *json /* malloc'ed, taken */) {
    if (!json) return reply(c, 500, "application/json", "{\"error\":\"out of memory\"}", 25, MHD_RESPMEM_PERSISTENT);
    return reply(c, code, "application/json", json, strlen(json), MHD_RESPMEM_MUST_FREE);
}

static enum MHD_Result reply_error(viewer *v, struct MHD_Connection *c, unsigned code, const char *status,
                                   const char *msg) {
    pthread_mutex_lock(&v->frame_lock);
    v->stats.requests_rejected++;
    pthread_mutex_unlock(&v->frame_lock);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "error", msg);
    cJSON_AddStringToObject(o, "status", status);
    char *text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    char *copy = text ? strdup(text) : NULL;
    cJSON_free(text);
    return reply_json(c, code, copy);
}

static unsigned http_code_of(volux_status st) {
    switch (st) {
    case VOLUX_OK: return 200;
    case VOLUX_ERR_LIMIT: return 413;
    case VOLUX_ERR_NOMEM:
    case VOLUX_ERR_INTERNAL:
    case VOLUX_ERR_WRITE:
    case VOLUX_ERR_CANCELLED: return 500;
    default: return 400; /* INVALID, IO, FORMAT, UNSUPPORTED: the request was at fault */
    }
}

/* ------------------------------------------------------------------ checks */

static int same_secret(const char *a, const char *b) {
    size_t na = strlen(a), nb = strlen(b);
    unsigned diff = (unsigned)(na ^ nb);
    for (size_t i = 0; i < nb; i++) diff |= (unsigned)(unsigned char)(i < na ? a[i] : 0) ^ (unsigned char)b[i];
    return diff == 0;
}

static int authorized(viewer *v, struct MHD_Connection *c) {
    const char *token = v->opt.token;
    if (!token) return 1;
    const char *h = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Authorization");
    if (h && !strncasecmp(h, "Bearer ", 7) && same_secret(h + 7, token)) return 1;
    h = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "X-Volux-Token");
    if (h && same_secret(h, token)) return 1;
    h = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "token");
    if (h && same_secret(h, token)) return 1;
    h = MHD_lookup_connection_value(c, MHD_COOKIE_KIND, "volux_token");
    return h && same_secret(h, token);
}

static int loopback_bind(const viewer *v) {
    const char *b = v->opt.bind;
    return !strncmp(b, "127.", 4) || !strcmp(b, "::1") || !strcmp(b, "localhost");
}

/* "127.0.0.1:8080", "localhost", "[::1]:80" → is the name a loopback one? */
static int loopback_host(const char *host) {
    char name[256];
    size_t n = strlen(host);
    if (!n || n >= sizeof name) return 0;
    const char *port;
    if (host[0] == '[') {
        const char *end = strchr(host, ']');
        if (!end) return 0;
        snprintf(name, sizeof name, "%.*s", (int)(end - host - 1), host + 1);
        port = end + 1;
    } else {
        const char *colon = strchr(host, ':');
        snprintf(name, sizeof name, "%.*s", (int)(colon ? (size_t)(colon - host) : n), host);
        port = colon ? colon : host + n;
    }
    /* Nothing may follow the name but ":" and 1-5 digits: "localhost:80@evil.com"
     * is not a loopback name. */
    if (*port) {
        size_t digits = strspn(port + 1, "0123456789");
        if (port[0] != ':' || digits < 1 || digits > 5 || port[1 + digits]) return 0;
    }
    if (!strcasecmp(name, "localhost")) return 1;
    struct in_addr a4;
    struct in6_addr a6;
    if (inet_pton(AF_INET, name, &a4) == 1) return (ntohl(a4.s_addr) >> 24) == 127;
    if (inet_pton(AF_INET6, name, &a6) == 1) return IN6_IS_ADDR_LOOPBACK(&a6);
    return 0;
}

/* ------------------------------------------------------------------ events */

typedef struct stream {
    viewer *v;
    uint64_t last_frame;
    uint64_t last_scene;
    uint64_t last_busy;
    char *pending;
    size_t len, off;
    int done;
} stream;

/* The next event for a stream (malloc'ed), waiting for one; NULL at exit. */
static char *next_event(stream *s) {
    viewer *v = s->v;
    static const char *const kinds[] = {"preview", "refine", "final"};
    char *event = NULL;
    viewer_pixels *px = NULL;
    char head[640];
    int hn = 0;
    pthread_mutex_lock(&v->frame_lock);
    double deadline = viewer_now_ms() + KEEPALIVE_MS;
    for (;;) {
        if (atomic_load(&v->quit)) break;
        uint64_t scene_version;
        pthread_mutex_lock(&v->snap_lock);
        scene_version = v->snap_version;
        pthread_mutex_unlock(&v->snap_lock);
        if (scene_version != s->last_scene) {
            s->last_scene = scene_version;
            char buf[96];
            snprintf(buf, sizeof buf, "event: scene\ndata: {\"version\":%llu}\n\n", (unsigned long long)scene_version);
            event = strdup(buf);
            break;
        }
        if (v->busy.seq != s->last_busy) { /* a preparation's progress (renderer.c, set_busy) */
            s->last_busy = v->busy.seq;
            cJSON *o = cJSON_CreateObject();
            cJSON_AddStringToObject(o, "task", v->busy.task);
            cJSON_AddNumberToObject(o, "percent", (int)(v->busy.fraction * 100.0));
            char *t = cJSON_PrintUnformatted(o);
            cJSON_Delete(o);
            if (t) {
                size_t n = strlen(t) + 32;
                event = malloc(n);
                if (event) snprintf(event, n, "event: busy\ndata: %s\n\n", t);
                cJSON_free(t);
            }
            break;
        }
        if (v->frame.id != s->last_frame) {
            s->last_frame = v->frame.id;
            if (v->stats.error[0]) {
                cJSON *o = cJSON_CreateObject();
                cJSON_AddStringToObject(o, "error", v->stats.error);
                char *t = cJSON_PrintUnformatted(o);
                cJSON_Delete(o);
                if (t) {
                    size_t n = strlen(t) + 32;
                    event = malloc(n);
                    if (event) snprintf(event, n, "event: failure\ndata: %s\n\n", t);
                    cJSON_free(t);
                }
                break;
            }
            if (!v->frame.data) continue;
            const viewer_frame *f = &v->frame;
            hn = snprintf(head, sizeof head,
                          "event: frame\ndata: {\"id\":%llu,\"version\":%llu,\"kind\":\"%s\",\"spp\":%u,"
                          "\"width\":%d,\"height\":%d,\"format\":\"%s\",\"bytes\":%zu,\"update_ms\":%.3f,"
                          "\"render_ms\":%.3f,\"encode_ms\":%.3f,\"latency_ms\":%.3f,\"cpu_ms\":%.3f,\"step_scale\":%.3f,\"stand_in\":\"%s\",\"data\":\"",
                          (unsigned long long)f->id, (unsigned long long)f->version, kinds[f->kind], f->spp,
                          f->width, f->height, f->format, f->size, f->update_ms, f->render_ms, f->encode_ms,
                          f->latency_ms, f->cpu_ms, (double)f->step_scale, f->stand_in);
            px = viewer_pixels_retain(f->px); /* base64 below, without the lock */
            break;
        }
        double now = viewer_now_ms();
        if (now >= deadline) {
            event = strdup(": keepalive\n\n");
            break;
        }
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        long long ns = (long long)ts.tv_nsec + (long long)((deadline - now) * 1e6);
        ts.tv_sec += (time_t)(ns / 1000000000LL);
        ts.tv_nsec = (long)(ns % 1000000000LL);
        pthread_cond_timedwait(&v->frame_cv, &v->frame_lock, &ts);
    }
    pthread_mutex_unlock(&v->frame_lock);
    if (px) {
        size_t n64 = 0;
        char *b64 = viewer_base64(px->data, px->size, &n64);
        if (b64 && hn > 0 && (size_t)hn < sizeof head) {
            event = malloc((size_t)hn + n64 + 8);
            if (event) {
                memcpy(event, head, (size_t)hn);
                memcpy(event + hn, b64, n64);
                memcpy(event + (size_t)hn + n64, "\"}\n\n", 5);
            }
        }
        free(b64);
        viewer_pixels_release(px);
    }
    return event;
}

static ssize_t stream_read(void *cls, uint64_t pos, char *buf, size_t max) {
    (void)pos;
    stream *s = cls;
    if (s->off == s->len) {
        free(s->pending);
        s->pending = next_event(s);
        s->off = 0;
        s->len = s->pending ? strlen(s->pending) : 0;
        if (!s->pending) return MHD_CONTENT_READER_END_OF_STREAM;
    }
    size_t n = s->len - s->off < max ? s->len - s->off : max;
    memcpy(buf, s->pending + s->off, n);
    s->off += n;
    return (ssize_t)n;
}

static void stream_free(void *cls) {
    stream *s = cls;
    free(s->pending);
    free(s);
}

static enum MHD_Result serve_events(viewer *v, struct MHD_Connection *c) {
    stream *s = calloc(1, sizeof *s);
    if (!s) return MHD_NO;
    s->v = v;
    /* The first event is the current frame (if any) and the scene version. */
    s->last_frame = (uint64_t)-1;
    s->last_scene = (uint64_t)-1;
    struct MHD_Response *r = MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 32 * 1024, stream_read, s, stream_free);
    if (!r) {
        free(s);
        return MHD_NO;
    }
    MHD_add_response_header(r, "Content-Type", "text/event-stream");
    MHD_add_response_header(r, "Cache-Control", "no-store");
    MHD_add_response_header(r, "X-Accel-Buffering", "no");
    enum MHD_Result ok = MHD_queue_response(c, 200, r);
    MHD_destroy_response(r);
    return ok;
}

/* ------------------------------------------------------------------ frame */

/* Downloads of frames larger than this many pixels (a 512² PFM is 3 MiB)
 * are "large": at most MAX_LARGE_DOWNLOADS of them are encoded or sent at
 * once; another gets 503 with Retry-After (docs/VIEWER.md). */
#define LARGE_DOWNLOAD_PIXELS (512.0 * 512.0)
#define MAX_LARGE_DOWNLOADS 2
#define RETRY_AFTER_S "1"

/* One frame download: the bytes sent, and who owns them (the shared
 * pixels, a malloc'ed JPEG or an encode of its own context). */
typedef struct download {
    viewer *v;
    viewer_pixels *px;
    unsigned char *own, *enc;
    volux_context *ctx;
    const unsigned char *data;
    size_t size;
    int large;
} download;

static ssize_t download_read(void *cls, uint64_t pos, char *buf, size_t max) {
    download *d = cls;
    if (pos >= d->size) return MHD_CONTENT_READER_END_OF_STREAM;
    size_t n = d->size - (size_t)pos < max ? d->size - (size_t)pos : max;
    memcpy(buf, d->data + pos, n);
    return (ssize_t)n;
}

/* MHD's free callback: the response was sent, or the client went away. */
static void download_free(void *cls) {
    download *d = cls;
    viewer_pixels_release(d->px);
    free(d->own);
    if (d->enc) volux_encoded_free(d->ctx, d->enc, d->size);
    volux_context_destroy(d->ctx);
    if (d->large) atomic_fetch_sub(&d->v->large_downloads, 1);
    free(d);
}

/* 503 with Retry-After: every large-download slot is taken. Called with
 * `frame_lock` released. */
static enum MHD_Result reply_busy(viewer *v, struct MHD_Connection *c) {
    char msg[160];
    snprintf(msg, sizeof msg, "%d large frame downloads are in progress; retry after %s s", MAX_LARGE_DOWNLOADS,
             RETRY_AFTER_S);
    pthread_mutex_lock(&v->frame_lock);
    v->stats.requests_rejected++;
    pthread_mutex_unlock(&v->frame_lock);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "error", msg);
    cJSON_AddStringToObject(o, "status", "busy");
    char *text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    if (!text) return MHD_NO;
    enum MHD_Result ok =
        reply_retry(c, 503, "application/json", text, strlen(text), MHD_RESPMEM_MUST_COPY, RETRY_AFTER_S);
    cJSON_free(text);
    return ok;
}

static double arg_number(struct MHD_Connection *c, const char *key, double fallback) {
    const char *s = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, key);
    if (!s || !*s) return fallback;
    char *end;
    double d = strtod(s, &end);
    return *end || d != d ? fallback : d;
}

static enum MHD_Result serve_frame(viewer *v, struct MHD_Connection *c) {
    const char *format = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "format");
    const char *wait = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "wait");
    if (!format) format = "png";
    if (strcmp(format, "png") && strcmp(format, "jpeg") && strcmp(format, "pfm") && strcmp(format, "exr"))
        return reply_error(v, c, 400, "invalid", "format: expected png, jpeg, pfm or exr");
    if (wait && strcmp(wait, "final")) return reply_error(v, c, 400, "invalid", "wait: expected final");
    double after = arg_number(c, "after", -1);
    double timeout = arg_number(c, "timeout", 30000);
    if (timeout < 0) timeout = 0;
    if (timeout > MAX_WAIT_MS) timeout = MAX_WAIT_MS;
    /* `wait=final`: the final frame of the current document version (what
     * "save image" downloads); `after=ID`: the first frame newer than ID. */
    uint64_t want_version = 0;
    if (wait) {
        pthread_mutex_lock(&v->snap_lock);
        want_version = v->snap_version;
        pthread_mutex_unlock(&v->snap_lock);
    }
    double deadline = viewer_now_ms() + timeout;
    pthread_mutex_lock(&v->frame_lock);
    for (;;) {
        viewer_frame *f = &v->frame;
        int ready = f->data && (!wait || (f->kind == FRAME_FINAL && f->version >= want_version)) &&
                    (after < 0 || (double)f->id > after);
        if (ready || atomic_load(&v->quit)) break;
        if (v->stats.error[0] && wait) break;
        double now = viewer_now_ms();
        if (now >= deadline) break;
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        long long ns = (long long)ts.tv_nsec + (long long)((deadline - now) * 1e6);
        ts.tv_sec += (time_t)(ns / 1000000000LL);
        ts.tv_nsec = (long)(ns % 1000000000LL);
        pthread_cond_timedwait(&v->frame_cv, &v->frame_lock, &ts);
    }
    viewer_frame *f = &v->frame;
    int ready = f->data && (!wait || (f->kind == FRAME_FINAL && f->version >= want_version)) &&
                (after < 0 || (double)f->id > after);
    if (!ready) {
        char msg[600];
        snprintf(msg, sizeof msg, "%s", v->stats.error[0] ? v->stats.error : "no such frame yet (timed out)");
        pthread_mutex_unlock(&v->frame_lock);
        return reply_error(v, c, v->stats.error[0] ? 500 : 503, "unavailable", msg);
    }
    static const char *const kinds[] = {"preview", "refine", "final"};
    char id[32], version[32], spp[16];
    snprintf(id, sizeof id, "%llu", (unsigned long long)f->id);
    snprintf(version, sizeof version, "%llu", (unsigned long long)f->version);
    snprintf(spp, sizeof spp, "%u", f->spp);
    const char *kind = kinds[f->kind];
    const int same = !strcmp(format, f->format);
    const float exposure = f->exposure;
    /* A large frame holds a slot from here until its response is freed
     * (sent, or the client gone): at most MAX_LARGE_DOWNLOADS such
     * encodes and buffers exist at once, whatever the number of clients. */
    const int large = (double)f->width * f->height > LARGE_DOWNLOAD_PIXELS;
    if (large && atomic_fetch_add(&v->large_downloads, 1) >= MAX_LARGE_DOWNLOADS) {
        atomic_fetch_sub(&v->large_downloads, 1);
        v->stats.downloads_refused++;
        pthread_mutex_unlock(&v->frame_lock);
        return reply_busy(v, c);
    }
    viewer_pixels *px = viewer_pixels_retain(f->px);
    pthread_mutex_unlock(&v->frame_lock);
    /* Without the frame lock from here on: publishing, /api/stats and the
     * event streams go on while this frame is encoded and sent. */
    download *d = calloc(1, sizeof *d);
    if (!d) {
        viewer_pixels_release(px);
        if (large) atomic_fetch_sub(&v->large_downloads, 1);
        return reply_error(v, c, 500, "nomem", "out of memory");
    }
    d->v = v;
    d->large = large;
    const char *type = "image/png";
    int ok = 1;
    if (same) { /* the published encoding: sent from the shared pixels, no copy */
        d->px = px;
        d->data = px->data;
        d->size = px->size;
        type = !strcmp(format, "jpeg") ? "image/jpeg" : "image/png";
    } else if (!strcmp(format, "jpeg")) {
        ok = viewer_encode_jpeg(&px->image, exposure, v->opt.jpeg_quality, &d->own, &d->size);
        d->data = d->own;
        type = "image/jpeg";
        viewer_pixels_release(px);
    } else {
        volux_context_desc cd = {0};
        cd.max_bytes = volux_context_max_bytes(v->ctx);
        volux_image_meta meta;
        viewer_png_meta(&meta, exposure);
        ok = volux_context_create(&cd, &d->ctx) == VOLUX_OK &&
             volux_image_encode_meta(d->ctx, &px->image, format, exposure, !strcmp(format, "png") ? &meta : NULL,
                                     &d->enc, &d->size) == VOLUX_OK;
        d->data = d->enc;
        type = !strcmp(format, "png") ? "image/png" : "application/octet-stream";
        viewer_pixels_release(px);
    }
    if (!ok) {
        download_free(d);
        return reply_error(v, c, 500, "nomem", "encoding the frame failed");
    }
    struct MHD_Response *r = MHD_create_response_from_callback(d->size, 256 * 1024, download_read, d, download_free);
    if (!r) {
        download_free(d);
        return MHD_NO;
    }
    MHD_add_response_header(r, "Content-Type", type);
    MHD_add_response_header(r, "Cache-Control", "no-store");
    MHD_add_response_header(r, "X-Volux-Frame", id);
    MHD_add_response_header(r, "X-Volux-Version", version);
    MHD_add_response_header(r, "X-Volux-Kind", kind);
    MHD_add_response_header(r, "X-Volux-Spp", spp);
    if (MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "download")) {
        char disp[64];
        snprintf(disp, sizeof disp, "attachment; filename=\"volux.%s\"", !strcmp(format, "jpeg") ? "jpg" : format);
        MHD_add_response_header(r, "Content-Disposition", disp);
    }
    enum MHD_Result res = MHD_queue_response(c, 200, r);
    MHD_destroy_response(r);
    return res;
}

/* ------------------------------------------------------------------ edit */

static enum MHD_Result serve_edit(viewer *v, struct MHD_Connection *c, request *rq) {
    viewer_lock_edit(v);
    volux_context_clear_error(v->ctx);
    uint32_t changed = 0;
    volux_status st = volux_scene_doc_edit_json(v->doc, rq->body ? rq->body : "", rq->len, &changed);
    char msg[1100];
    snprintf(msg, sizeof msg, "%s", volux_context_error(v->ctx));
    uint64_t version = volux_scene_doc_version(v->doc);
    if (!st) {
        if (!v->need_latency) { /* coalesced edits: the oldest one counts */
            v->last_edit_ms = rq->t0;
            v->last_edit_cpu_ms = rq->cpu0;
        }
        v->last_change_ms = rq->t0;
        v->pending_changes |= changed;
        v->need_latency = v->need_final_latency = 1;
        if (!viewer_snapshot(v)) st = VOLUX_ERR_NOMEM, snprintf(msg, sizeof msg, "out of memory");
    }
    viewer_unlock(v, st == VOLUX_OK);
    pthread_mutex_lock(&v->frame_lock);
    if (st) v->stats.edits_rejected++;
    else v->stats.edits++;
    pthread_cond_broadcast(&v->frame_cv); /* streams announce the new scene version */
    pthread_mutex_unlock(&v->frame_lock);
    if (st) return reply_error(v, c, http_code_of(st), volux_status_name(st), msg);
    static const char *const names[] = {"volume", "transfer_function", "camera", "lights", "other"};
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "version", (double)version);
    cJSON *ch = cJSON_AddArrayToObject(o, "changed");
    for (int i = 0; i < 5; i++)
        if (changed & (1u << i)) cJSON_AddItemToArray(ch, cJSON_CreateString(names[i]));
    char *text = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    char *copy = text ? strdup(text) : NULL;
    cJSON_free(text);
    return reply_json(c, 200, copy);
}

/* ------------------------------------------------------------------ slices */

/* GET /api/slice?axis=x|y|z[&index=N][&mode=tf|grey][&window=W][&level=L]:
 * a PNG of one axis-aligned slice of the raw volume (slice.c). */
static enum MHD_Result serve_slice(viewer *v, struct MHD_Connection *c) {
    viewer_slice_request rq = {0};
    const char *axis = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "axis");
    const char *index = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "index");
    const char *mode = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "mode");
    const char *window = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "window");
    const char *level = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "level");
    if (!axis || strlen(axis) != 1 || !strchr("xyz", axis[0]))
        return reply_error(v, c, 400, "invalid", "axis: expected x, y or z");
    rq.axis = axis[0] - 'x';
    rq.index = -1;
    char *end;
    if (index) {
        long n = strtol(index, &end, 10);
        if (!*index || *end || n < 0 || n > 1 << 30)
            return reply_error(v, c, 400, "invalid", "index: expected a voxel index >= 0");
        rq.index = (int)n;
    }
    if (mode && strcmp(mode, "tf") && strcmp(mode, "grey"))
        return reply_error(v, c, 400, "invalid", "mode: expected tf or grey");
    rq.grey = mode && !strcmp(mode, "grey");
    if (window) {
        rq.window = strtod(window, &end);
        if (!*window || *end || !(rq.window > 0) || !isfinite(rq.window))
            return reply_error(v, c, 400, "invalid", "window: expected a number > 0");
    }
    if (level) {
        rq.level = strtod(level, &end);
        if (!*level || *end || !isfinite(rq.level)) return reply_error(v, c, 400, "invalid", "level: expected a number");
        rq.has_level = 1;
    }
    volux_context *ctx = NULL;
    volux_context_desc cd = {0};
    cd.max_bytes = volux_context_max_bytes(v->ctx);
    if (volux_context_create(&cd, &ctx)) return reply_error(v, c, 500, "nomem", "out of memory");
    volux_image img = {0};
    char err[256] = "";
    unsigned char *png = NULL;
    size_t size = 0;
    int code = viewer_slice_image(v, &rq, ctx, &img, err, sizeof err);
    if (code == 200 && volux_image_encode(ctx, &img, "png", 0.0f, &png, &size)) {
        code = 500;
        snprintf(err, sizeof err, "encoding the slice failed");
    }
    volux_image_free(ctx, &img);
    enum MHD_Result res;
    if (code != 200) {
        res = reply_error(v, c, (unsigned)code, code == 400 ? "invalid" : code == 413 ? "limit" : "nomem", err);
    } else {
        unsigned char *copy = malloc(size);
        if (copy) memcpy(copy, png, size);
        res = copy ? reply(c, 200, "image/png", copy, size, MHD_RESPMEM_MUST_FREE)
                   : reply_error(v, c, 500, "nomem", "out of memory");
    }
    if (png) volux_encoded_free(ctx, png, size);
    volux_context_destroy(ctx);
    return res;
}

/* ------------------------------------------------------------------ viewer settings */

/* POST /api/view {"auto_exposure": bool, "expose": true, "denoise": bool}:
 * the viewer's own switches (not the scene's): automatic exposure on/off,
 * apply it now (from the next frame of the technique), denoised frames
 * on/off. Each redraws the current state. */
static enum MHD_Result serve_view(viewer *v, struct MHD_Connection *c, request *rq) {
    cJSON *o = cJSON_ParseWithLength(rq->body ? rq->body : "", rq->len);
    if (!cJSON_IsObject(o)) {
        cJSON_Delete(o);
        return reply_error(v, c, 400, "invalid", "expected a JSON object {\"auto_exposure\", \"expose\", \"denoise\"}");
    }
    int set_auto = -1, expose = 0, denoise = -1;
    for (cJSON *k = o->child; k; k = k->next) {
        int *slot = !strcmp(k->string, "auto_exposure") ? &set_auto
                    : !strcmp(k->string, "expose")      ? &expose
                    : !strcmp(k->string, "denoise")     ? &denoise
                                                        : NULL;
        char msg[160];
        if (!slot) {
            snprintf(msg, sizeof msg, "unknown key '%.64s' (known: auto_exposure, expose, denoise)", k->string);
            cJSON_Delete(o);
            return reply_error(v, c, 400, "invalid", msg);
        }
        if (!cJSON_IsBool(k)) {
            snprintf(msg, sizeof msg, "%s: expected true or false", k->string);
            cJSON_Delete(o);
            return reply_error(v, c, 400, "invalid", msg);
        }
        *slot = cJSON_IsTrue(k);
    }
    cJSON_Delete(o);
    viewer_lock_edit(v);
    if (set_auto >= 0) atomic_store(&v->auto_exposure, set_auto);
    if (expose || set_auto == 1) atomic_store(&v->auto_due, 1);
    if (denoise >= 0) atomic_store(&v->no_denoise, !denoise);
    v->shown_version = (uint64_t)-1; /* the render thread redraws the state */
    v->last_change_ms = rq->t0;
    viewer_unlock(v, 1);
    char body[96];
    snprintf(body, sizeof body, "{\"auto_exposure\":%s,\"denoise\":%s}",
             atomic_load(&v->auto_exposure) ? "true" : "false", atomic_load(&v->no_denoise) ? "false" : "true");
    return reply_json(c, 200, strdup(body));
}

/* ------------------------------------------------------------------ routing */

static enum MHD_Result serve_snapshot(viewer *v, struct MHD_Connection *c, int which) {
    pthread_mutex_lock(&v->snap_lock);
    const char *src = which == 0 ? v->scene_json : which == 1 ? v->scene_json_abs : v->state_json;
    char *copy = src ? strdup(src) : NULL;
    pthread_mutex_unlock(&v->snap_lock);
    if (!copy) return reply_error(v, c, 500, "nomem", "out of memory");
    struct MHD_Response *r = MHD_create_response_from_buffer(strlen(copy), copy, MHD_RESPMEM_MUST_FREE);
    if (!r) {
        free(copy);
        return MHD_NO;
    }
    MHD_add_response_header(r, "Content-Type", "application/json");
    MHD_add_response_header(r, "Cache-Control", "no-store");
    if (which != 2 && MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "download"))
        MHD_add_response_header(r, "Content-Disposition", "attachment; filename=\"scene.json\"");
    enum MHD_Result ok = MHD_queue_response(c, 200, r);
    MHD_destroy_response(r);
    return ok;
}

static enum MHD_Result serve_asset(viewer *v, struct MHD_Connection *c, const char *url) {
    const viewer_asset *a = viewer_asset_find(!strcmp(url, "/") ? "/index.html" : url);
    if (!a) return reply_error(v, c, 404, "invalid", "no such page");
    struct MHD_Response *r = MHD_create_response_from_buffer(a->size, (void *)a->data, MHD_RESPMEM_PERSISTENT);
    if (!r) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", a->type);
    MHD_add_response_header(r, "Cache-Control", "no-store");
    MHD_add_response_header(r, "X-Content-Type-Options", "nosniff");
    MHD_add_response_header(r, "X-Frame-Options", "DENY");
    MHD_add_response_header(r, "Referrer-Policy", "no-referrer");
    /* Everything the page needs comes from this server (no CDN). */
    MHD_add_response_header(r, "Content-Security-Policy",
                            "default-src 'self'; img-src 'self' data: blob:; style-src 'self'; script-src 'self'; "
                            "connect-src 'self'; frame-ancestors 'none'");
    if (v->opt.token && strstr(a->type, "text/html")) {
        char cookie[512];
        snprintf(cookie, sizeof cookie, "volux_token=%s; Path=/; HttpOnly; SameSite=Strict", v->opt.token);
        MHD_add_response_header(r, "Set-Cookie", cookie);
    }
    enum MHD_Result ok = MHD_queue_response(c, 200, r);
    MHD_destroy_response(r);
    return ok;
}

/* "application/json", alone or with parameters ("; charset=utf-8"). */
static int json_media_type(const char *type) {
    static const char want[] = "application/json";
    if (strncasecmp(type, want, sizeof want - 1)) return 0;
    const char *rest = type + sizeof want - 1;
    rest += strspn(rest, " \t");
    return !*rest || *rest == ';';
}

/* The Origin of a same-origin request: "http://" or "https://" and
 * exactly the Host it was sent to. "null" (a sandboxed or file: page) and
 * other schemes are cross-origin. */
static int same_origin(const char *origin, const char *host) {
    if (!host) return 0;
    const char *rest = !strncasecmp(origin, "http://", 7) ? origin + 7 : !strncasecmp(origin, "https://", 8) ? origin + 8 : NULL;
    return rest && !strcmp(rest, host);
}

/* Every Content-Length header must agree: two that differ make the body's
 * end ambiguous (request smuggling through a proxy). */
typedef struct length_headers {
    const char *first;
    int conflict;
} length_headers;

static enum MHD_Result collect_length(void *cls, enum MHD_ValueKind kind, const char *key, const char *value) {
    (void)kind;
    length_headers *l = cls;
    if (strcasecmp(key, "Content-Length")) return MHD_YES;
    if (!l->first) l->first = value;
    else if (strcmp(l->first, value)) l->conflict = 1;
    return MHD_YES;
}

/* Checks that apply before the body is read; returns a queued rejection
 * (MHD_YES/NO) through *handled. */
static enum MHD_Result precheck(viewer *v, struct MHD_Connection *c, const char *url, const char *method,
                                int *handled) {
    *handled = 1;
    int is_get = !strcmp(method, "GET") || !strcmp(method, "HEAD"), is_post = !strcmp(method, "POST");
    if (!is_get && !is_post) return reply_error(v, c, 405, "invalid", "method not allowed (GET, HEAD, POST)");
    if (loopback_bind(v) && !v->opt.token) {
        const char *host = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Host");
        if (!host || !loopback_host(host))
            return reply_error(v, c, 403, "invalid", "Host must be a loopback name (127.0.0.1, localhost, [::1])");
    }
    if (!authorized(v, c)) return reply_error(v, c, 401, "invalid", "missing or wrong token");
    if (is_post) {
        if (strcmp(url, "/api/edit") && strcmp(url, "/api/view"))
            return reply_error(v, c, 405, "invalid", "only /api/edit and /api/view take POST");
        const char *type = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Content-Type");
        if (!type || !json_media_type(type))
            return reply_error(v, c, 415, "invalid", "an edit must be sent as application/json");
        const char *origin = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Origin");
        const char *host = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Host");
        if (origin && !same_origin(origin, host))
            return reply_error(v, c, 403, "invalid", "cross-origin edits are refused");
        length_headers lengths = {NULL, 0};
        MHD_get_connection_values(c, MHD_HEADER_KIND, collect_length, &lengths);
        if (lengths.conflict) return reply_error(v, c, 400, "invalid", "conflicting Content-Length headers");
        const char *len = lengths.first;
        if (len && strtoull(len, NULL, 10) > MAX_BODY)
            return reply_error(v, c, 413, "limit", "request body larger than 4 MiB");
    } else if (!strcmp(url, "/api/edit") || !strcmp(url, "/api/view")) {
        return reply_error(v, c, 405, "invalid", !strcmp(url, "/api/edit") ? "/api/edit takes POST" : "/api/view takes POST");
    }
    *handled = 0;
    return MHD_YES;
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                                  const char *version, const char *upload_data, size_t *upload_size, void **con_cls) {
    (void)version;
    viewer *v = cls;
    request *rq = *con_cls;
    if (!rq) {
        rq = calloc(1, sizeof *rq);
        if (!rq) return MHD_NO;
        *con_cls = rq;
        pthread_mutex_lock(&v->frame_lock);
        v->stats.requests++;
        pthread_mutex_unlock(&v->frame_lock);
        int handled;
        enum MHD_Result res = precheck(v, c, url, method, &handled);
        if (handled) {
            rq->rejected = 1;
            request_complete(v, c);
            return res;
        }
        return MHD_YES; /* headers done; the body (if any) follows */
    }
    if (rq->rejected) {
        *upload_size = 0; /* discard what still arrives */
        return MHD_YES;
    }
    if (rq->too_large) {
        /* A body without a declared length (chunked) that passed the
         * limit: read and dropped to its end, then the documented 413
         * (a response cannot be queued mid-upload; the per-client time
         * limit bounds how long this may take). */
        if (*upload_size) {
            *upload_size = 0;
            return MHD_YES;
        }
        rq->rejected = 1;
        return reply_error(v, c, 413, "limit", "request body larger than 4 MiB");
    }
    if (*upload_size) {
        if (rq->len + *upload_size > MAX_BODY) {
            rq->too_large = 1;
            *upload_size = 0;
            return MHD_YES;
        }
        if (rq->len + *upload_size + 1 > rq->cap) {
            size_t cap = rq->cap ? rq->cap : 4096;
            while (cap < rq->len + *upload_size + 1) cap *= 2;
            char *b = realloc(rq->body, cap);
            if (!b) return MHD_NO;
            rq->body = b;
            rq->cap = cap;
        }
        memcpy(rq->body + rq->len, upload_data, *upload_size);
        rq->len += *upload_size;
        rq->body[rq->len] = 0;
        *upload_size = 0;
        return MHD_YES;
    }
    request_complete(v, c);
    rq->t0 = viewer_now_ms();
    rq->cpu0 = viewer_cpu_ms();
    if (!strcmp(method, "POST")) return !strcmp(url, "/api/view") ? serve_view(v, c, rq) : serve_edit(v, c, rq);
    if (!strcmp(url, "/api/scene")) {
        const char *paths = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "paths");
        if (paths && strcmp(paths, "absolute") && strcmp(paths, "relative"))
            return reply_error(v, c, 400, "invalid", "paths: expected absolute or relative");
        return serve_snapshot(v, c, paths && !strcmp(paths, "absolute") ? 1 : 0);
    }
    if (!strcmp(url, "/api/state")) return serve_snapshot(v, c, 2);
    if (!strcmp(url, "/api/techniques")) return reply_json(c, 200, viewer_techniques_json());
    if (!strcmp(url, "/api/stats")) return reply_json(c, 200, viewer_stats_json(v));
    if (!strcmp(url, "/api/frame")) return serve_frame(v, c);
    if (!strcmp(url, "/api/events")) return serve_events(v, c);
    if (!strcmp(url, "/api/slice")) return serve_slice(v, c);
    if (!strncmp(url, "/api/", 5) || !strcmp(url, "/api")) return reply_error(v, c, 404, "invalid", "no such API");
    if (!strcmp(url, "/favicon.ico")) return reply(c, 204, "image/x-icon", "", 0, MHD_RESPMEM_PERSISTENT);
    return serve_asset(v, c, url);
}

static void on_completed(void *cls, struct MHD_Connection *c, void **con_cls, enum MHD_RequestTerminationCode toe) {
    (void)cls;
    (void)c;
    (void)toe;
    request *rq = *con_cls;
    if (rq) {
        free(rq->body);
        free(rq);
    }
    *con_cls = NULL;
}

static void on_log(void *cls, const char *fmt, va_list ap) {
    viewer *v = cls;
    if (v->opt.quiet) return;
    fprintf(stderr, "volux serve: http: ");
    vfprintf(stderr, fmt, ap);
}

int viewer_http_start(viewer *v) {
    struct sockaddr_storage addr;
    memset(&addr, 0, sizeof addr);
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_THREAD_PER_CONNECTION | MHD_USE_ERROR_LOG;
    /* Before the daemon: its first connection may come at once. Without
     * the watchdog (no thread), only the idle timeout applies. */
    v->slow = slow_clients_start(1000.0 * v->opt.timeout_s);
    const char *bind = !strcmp(v->opt.bind, "localhost") ? "127.0.0.1" : v->opt.bind;
    struct sockaddr_in *a4 = (struct sockaddr_in *)&addr;
    struct sockaddr_in6 *a6 = (struct sockaddr_in6 *)&addr;
    if (inet_pton(AF_INET, bind, &a4->sin_addr) == 1) {
        a4->sin_family = AF_INET;
        a4->sin_port = htons((uint16_t)v->opt.port);
    } else if (inet_pton(AF_INET6, bind, &a6->sin6_addr) == 1) {
        a6->sin6_family = AF_INET6;
        a6->sin6_port = htons((uint16_t)v->opt.port);
        flags |= MHD_USE_IPv6;
    } else {
        cli_eprintf("volux serve: --bind %s: expected an IPv4 or IPv6 address\n", v->opt.bind);
        slow_clients_stop(v->slow);
        v->slow = NULL;
        return 0;
    }
    v->daemon = MHD_start_daemon(flags, (uint16_t)v->opt.port, NULL, NULL, on_request, v, MHD_OPTION_EXTERNAL_LOGGER,
                                 on_log, v, MHD_OPTION_SOCK_ADDR, (struct sockaddr *)&addr, MHD_OPTION_CONNECTION_LIMIT,
                                 (unsigned)v->opt.max_connections, MHD_OPTION_CONNECTION_TIMEOUT,
                                 (unsigned)v->opt.timeout_s, MHD_OPTION_CONNECTION_MEMORY_LIMIT, (size_t)(64 * 1024),
                                 MHD_OPTION_NOTIFY_COMPLETED, on_completed, v, MHD_OPTION_NOTIFY_CONNECTION,
                                 on_connection, v, MHD_OPTION_END);
    if (!v->daemon) {
        cli_eprintf("volux serve: cannot listen on %s port %d (in use?)\n", v->opt.bind, v->opt.port);
        slow_clients_stop(v->slow);
        v->slow = NULL;
        return 0;
    }
    const union MHD_DaemonInfo *info = MHD_get_daemon_info(v->daemon, MHD_DAEMON_INFO_BIND_PORT);
    v->port = info ? info->port : v->opt.port;
    return 1;
}

void viewer_http_stop(viewer *v) {
    if (!v->daemon) return;
    /* Streams wait on frame_cv: wake them so their threads can end. */
    pthread_mutex_lock(&v->frame_lock);
    atomic_store(&v->quit, 1);
    pthread_cond_broadcast(&v->frame_cv);
    pthread_mutex_unlock(&v->frame_lock);
    MHD_stop_daemon(v->daemon);
    v->daemon = NULL;
    slow_clients_stop(v->slow);
    v->slow = NULL;
}
