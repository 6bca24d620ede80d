/*
 * io/output_file.c — output admission and whole-file writes (see
 * output_file.h for the rules and why).
 */
#define _GNU_SOURCE /* O_TMPFILE, linkat's AT_SYMLINK_FOLLOW */
#include "output_file.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "core/context_internal.h"

/* ---- the registry of named temporaries (for a signal handler) ---- */

#define MAX_LIVE 16
static char live_name[MAX_LIVE][4200];
static volatile sig_atomic_t live_used[MAX_LIVE];
static int live_claim[MAX_LIVE];

static int registry_add(const char *name) {
    for (int i = 0; i < MAX_LIVE; i++) {
        int expected = 0;
        if (__atomic_compare_exchange_n(&live_claim[i], &expected, 1, 0, __ATOMIC_ACQ_REL, __ATOMIC_RELAXED)) {
            snprintf(live_name[i], sizeof live_name[i], "%s", name);
            __atomic_thread_fence(__ATOMIC_RELEASE);
            live_used[i] = 1;
            return i;
        }
    }
    return -1; /* more than MAX_LIVE writes at once: this one is not covered */
}

static void registry_remove(int slot) {
    if (slot < 0) return;
    live_used[slot] = 0;
    __atomic_store_n(&live_claim[slot], 0, __ATOMIC_RELEASE);
}

void volux_file_abandon_writes(void) {
    /* unlink() is async-signal-safe; a name is complete before its flag is set. */
    for (int i = 0; i < MAX_LIVE; i++)
        if (live_used[i]) unlink(live_name[i]);
}

/* ---- admission ---- */

static void dir_of(const char *path, char *out, size_t n) {
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(out, n, ".");
    else if (slash == path) snprintf(out, n, "/");
    else snprintf(out, n, "%.*s", (int)(slash - path), path);
}

static volux_status check_folder(volux_context *ctx, const char *path, const char *file, volux_status fail) {
    char dir[PATH_MAX];
    if (strlen(file) >= sizeof dir) return volux_error(ctx, fail, "cannot write '%s': path too long", path);
    dir_of(file, dir, sizeof dir);
    struct stat sb;
    if (stat(dir, &sb) != 0)
        return volux_error(ctx, fail, "cannot write '%s': folder '%s': %s", path, dir, strerror(errno));
    if (!S_ISDIR(sb.st_mode))
        return volux_error(ctx, fail, "cannot write '%s': '%s' is not a folder", path, dir);
    /* The file is created beside the target: the folder needs write and
     * search permission. */
    if (access(dir, W_OK | X_OK) != 0)
        return volux_error(ctx, fail, "cannot write '%s': folder '%s': %s", path, dir, strerror(errno));
    return VOLUX_OK;
}

/* Admits `path`; the file to replace goes to *target (allocated through
 * ctx, *target_size bytes) when target is not NULL. Refusals are `fail`:
 * VOLUX_ERR_IO for a check before any work, VOLUX_ERR_WRITE when writing. */
static volux_status admit(volux_context *ctx, const char *path, char **target, size_t *target_size,
                          volux_status fail) {
    if (!path || !*path) return volux_error(ctx, VOLUX_ERR_INVALID, "empty output file name");
    char resolved[PATH_MAX];
    const char *file = path;
    struct stat sb;
    if (lstat(path, &sb) == 0) {
        if (S_ISLNK(sb.st_mode)) {
            char link_dir[PATH_MAX], real_dir[PATH_MAX], target_dir[PATH_MAX];
            if (!realpath(path, resolved))
                return volux_error(ctx, fail, "cannot write '%s': a symbolic link whose target is missing",
                                   path);
            dir_of(path, link_dir, sizeof link_dir);
            dir_of(resolved, target_dir, sizeof target_dir);
            if (!realpath(link_dir, real_dir) || strcmp(real_dir, target_dir) != 0)
                return volux_error(ctx, fail,
                                   "cannot write '%s': a symbolic link out of its folder (to '%s'); volux follows "
                                   "links only within the output's folder",
                                   path, resolved);
            if (stat(resolved, &sb) != 0)
                return volux_error(ctx, fail, "cannot write '%s': %s", path, strerror(errno));
            file = resolved;
        }
        if (S_ISDIR(sb.st_mode)) return volux_error(ctx, fail, "cannot write '%s': it is a folder", path);
        if (!S_ISREG(sb.st_mode))
            return volux_error(ctx, fail,
                               "cannot write '%s': it exists and is not a regular file (a device, pipe or socket); "
                               "volux writes and replaces regular files only",
                               path);
    } else if (errno != ENOENT) {
        return volux_error(ctx, fail, "cannot write '%s': %s", path, strerror(errno));
    }
    volux_status st = check_folder(ctx, path, file, fail);
    if (st || !target) return st;
    *target_size = strlen(file) + 1;
    *target = volux_alloc_or_error(ctx, *target_size, "an output file name");
    if (!*target) return VOLUX_ERR_NOMEM;
    memcpy(*target, file, *target_size);
    return VOLUX_OK;
}

volux_status volux_file_check_output(volux_context *ctx, const char *path) {
    return admit(ctx, path, NULL, NULL, VOLUX_ERR_IO);
}

