/*
 * io/file_open.h — how every reader in io opens a file it was given a name
 * for: regular files only, checked on the open descriptor.
 *
 * A name from a scene or a viewer edit may be a FIFO, a device or a
 * directory: fopen() of a FIFO blocks until a writer appears (a server
 * thread holding the scene lock would hang), /dev/zero never ends. The
 * open below uses O_NONBLOCK so a FIFO returns at once, fstat()s the
 * descriptor (no window between a check and the open), refuses anything
 * but a regular file, then restores blocking reads.
 *
 * Internal to io (and the tools that read files themselves).
 */
#ifndef VOLUX_IO_FILE_OPEN_H
#define VOLUX_IO_FILE_OPEN_H

#include <stdint.h>
#include <stdio.h>

#include "volux/base.h"

/* Without a context (cache reads record no error): 0 and the descriptor
 * in *fd (O_RDONLY | O_CLOEXEC, the caller closes it), or a code that
 * volux_file_open_why() turns into text ("not a regular file" or the
 * errno's). */
int volux_file_open_regular(const char *path, int *fd, uint64_t *size);
const char *volux_file_open_why(int code);

/* Opens `path` for binary reading into *out (the caller fcloses it) and
 * its size into *size (may be NULL). Errors on ctx, naming `path`:
 * VOLUX_ERR_IO "cannot open: <reason>" or "not a regular file". */
volux_status volux_file_open_read(volux_context *ctx, const char *path, FILE **out, uint64_t *size);

/* The same as a descriptor (O_RDONLY | O_CLOEXEC; the caller closes it). */
volux_status volux_file_open_read_fd(volux_context *ctx, const char *path, int *fd, uint64_t *size);

#endif
