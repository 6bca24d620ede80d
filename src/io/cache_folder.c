/* io/cache_folder.c — see cache_folder.h. */
#include "cache_folder.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

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