/* ---- writing ---- */

/* "PATH.tmp-XXXXXX" created exclusively (or, with fd == NULL, only a free
 * name for linkat), with the umask applied as for any new file. The suffix
 * mixes time, pid and a counter through splitmix64. */
static int temp_name(char *tmp, size_t tmp_size, const char *path, int create) {
    static const char alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";
    static unsigned counter;
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    uint64_t seed = (uint64_t)ts.tv_nsec ^ ((uint64_t)ts.tv_sec << 30) ^ ((uint64_t)getpid() << 16);
    uint64_t z = seed + 0x9e3779b97f4a7c15ull * (uint64_t)(__atomic_add_fetch(&counter, 1, __ATOMIC_RELAXED));
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    char suffix[7];
    for (int i = 0; i < 6; i++, z /= 62) suffix[i] = alphabet[z % 62];
    suffix[6] = 0;
    if (snprintf(tmp, tmp_size, "%s.tmp-%s", path, suffix) >= (int)tmp_size) {
        errno = ENAMETOOLONG;
        return -1;
    }
    return create ? open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666) : 0;
}

volux_status volux_output_begin(volux_context *ctx, const char *path, volux_output_file *out) {
    memset(out, 0, sizeof *out);
    out->slot = -1;
    volux_status st = admit(ctx, path, &out->target, &out->target_size, VOLUX_ERR_WRITE);
    if (st) return st;
    int fd = -1;
#ifdef O_TMPFILE
    /* Unnamed until commit; linkat needs /proc/self/fd to give it a name. */
    if (access("/proc/self/fd", X_OK) == 0) {
        char dir[PATH_MAX];
        dir_of(out->target, dir, sizeof dir);
        fd = open(dir, O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
    }
#endif
    if (fd < 0) {
        for (int attempt = 0; attempt < 64 && fd < 0; attempt++) {
            fd = temp_name(out->tmp, sizeof out->tmp, out->target, 1);
            if (fd < 0 && errno != EEXIST) break;
        }
        if (fd >= 0) out->slot = registry_add(out->tmp);
        else out->tmp[0] = 0;
    }
    if (fd >= 0 && !(out->f = fdopen(fd, "wb"))) {
        close(fd);
        fd = -1;
    }
    if (fd < 0) {
        int e = errno;
        if (out->tmp[0]) unlink(out->tmp);
        volux_output_abort(ctx, out);
        return volux_error(ctx, VOLUX_ERR_WRITE, "cannot write '%s': %s", path, strerror(e));
    }
    return VOLUX_OK;
}

static void release(volux_context *ctx, volux_output_file *o) {
    if (o->f) fclose(o->f);
    o->f = NULL;
    registry_remove(o->slot);
    o->slot = -1;
    if (o->target) volux_free(ctx, o->target, o->target_size);
    o->target = NULL;
}

void volux_output_abort(volux_context *ctx, volux_output_file *o) {
    if (o->tmp[0]) unlink(o->tmp);
    o->tmp[0] = 0;
    release(ctx, o); /* an unnamed file vanishes with its descriptor */
}

volux_status volux_output_commit(volux_context *ctx, volux_output_file *o) {
    int e = 0;
    /* Synced before it gets the name, so the name never points at data
     * still only in a cache that a crash could lose. */
    if (fflush(o->f) != 0 || fsync(fileno(o->f)) != 0) e = errno;
    if (!e && !o->tmp[0]) {
        char proc[64];
        snprintf(proc, sizeof proc, "/proc/self/fd/%d", fileno(o->f));
        for (int attempt = 0; attempt < 64; attempt++) {
            if (temp_name(o->tmp, sizeof o->tmp, o->target, 0) != 0) break;
            o->slot = registry_add(o->tmp);
            if (linkat(AT_FDCWD, proc, AT_FDCWD, o->tmp, AT_SYMLINK_FOLLOW) == 0) break;
            int le = errno;
            registry_remove(o->slot);
            o->slot = -1;
            o->tmp[0] = 0;
            if (le != EEXIST) {
                e = le;
                break;
            }
        }
        if (!e && !o->tmp[0]) e = EEXIST;
    }
    if (fclose(o->f) != 0 && !e) e = errno;
    o->f = NULL;
    if (!e && rename(o->tmp, o->target) != 0) e = errno;
    if (!e) o->tmp[0] = 0; /* in place: nothing to remove */
    const char *name = o->target;
    volux_status st = e ? volux_error(ctx, VOLUX_ERR_WRITE, "cannot write '%s': %s", name, strerror(e)) : VOLUX_OK;
    volux_output_abort(ctx, o);
    return st;
}

volux_status volux_file_save(volux_context *ctx, const char *path, const void *bytes, size_t n) {
    volux_output_file o;
    volux_status st = volux_output_begin(ctx, path, &o);
    if (st) return st;
    if (n && fwrite(bytes, 1, n, o.f) != n) {
        int e = errno;
        volux_output_abort(ctx, &o);
        return volux_error(ctx, VOLUX_ERR_WRITE, "cannot write '%s': %s", path, strerror(e));
    }
    return volux_output_commit(ctx, &o);
}
