/*
 * io/file_open.c — regular files only (see file_open.h for why).
 */
#define _POSIX_C_SOURCE 200809L
#include "file_open.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/context_internal.h"

/* Not an errno value: the name is there but is no regular file. */
#define NOT_REGULAR (-1)

int volux_file_open_regular(const char *path, int *fd_out, uint64_t *size) {
    *fd_out = -1;
    int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
    if (fd < 0) return errno ? errno : EIO;
    struct stat sb;
    if (fstat(fd, &sb) != 0 || !S_ISREG(sb.st_mode)) {
        close(fd);
        return NOT_REGULAR;
    }
    int flags = fcntl(fd, F_GETFL);
    if (flags < 0 || fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) {
        int e = errno ? errno : EIO;
        close(fd);
        return e;
    }
    *fd_out = fd;
    if (size) *size = (uint64_t)sb.st_size;
    return 0;
}

const char *volux_file_open_why(int code) { return code == NOT_REGULAR ? "not a regular file" : strerror(code); }

volux_status volux_file_open_read_fd(volux_context *ctx, const char *path, int *fd, uint64_t *size) {
    int code = volux_file_open_regular(path, fd, size);
    if (code == NOT_REGULAR) return volux_error(ctx, VOLUX_ERR_IO, "%s: not a regular file", path);
    if (code) return volux_error(ctx, VOLUX_ERR_IO, "%s: cannot open: %s", path, strerror(code));
    return VOLUX_OK;
}

volux_status volux_file_open_read(volux_context *ctx, const char *path, FILE **out, uint64_t *size) {
    *out = NULL;
    int fd;
    volux_status st = volux_file_open_read_fd(ctx, path, &fd, size);
    if (st) return st;
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        int e = errno;
        close(fd);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: cannot open: %s", path, strerror(e));
    }
    *out = f;
    return VOLUX_OK;
}
