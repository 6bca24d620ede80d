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
#include <stdint.h>

#include "volux/base.h"

/* Writes "<cache folder>/<name>" into buf. 0 if the disk cache is off ("")
 * or the path does not fit. */
int volux_cache_file_path(const volux_context *ctx, const char *name, char *buf, size_t size);

/* Creates the cache folder and any missing parents (mkdir -p). 1 if it
 * exists afterwards; 0 if the disk cache is off or it cannot be made. */
int volux_cache_folder_create(const volux_context *ctx);

/* The folder is capped: VOLUX_CACHE_MB in the environment (default
 * VOLUX_CACHE_DEFAULT_MB; 0 = no disk cache writes). Only volux's own
 * entries (names starting "ambient-" and ending ".vxat") count and are
 * ever removed; other files in a shared folder are left alone. */
#define VOLUX_CACHE_DEFAULT_MB 1024
uint64_t volux_cache_folder_cap(void);
/* Makes room for an entry of `incoming` bytes by removing the least
 * recently used entries (oldest modification time: a hit refreshes it).
 * 1 if the entry then fits under the cap, 0 if it cannot. */
int volux_cache_folder_make_room(const volux_context *ctx, uint64_t incoming);
/* Marks an entry as just used (a cache hit), for the LRU order. */
void volux_cache_file_touch(const char *path);

#endif
