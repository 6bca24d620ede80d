/*
 * core/volume_map.c — out-of-core storage (docs/SCALE.md, "Out of core").
 *
 * A volume whose file holds its values exactly as they are stored (raw,
 * native byte order, uint8/uint16/float32) is mapped read-only instead of
 * read: its pages are clean file pages that the kernel may drop and fetch
 * again at any time, so a volume larger than memory renders, and the
 * kernel's page cache is the brick cache (its LRU decides what stays). The
 * bricked copy of such a volume lives in an unlinked temporary file mapped
 * shared, so it too is pageable rather than anonymous memory.
 *
 * Passes that sweep the whole volume (value range, macrocells, the bricked
 * copy) drop the pages behind them with madvise(MADV_DONTNEED): dropping
 * clean or shared file pages loses nothing (they are read again from the
 * page cache or the file on the next touch), and it keeps the process's
 * resident set at the pass's window instead of the file's size.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "volume_internal.h"

static size_t page_size(void) {
    long p = sysconf(_SC_PAGESIZE);
    return p > 0 ? (size_t)p : 4096;
}

volux_status volux_volume_map_file(volux_context *ctx, const char *name, int fd, uint64_t offset, const int dims[3],
                                   const double spacing[3], volux_scalar_type type, volux_volume **out) {
    volux_volume *v;
    /* borrowed: not allocated, so neither the cap on one allocation nor
     * the context's budget applies to the data */
    volux_status st = volux_volume_create_borrowed(ctx, dims, spacing, type, &v);
    if (st) return st;
    size_t page = page_size(), lead = (size_t)(offset % page);
    size_t len = v->data_bytes + lead;
    void *base = mmap(NULL, len, PROT_READ, MAP_PRIVATE, fd, (off_t)(offset - lead));
    if (base == MAP_FAILED) {
        int e = errno;
        volux_volume_release(v);
        return volux_error(ctx, VOLUX_ERR_IO, "%s: out of core: cannot map %zu bytes of data: %s", name, len,
                           strerror(e));
    }
    /* The sweeps read forward; rays do not, so no read-ahead hint beyond
     * the kernel's default. */
    v->data = (unsigned char *)base + lead;
    v->mapped = 1;
    v->map_base = base;
    v->map_len = len;
    *out = v;
    return VOLUX_OK;
}

void volux_volume_unmap(volux_volume *v) {
    if (v->map_base) munmap(v->map_base, v->map_len);
    v->map_base = NULL;
}

void volux_map_trim(const void *p, size_t bytes) {
    size_t page = page_size();
    uintptr_t a = (uintptr_t)p, lo = (a + page - 1) / page * page, hi = (a + bytes) / page * page;
    /* whole pages inside [p, p + bytes) only: the neighbours' pages may be
     * in use by another sweep's window */
    if (hi > lo) madvise((void *)lo, hi - lo, MADV_DONTNEED);
}

void volux_volume_trim(const volux_volume *v, size_t first_byte, size_t bytes) {
    if (!v->mapped) return;
    if (first_byte >= v->data_bytes) return;
    if (bytes > v->data_bytes - first_byte) bytes = v->data_bytes - first_byte;
    volux_map_trim((const unsigned char *)v->data + first_byte, bytes);
}

/* An unlinked file in $TMPDIR (else /var/tmp, which is disk rather than a
 * tmpfs on common systems), sized and mapped shared. */
void *volux_map_scratch(volux_context *ctx, size_t bytes) {
    const char *dir = getenv("TMPDIR");
    if (!dir || !*dir) dir = "/var/tmp";
    char path[4096];
    if (snprintf(path, sizeof path, "%s/volux-bricks-XXXXXX", dir) >= (int)sizeof path) {
        volux_error(ctx, VOLUX_ERR_IO, "out of core: the temporary folder name is too long");
        return NULL;
    }
    int fd = mkstemp(path);
    if (fd < 0) {
        volux_error(ctx, VOLUX_ERR_IO, "out of core: cannot create a file for the bricked copy in %s: %s", dir,
                    strerror(errno));
        return NULL;
    }
    unlink(path); /* gone with the mapping, whatever ends the process */
    void *p = MAP_FAILED;
    int e = 0;
    /* blocks reserved now: a full disk is this error, not a SIGBUS when
     * the build writes a page the file system cannot place */
    if ((e = posix_fallocate(fd, 0, (off_t)bytes)) != 0) {
    } else if ((p = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0)) == MAP_FAILED) e = errno;
    close(fd);
    if (p == MAP_FAILED) {
        volux_error(ctx, VOLUX_ERR_IO, "out of core: cannot map %zu bytes for the bricked copy in %s: %s", bytes, dir,
                    strerror(e));
        return NULL;
    }
    return p;
}

void volux_unmap_scratch(void *p, size_t bytes) {
    if (p) munmap(p, bytes);
}
