/*
 * volux/base.h — status codes, small value types and the context.
 *
 * The context is the root object: it owns the allocator, the thread count,
 * the memory cap for loaders, the progress/cancel callback, the cache folder
 * and the first error message since the caller last cleared it. Every other
 * object is created from one.
 *
 * DOES NOT: print, exit or abort on bad input. The library reports errors
 * through return codes and volux_context_error(); printing and exit codes
 * are the CLI's business.
 *
 * STEP BY STEP
 *     volux_context *ctx;
 *     if (volux_context_create(NULL, &ctx) != VOLUX_OK) return 1;
 *     volux_volume *vol;
 *     if (volux_volume_load(ctx, "engine.nhdr", NULL, &vol) != VOLUX_OK)
 *         fprintf(stderr, "%s\n", volux_context_error(ctx));
 *     ...
 *     volux_volume_release(vol);
 *     volux_context_destroy(ctx);
 */
#ifndef VOLUX_BASE_H
#define VOLUX_BASE_H

#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__)
#define VOLUX_API __attribute__((visibility("default")))
#define VOLUX_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define VOLUX_API
#define VOLUX_PRINTF(f, a)
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Every fallible public function returns one of these. The CLI maps
 * INVALID/IO/FORMAT/UNSUPPORTED/LIMIT (the user's input is at fault) to exit
 * status 2 and the others (the run failed) to exit status 1. */
typedef enum volux_status {
    VOLUX_OK = 0,
    VOLUX_ERR_INVALID,     /* bad parameter or scene value               */
    VOLUX_ERR_IO,          /* an input file is missing or unreadable     */
    VOLUX_ERR_FORMAT,      /* an input file is malformed                 */
    VOLUX_ERR_UNSUPPORTED, /* well-formed, but a feature we do not read  */
    VOLUX_ERR_LIMIT,       /* sizes exceed a documented limit / mem cap  */
    VOLUX_ERR_NOMEM,       /* allocation failed                          */
    VOLUX_ERR_WRITE,       /* an output file could not be written        */
    VOLUX_ERR_CANCELLED,   /* the progress callback asked to stop        */
    VOLUX_ERR_INTERNAL     /* a bug: broken invariant                    */
} volux_status;

/* Short stable name of a status ("invalid", "io", ...). Never NULL. */
VOLUX_API const char *volux_status_name(volux_status s);
/* "Did you mean": the entry of the NULL-terminated `candidates` closest to
 * a misspelt `name` (Levenshtein distance ≤ 2 for short names, about a
 * third of the length for long ones; a candidate that `name` begins, from
 * two letters on, counts as distance 1), NULL when none is close. The
 * library's own messages use the same rule; front ends use it for their
 * options. Returns one of `candidates`. */
VOLUX_API const char *volux_name_closest(const char *name, const char *const *candidates);
/* Copies `in` into out (cap bytes, NUL-terminated, cut at a whole
 * character) with control characters other than newline and tab, DEL and
 * bytes that are not valid UTF-8 written as \xHH. Every error and warning
 * message of the library has been through it; the CLI passes its own
 * messages (which quote command-line arguments) through it too. Returns
 * the length written. */
VOLUX_API size_t volux_escape_text(const char *in, char *out, size_t cap);

/* 1 if a status means "the input was bad" (CLI exit status 2). */
VOLUX_API int volux_status_is_input_error(volux_status s);

typedef struct volux_vec3 {
    float x, y, z;
} volux_vec3;

/* ------------------------------------------------------------------ */
/* Context                                                             */
/* ------------------------------------------------------------------ */

typedef struct volux_context volux_context;

/* Allocator in the style of lua_Alloc: (ptr=NULL,new>0) allocates,
 * (ptr,new=0) frees, otherwise reallocates. Must be thread-safe. */
typedef void *(*volux_alloc_fn)(void *user, void *ptr, size_t old_size, size_t new_size);

/* Progress report: task name, fraction done in [0,1]. Return nonzero to
 * cancel the running operation (it then fails with VOLUX_ERR_CANCELLED).
 * May be called from any thread, but never concurrently. */
typedef int (*volux_progress_fn)(void *user, const char *task, double fraction);

/* Messages for the user that are not errors: a warning (e.g. a light a
 * technique cannot use: the technique renders without it; a file's
 * trailing bytes ignored; non-finite values replaced as asked; a render
 * cut short by its time budget) or a note about long work (e.g. a table
 * that is built once and where it is kept). Escaped like error messages
 * (no control characters, valid UTF-8). One
 * line of text, without a trailing newline, naming its source
 * ("single: ..."). Called from the thread that runs the call that emits
 * it. The library never prints; without a callback messages are dropped. */
typedef enum volux_message_level { VOLUX_MESSAGE_NOTE, VOLUX_MESSAGE_WARNING } volux_message_level;
typedef void (*volux_message_fn)(void *user, volux_message_level level, const char *text);

typedef struct volux_context_desc {
    int threads;               /* worker threads; 0 = all cores             */
    uint64_t max_bytes;        /* cap on one volume/image allocation;
                                  0 = default (VOLUX_DEFAULT_MAX_BYTES)    */
    volux_alloc_fn alloc;      /* NULL = malloc/realloc/free                 */
    void *alloc_user;
    volux_progress_fn progress; /* NULL = silent                            */
    void *progress_user;
    const char *cache_dir;     /* NULL = default, "" = no disk cache; see
                                  volux_context_set_cache_dir (copied)      */
    volux_message_fn message;  /* NULL = messages dropped                   */
    void *message_user;
} volux_context_desc;

#define VOLUX_DEFAULT_MAX_BYTES (8ull << 30) /* 8 GiB */

/* Creates a context. desc may be NULL (defaults). Caller destroys. */
VOLUX_API volux_status volux_context_create(const volux_context_desc *desc, volux_context **out);
VOLUX_API void volux_context_destroy(volux_context *ctx);

/* The FIRST error recorded on this context since the caller last cleared
 * it ("" / VOLUX_OK if none): a failure that follows from an earlier one
 * never hides it (SQLite, VolPack). Safe to print: control characters,
 * DEL and bytes that are not UTF-8 (e.g. from a file name or header) are
 * written as \xHH. The library never clears it; call
 * volux_context_clear_error() before an operation whose own message you
 * want. The string is valid until the next volux call on the context. */
VOLUX_API const char *volux_context_error(const volux_context *ctx);
VOLUX_API volux_status volux_context_error_status(const volux_context *ctx);
VOLUX_API void volux_context_clear_error(volux_context *ctx);
/* Records an error the way the library does (ignored when an error is
 * already recorded: the first wins) and returns `status`. For callbacks
 * the library calls that report through the context (e.g. the validate
 * hook of volux_scene_doc_options). */
VOLUX_API volux_status volux_context_set_error(volux_context *ctx, volux_status status, const char *fmt, ...)
    VOLUX_PRINTF(3, 4);

VOLUX_API void volux_context_set_threads(volux_context *ctx, int threads);
/* Threads actually used (resolves 0 to the core count). */
VOLUX_API int volux_context_threads(const volux_context *ctx);
VOLUX_API void volux_context_set_progress(volux_context *ctx, volux_progress_fn fn, void *user);
VOLUX_API void volux_context_set_message(volux_context *ctx, volux_message_fn fn, void *user);
VOLUX_API uint64_t volux_context_max_bytes(const volux_context *ctx);
/* The memory budget of a render (docs/SCALE.md): before a technique
 * instance allocates anything, volux_technique_create estimates what the
 * render will hold (volume, base, technique caches, framebuffer and
 * resolved image at the scene's render size) and refuses with
 * VOLUX_ERR_LIMIT, naming the estimate and the limit, when it exceeds this
 * many bytes; volux_framebuffer_create checks what the context already
 * holds plus the framebuffer likewise. 0 selects the default, 80 % of
 * physical memory (volux_context_default_memory_limit); UINT64_MAX turns
 * the check off. Separate from max_bytes, the cap on one allocation. */
VOLUX_API void volux_context_set_memory_limit(volux_context *ctx, uint64_t bytes);
/* The limit in force (the default resolved). */
VOLUX_API uint64_t volux_context_memory_limit(const volux_context *ctx);
/* 80 % of this machine's physical memory (UINT64_MAX if unknown). */
VOLUX_API uint64_t volux_context_default_memory_limit(void);
/* Out of core (docs/SCALE.md): with `on`, volume files loaded through this
 * context whose data is stored as the volume stores it (uncompressed raw,
 * NRRD, NIfTI or MetaImage data in native byte order, uint8/uint16/float32,
 * in one file, aligned to its element size) are memory-mapped read-only
 * instead of read, and the bricked copy techniques build of such a volume
 * is a temporary file ($TMPDIR, else /var/tmp) mapped shared: the kernel
 * pages both in and out, so a volume larger than memory renders. Neither
 * counts against the memory limit. Other files are read as usual, with a
 * warning naming why. Off by default. */
VOLUX_API void volux_context_set_out_of_core(volux_context *ctx, int on);
VOLUX_API int volux_context_out_of_core(const volux_context *ctx);
/* Bytes currently allocated through the context (for memory reports); the
 * context's own storage (itself, its cache folder name) is not counted. */
VOLUX_API uint64_t volux_context_bytes_in_use(const volux_context *ctx);

/* The folder where techniques keep data that is expensive to build and
 * independent of any scene (today: the ambient preintegration table,
 * docs/techniques/ambient.md). NULL selects the default, read from the
 * environment when this is called (for volux_context_create: once, at
 * creation): $XDG_CACHE_HOME/volux if XDG_CACHE_HOME is set and non-empty,
 * else $HOME/.cache/volux, else none. "" turns the disk cache off: such data
 * is then built in memory by every technique instance that needs it. The
 * folder is created when first written; one that cannot be written only
 * means the data is not kept. The string is copied through the context's
 * allocator; VOLUX_ERR_NOMEM leaves the previous folder in place. */
VOLUX_API volux_status volux_context_set_cache_dir(volux_context *ctx, const char *dir);
/* The cache folder in use; "" if none. Valid until the next set. */
VOLUX_API const char *volux_context_cache_dir(const volux_context *ctx);

#ifdef __cplusplus
}
#endif
#endif
