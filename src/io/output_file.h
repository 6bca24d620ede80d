/*
 * io/output_file.h — how every output file is written: admitted, then
 * created unnamed and put in place whole.
 *
 * Admission (volux_file_check_output): the path is a regular file, a
 * symbolic link to a regular file in the same folder (the target is
 * replaced, the link kept), or does not exist yet in an existing,
 * writable folder. A device, FIFO, socket or folder is never replaced
 * (`-o /dev/stdout` once turned the device node into a regular file), and
 * a link is never followed out of its folder.
 *
 * Writing: the data goes to an unnamed file in the target's folder
 * (O_TMPFILE), so a process killed mid-write — even by SIGKILL — leaves
 * nothing behind; on commit the file is synced, linked under a temporary
 * name and renamed over the target (readers see the old or the new file,
 * never a part). Where the file system has no O_TMPFILE, a named
 * "PATH.tmp-XXXXXX" is used instead and registered, so that
 * volux_file_abandon_writes() (async-signal-safe) can remove it from a
 * signal handler.
 *
 * Internal to io; the public entry points are in volux/io.h.
 */
#ifndef VOLUX_IO_OUTPUT_FILE_H
#define VOLUX_IO_OUTPUT_FILE_H

#include <stdio.h>

#include "volux/io.h"

typedef struct volux_output_file {
    FILE *f;          /* write here                                         */
    char *target;     /* the file that will be replaced (link resolved)     */
    size_t target_size;
    char tmp[4200];   /* the named temporary ("" while unnamed)             */
    int slot;         /* registry slot of a named temporary, −1: none       */
} volux_output_file;

/* Admits `path` and opens the unnamed file; `what` names the output in
 * messages (e.g. the path itself). VOLUX_ERR_IO / VOLUX_ERR_WRITE. */
volux_status volux_output_begin(volux_context *ctx, const char *path, volux_output_file *out);
/* Flushes, syncs and puts the file in place; always releases `o`. */
volux_status volux_output_commit(volux_context *ctx, volux_output_file *o);
/* Drops the file (nothing is left); always releases `o`. */
void volux_output_abort(volux_context *ctx, volux_output_file *o);

#endif
