/* core/sequence.c — see volux/sequence.h. */
#include <string.h>

#include "context_internal.h"
#include "volume_internal.h"
#include "volux/sequence.h"

/* Cache entries beyond which the least recently used step is dropped even
 * when memory would allow more (keeps the lookups linear and the table
 * fixed-size, so acquiring a cached step never allocates). */
#define MAX_ENTRIES 64

typedef struct entry {
    int step;          /* −1: free                                           */
    volux_volume *vol; /* one reference held by the cache                    */
    uint64_t bytes;
    uint64_t used;     /* LRU clock value of the last acquire                */
} entry;

static uint64_t next_sequence_id = 1;

struct volux_sequence {
    volux_context *ctx;
    uint64_t id;
    int steps;
    volux_step_load_fn load;
    void *user;
    void (*release_user)(volux_context *ctx, void *user);
    char *name;
    uint64_t limit, cached, clock, loads;
    /* The shape every step must have: the first step loaded. */
    int have_shape, shape_step;
    int dims[3];
    volux_scalar_type type;
    double spacing[3];
    volux_vec3 origin;
    entry entries[MAX_ENTRIES];
};

volux_status volux_sequence_create(volux_context *ctx, const volux_sequence_desc *d, volux_sequence **out) {
    if (!d || !d->load) return volux_error(ctx, VOLUX_ERR_INVALID, "sequence: no loader");
    if (d->steps < 1 || d->steps > VOLUX_MAX_STEPS)
        return volux_error(ctx, VOLUX_ERR_INVALID, "sequence: %d time steps is outside [1, %d]", d->steps,
                           VOLUX_MAX_STEPS);
    volux_sequence *q = volux_calloc(ctx, 1, sizeof *q);
    if (!q) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a volume sequence");
    q->name = volux_strdup(ctx, d->name ? d->name : "sequence");
    if (!q->name) {
        volux_free(ctx, q, sizeof *q);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a volume sequence");
    }
    q->ctx = ctx;
    q->id = __atomic_fetch_add(&next_sequence_id, 1, __ATOMIC_RELAXED);
    q->steps = d->steps;
    q->load = d->load;
    q->user = d->user;
    q->release_user = d->release_user;
    q->limit = d->cache_bytes ? d->cache_bytes : VOLUX_SEQUENCE_CACHE_DEFAULT;
    for (int i = 0; i < MAX_ENTRIES; i++) q->entries[i].step = -1;
    *out = q;
    return VOLUX_OK;
}

static void drop(volux_sequence *q, entry *e) {
    volux_volume_release(e->vol);
    q->cached -= e->bytes;
    e->step = -1;
    e->vol = NULL;
    e->bytes = 0;
}

void volux_sequence_destroy(volux_sequence *q) {
    if (!q) return;
    volux_context *ctx = q->ctx;
    for (int i = 0; i < MAX_ENTRIES; i++)
        if (q->entries[i].step >= 0) drop(q, &q->entries[i]);
    if (q->release_user) q->release_user(ctx, q->user);
    volux_strfree(ctx, q->name);
    volux_free(ctx, q, sizeof *q);
}

int volux_sequence_steps(const volux_sequence *q) { return q->steps; }
uint64_t volux_sequence_id(const volux_sequence *q) { return q->id; }
const char *volux_sequence_name(const volux_sequence *q) { return q->name; }
uint64_t volux_sequence_cached_bytes(const volux_sequence *q) { return q->cached; }
uint64_t volux_sequence_loads(const volux_sequence *q) { return q->loads; }

/* Drops least recently used steps until `extra` more bytes fit under the
 * limit and a table slot is free (keeping `keep`, if any). */
static void make_room(volux_sequence *q, uint64_t extra, const entry *keep) {
    for (;;) {
        int free_slot = 0;
        entry *lru = NULL;
        for (int i = 0; i < MAX_ENTRIES; i++) {
            entry *e = &q->entries[i];
            if (e->step < 0) {
                free_slot = 1;
                continue;
            }
            if (e != keep && (!lru || e->used < lru->used)) lru = e;
        }
        if (free_slot && q->cached + extra <= q->limit) return;
        if (!lru) return;
        drop(q, lru);
    }
}

void volux_sequence_set_cache_limit(volux_sequence *q, uint64_t bytes) {
    q->limit = bytes ? bytes : VOLUX_SEQUENCE_CACHE_DEFAULT;
    make_room(q, 0, NULL);
}

static volux_status check_shape(volux_sequence *q, int step, const volux_volume *v) {
    if (!q->have_shape) {
        q->have_shape = 1;
        q->shape_step = step;
        memcpy(q->dims, v->dims, sizeof q->dims);
        memcpy(q->spacing, v->spacing, sizeof q->spacing);
        q->type = v->type;
        q->origin = v->origin;
        return VOLUX_OK;
    }
    const char *what = NULL;
    if (memcmp(q->dims, v->dims, sizeof q->dims) != 0) what = "dims";
    else if (q->type != v->type) what = "scalar type";
    else if (memcmp(q->spacing, v->spacing, sizeof q->spacing) != 0) what = "spacing";
    else if (memcmp(&q->origin, &v->origin, sizeof q->origin) != 0) what = "origin";
    if (!what) return VOLUX_OK;
    return volux_error(q->ctx, VOLUX_ERR_FORMAT,
                       "%s: time step %d is %dx%dx%d %s (spacing %g %g %g), but step %d is %dx%dx%d %s "
                       "(spacing %g %g %g): every step must have the same dims, type, spacing and origin (%s differ)",
                       q->name, step, v->dims[0], v->dims[1], v->dims[2], volux_scalar_type_name(v->type),
                       v->spacing[0], v->spacing[1], v->spacing[2], q->shape_step, q->dims[0], q->dims[1], q->dims[2],
                       volux_scalar_type_name(q->type), q->spacing[0], q->spacing[1], q->spacing[2], what);
}

volux_status volux_sequence_acquire(volux_sequence *q, int step, volux_volume **out) {
    if (step < 0 || step >= q->steps)
        return volux_error(q->ctx, VOLUX_ERR_INVALID, "%s: time step %d is outside [0, %d)", q->name, step, q->steps);
    q->clock++;
    for (int i = 0; i < MAX_ENTRIES; i++) {
        entry *e = &q->entries[i];
        if (e->step == step) {
            e->used = q->clock;
            volux_volume_retain(e->vol);
            *out = e->vol;
            return VOLUX_OK;
        }
    }
    volux_volume *v = NULL;
    volux_status st = q->load(q->user, q->ctx, step, &v);
    if (st) return st;
    q->loads++;
    if ((st = check_shape(q, step, v))) {
        volux_volume_release(v);
        return st;
    }
    uint64_t bytes = volux_volume_memory_bytes(v);
    if (bytes <= q->limit) {
        make_room(q, bytes, NULL);
        for (int i = 0; i < MAX_ENTRIES; i++) {
            entry *e = &q->entries[i];
            if (e->step >= 0) continue;
            e->step = step;
            e->vol = v;
            e->bytes = bytes;
            e->used = q->clock;
            q->cached += bytes;
            volux_volume_retain(v);
            break;
        }
    }
    *out = v;
    return VOLUX_OK;
}
