/* io/cache_folder.c — see cache_folder.h. */
#include "cache_folder.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int volux_cache_file_path(const volux_context *ctx, const char *name, char *buf, size_t size) {
    const char *dir = volux_context_cache_dir(ctx);
    if (!dir[0]) return 0;
    int n = snprintf(buf, size, "%s/%s", dir, name);
    return n > 0 && (size_t)n < size;
}

static int make_dir(const char *path) { return mkdir(path, 0755) == 0 || errno == EEXIST; }

int volux_cache_folder_create(const volux_context *ctx) {
    char tmp[4200];
    const char *dir = volux_context_cache_dir(ctx);
    if (!dir[0]) return 0;
    int n = snprintf(tmp, sizeof tmp, "%s", dir);
    if (n < 0 || (size_t)n >= sizeof tmp) return 0;
    /* every prefix ending before a '/', then the folder itself; EEXIST for
     * a regular file is caught below, when the folder is checked */
    for (char *p = tmp + 1; *p; p++) {
        if (*p != '/') continue;
        *p = 0;
        int ok = make_dir(tmp);
        *p = '/';
        if (!ok) return 0;
    }
    struct stat sb;
    return make_dir(tmp) && stat(tmp, &sb) == 0 && S_ISDIR(sb.st_mode);
}

uint64_t volux_cache_folder_cap(void) {
    const char *env = getenv("VOLUX_CACHE_MB");
    uint64_t mb = VOLUX_CACHE_DEFAULT_MB;
    if (env && *env) {
        char *end;
        unsigned long long v = strtoull(env, &end, 10);
        if (!*end && v <= (1ull << 40)) mb = v;
    }
    return mb << 20;
}

static int own_entry(const char *name) {
    size_t n = strlen(name);
    return !strncmp(name, "ambient-", 8) && n > 13 && !strcmp(name + n - 5, ".vxat");
}

typedef struct entry {
    char name[256];
    uint64_t bytes;
    struct timespec used;
} entry;

static int older_first(const void *a, const void *b) {
    const entry *x = a, *y = b;
    if (x->used.tv_sec != y->used.tv_sec) return x->used.tv_sec < y->used.tv_sec ? -1 : 1;
    if (x->used.tv_nsec != y->used.tv_nsec) return x->used.tv_nsec < y->used.tv_nsec ? -1 : 1;
    return strcmp(x->name, y->name);
}

int volux_cache_folder_make_room(const volux_context *ctx, uint64_t incoming) {
    uint64_t cap = volux_cache_folder_cap();
    if (incoming > cap) return 0;
    const char *dir = volux_context_cache_dir(ctx);
    if (!dir[0]) return 0;
    DIR *d = opendir(dir);
    if (!d) return 1; /* no folder yet: nothing to evict */
    /* Plain malloc: this is bookkeeping, not data the context accounts. */
    entry *list = NULL;
    size_t n = 0, cap_n = 0;
    uint64_t total = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (!own_entry(e->d_name) || strlen(e->d_name) >= sizeof list->name) continue;
        struct stat sb;
        if (fstatat(dirfd(d), e->d_name, &sb, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(sb.st_mode)) continue;
        if (n == cap_n) {
            size_t grow = cap_n ? 2 * cap_n : 16;
            entry *bigger = realloc(list, grow * sizeof *list);
            if (!bigger) break;
            list = bigger;
            cap_n = grow;
        }
        snprintf(list[n].name, sizeof list[n].name, "%s", e->d_name);
        list[n].bytes = (uint64_t)sb.st_size;
        list[n].used = sb.st_mtim;
        total += list[n].bytes;
        n++;
    }
    if (n) qsort(list, n, sizeof *list, older_first);
    for (size_t i = 0; i < n && total + incoming > cap; i++)
        if (unlinkat(dirfd(d), list[i].name, 0) == 0) total -= list[i].bytes;
    closedir(d);
    free(list);
    return total + incoming <= cap;
}

void volux_cache_file_touch(const char *path) { utimensat(AT_FDCWD, path, NULL, 0); }
