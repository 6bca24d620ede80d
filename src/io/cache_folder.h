/*
 * io/cache_folder.h — files in the context's cache folder
 * (volux_context_cache_dir): data that is expensive to build, independent of
 * any scene, and safe to lose.
 *
 * Nothing here records an error on the context: a cache that cannot be
 * used is never the caller's problem, only a reason to build in memory.
 */
#ifndef VOLUX_IO_CACHE_FOLDER_H
#define VOLUX_IO_CACHE_FOLDER_H

#include <stddef.h>

#include "volux/base.h"

/* Writes "<cache folder>/<name>" into buf. 0 if the disk cache is off ("")
 * or the path does not fit. */
int volux_cache_file_path(const volux_context *ctx, const char *name, char *buf, size_t size);

/* Creates the cache folder and any missing parents (mkdir -p). 1 if it
 * exists afterwards; 0 if the disk cache is off or it cannot be made. */
int volux_cache_folder_create(const volux_context *ctx);

#endif
