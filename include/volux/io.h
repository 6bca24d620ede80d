/*
 * volux/io.h — files ⇄ core objects.
 *
 * Volumes: NRRD (.nrrd attached, .nhdr detached; raw and gzip encodings;
 * slice stacks by LIST or pattern), MetaImage (.mhd/.mha), NIfTI-1 and
 * NIfTI-2 (.nii, .nii.gz, .hdr/.img), VTK XML ImageData (.vti), raw with
 * an explicit description, and procedural volumes by name. Every reader validates the
 * header with checked arithmetic against the bytes actually present, and
 * against the context's max_bytes, before it allocates.
 *
 * Images: PNG (tone-mapped 8-bit sRGB on write), PFM and OpenEXR (linear
 * float), Radiance .hdr (read).
 *
 * Scenes: the JSON format of DESIGN §3, with --set style overrides.
 *
 * DOES NOT: keep any file open after a call returns.
 */
#ifndef VOLUX_IO_H
#define VOLUX_IO_H

#include "base.h"
#include "image.h"
#include "scene.h"
#include "sequence.h"
#include "transfer.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A raw file's layout (all fields required unless noted). */
typedef struct volux_raw_desc {
    int dims[3];
    volux_scalar_type type;
    int big_endian;
    double spacing[3];     /* 0 = 1.0                                      */
    uint64_t byte_skip;    /* bytes to skip at the start                   */
} volux_raw_desc;

/* One brick of a volume (data-parallel rendering, docs/DISTRIBUTED.md):
 * brick `index` of the k-d split of the file's grid into `count` bricks
 * (volux_brick_split), with `ghost` node layers around its owned box. */
typedef struct volux_volume_region {
    int count;  /* ≥ 1                                                     */
    int index;  /* [0, count)                                              */
    int ghost;  /* 0 = VOLUX_BRICK_GHOST; enough for trilinear samples,
                   central-difference gradients and a pre-integration front
                   sample up to one voxel outside the owned box             */
} volux_volume_region;
#define VOLUX_BRICK_GHOST 2

typedef struct volux_volume_load_options {
    const volux_raw_desc *raw; /* non-NULL: read `path` as raw with this  */
    int use_file_origin;       /* 1: origin from the header, else centred  */
    int allow_outside_dir;     /* 1: detached data may lie outside the
                                  header's folder (else a data file must
                                  resolve inside it, symbolic links
                                  followed)                                 */
    const char *data_root;     /* non-NULL: detached data must also lie in
                                  this folder once symbolic links are
                                  resolved (absolute, symlink-free name)   */
    int allow_nonfinite;       /* 1: NaN/Inf values become the lowest
                                  value, with a warning; 0: they are
                                  VOLUX_ERR_FORMAT (count, first voxel)     */
    /* non-NULL: load only this brick (borrowed for the call). The volume
     * holds the brick's nodes plus ghosts, placed where they lie in the
     * whole volume (the whole's origin: the file's or centred), and
     * volux_volume_brick describes it. Raw data is read row by row
     * (seeking past the rest); gzip/zlib data is decoded as a stream and
     * the bytes outside the brick are dropped as they pass, up to the
     * brick's last row (the rest of the stream is not read, so a size
     * mismatch after it goes unnoticed). The brick's bytes count against
     * the context's max_bytes; the whole grid may be up to count × that.
     * Not for sequences. */
    const volux_volume_region *region;
} volux_volume_load_options;

/* The file-name extensions volux_volume_load recognises by themselves (raw
 * files, ".raw", need a description), as one string for help texts and
 * messages. DICOM (.dcm, a file with the PS3.10 "DICM" prefix, or a folder
 * of a series) needs a build with GDCM (without it, loading one says so). */
#define VOLUX_VOLUME_EXTENSIONS ".nrrd .nhdr .mhd .mha .nii .nii.gz .hdr .vti .dcm or a DICOM folder"

/* 1 if path ends (case-insensitively) in one of VOLUX_VOLUME_EXTENSIONS,
 * or is a folder, or a file that starts like DICOM (PS3.10 prefix). */
VOLUX_API int volux_volume_path_is_known(const char *path);

/* Loads a volume file, choosing the reader by extension (VOLUX_VOLUME_EXTENSIONS,
 * or .raw with a description; otherwise by the first bytes). options may be NULL. Errors name the file and
 * the problem; VOLUX_ERR_IO when missing/unreadable, VOLUX_ERR_FORMAT when
 * malformed, VOLUX_ERR_UNSUPPORTED, VOLUX_ERR_LIMIT. Caller releases. */
VOLUX_API volux_status volux_volume_load(volux_context *ctx, const char *path,
                                         const volux_volume_load_options *options, volux_volume **out);

/* Procedural volumes: "sphere", "marschner_lobb", "cloud", "phantom",
 * "constant" (all 1.0 — a homogeneous box). uint8 except "constant"
 * (float32). Spacing 1. */
VOLUX_API volux_status volux_volume_procedural(volux_context *ctx, const char *name, const int dims[3],
                                               uint64_t seed, volux_volume **out);
/* One brick of a procedural volume (see volux_volume_region): the nodes
 * the whole volume would have there, computed for the brick only. */
VOLUX_API volux_status volux_volume_procedural_region(volux_context *ctx, const char *name, const int dims[3],
                                                      uint64_t seed, const volux_volume_region *region,
                                                      volux_volume **out);
/* Comma-separated list of procedural names (for messages). */
VOLUX_API const char *volux_procedural_names(void);
/* The procedural volume at a time: only "cloud" is animated (its puffs
 * drift and change shape smoothly with `time`; time 0 is the static cloud);
 * a nonzero time for another volume is VOLUX_ERR_INVALID. */
VOLUX_API volux_status volux_volume_procedural_at(volux_context *ctx, const char *name, const int dims[3],
                                                  uint64_t seed, double time, volux_volume **out);
/* 1 if the named procedural volume changes with time. */
VOLUX_API int volux_procedural_is_animated(const char *name);

/* Time-varying volumes (volux/sequence.h). Each returns a sequence whose
 * steps load on demand (caller destroys, or a scene keeps it);
 * cache_bytes bounds the cached steps (0 = default).
 *   files:      one volume file per step (options apply to every file).
 *               Every file's header is read now: a missing file, or a
 *               frame whose dims, type or spacing differ from the first,
 *               is an error naming both (VOLUX_ERR_FORMAT for a mismatch).
 *   pattern:    the files pattern % i for i = first, first + stride, ...,
 *               ≤ last; the pattern holds exactly one %d, %Nd or %0Nd
 *               (and "%%" for a literal %), e.g. "frames/t%03d.nhdr".
 *   procedural: the animated procedural `name` (only "cloud") at times
 *               time0 + i·time_per_step, i ∈ [0, steps). */
VOLUX_API volux_status volux_sequence_load_files(volux_context *ctx, const char *const *paths, int n,
                                                 const volux_volume_load_options *options, uint64_t cache_bytes,
                                                 volux_sequence **out);
VOLUX_API volux_status volux_sequence_load_pattern(volux_context *ctx, const char *pattern, int first, int last,
                                                   int stride, const volux_volume_load_options *options,
                                                   uint64_t cache_bytes, volux_sequence **out);
/* How many step-number conversions (%d, %Nd, %0Nd with N ≤ 9) `pattern`
 * holds — volux_sequence_load_pattern needs exactly 1 — or −1 when it
 * holds any other '%' than those and "%%" (such a name must never reach
 * printf). Also for numbered output names (`volux render --all-steps`). */
VOLUX_API int volux_sequence_pattern_conversions(const char *pattern);
VOLUX_API volux_status volux_sequence_procedural(volux_context *ctx, const char *name, const int dims[3],
                                                 uint64_t seed, double time0, double time_per_step, int steps,
                                                 uint64_t cache_bytes, volux_sequence **out);

/* Images. Format by extension: .png .pfm .exr .hdr (read only). */
VOLUX_API volux_status volux_image_load(volux_context *ctx, const char *path, volux_image *out);
/* Writes atomically (temp file + rename): a failed write leaves no file.
 * exposure applies to PNG only (2^exposure, then sRGB, clamp, 8 bit). */
VOLUX_API volux_status volux_image_save(volux_context *ctx, const char *path, const volux_image *img,
                                        float exposure);
/* Text metadata stored with an image: PNG tEXt chunks (before the pixel
 * data), OpenEXR string attributes of part 0. The CLI records how an image
 * was made ("volux.spp", "volux.technique", "volux.interrupted", ...). PFM
 * has no place for it. Keys up to 63 bytes, values up to 255. */
#define VOLUX_IMAGE_MAX_META 16
typedef struct volux_image_meta {
    int count;
    char key[VOLUX_IMAGE_MAX_META][64];
    char value[VOLUX_IMAGE_MAX_META][256];
} volux_image_meta;
/* Adds or replaces key (silently ignored when full or too long). */
VOLUX_API void volux_image_meta_set(volux_image_meta *m, const char *key, const char *value);
/* The value of key, or NULL. */
VOLUX_API const char *volux_image_meta_get(const volux_image_meta *m, const char *key);
/* volux_image_save with metadata (NULL: none; ignored for PFM). */
VOLUX_API volux_status volux_image_save_meta(volux_context *ctx, const char *path, const volux_image *img,
                                             float exposure, const volux_image_meta *meta);
/* Extra layers of an OpenEXR file (AOVs, as OSPRay Studio writes them):
 * `channels` floats per pixel, interleaved, rows from the top, written as
 * float32 channels "<layer>.<names[k]>" — or names[k] alone when layer is
 * NULL or empty (OpenEXR's conventional "Z" for depth). */
typedef struct volux_image_layer {
    const char *layer;    /* "albedo", "normal", "raw", ...; NULL: none    */
    int channels;         /* 1 … 4                                        */
    const char *names[4]; /* "R","G","B" / "X","Y","Z" / "Z" / "Y" ...    */
    const float *data;    /* width·height·channels of the image's size    */
} volux_image_layer;
#define VOLUX_IMAGE_MAX_LAYERS 16
/* volux_image_save_meta with n extra layers (borrowed for the call). n > 0
 * needs an .exr path (else VOLUX_ERR_INVALID naming the file); a channel
 * name repeated, too long (> 63 bytes) or clashing with R, G, B is
 * VOLUX_ERR_INVALID. The main R, G, B are what volux_image_load reads. */
VOLUX_API volux_status volux_image_save_layers(volux_context *ctx, const char *path, const volux_image *img,
                                               float exposure, const volux_image_meta *meta,
                                               const volux_image_layer *layers, int n);
/* volux_image_load plus the file's metadata (PNG text chunks before the
 * pixels; EXR string, int, float and double attributes that are not part
 * of the format's required set). meta->count is 0 for PFM and HDR. */
VOLUX_API volux_status volux_image_load_meta(volux_context *ctx, const char *path, volux_image *out,
                                             volux_image_meta *meta);
/* Checks, before any work, that an image can be written at `path`: a
 * writable extension (.png .pfm .exr) and volux_file_check_output's rules,
 * then creates and drops the unnamed file the save would write (permission
 * bits do not tell everything: /proc, a read-only mount, a full quota).
 * VOLUX_ERR_INVALID for the extension, VOLUX_ERR_IO otherwise, with the
 * reason. Leaves nothing behind. */
VOLUX_API volux_status volux_image_check_output(volux_context *ctx, const char *path);

/* Output files (images, scenes, tables: every file volux writes).
 * volux_file_check_output admits `path` as an output: a regular file, a
 * symbolic link to a regular file in the same folder (the target is
 * replaced, the link kept), or a new name in an existing writable folder.
 * Devices, pipes, sockets and folders are never replaced, links are not
 * followed out of their folder. VOLUX_ERR_IO with the reason; writes
 * nothing. */
VOLUX_API volux_status volux_file_check_output(volux_context *ctx, const char *path);
/* Writes n bytes to an admitted `path` whole: into an unnamed file in the
 * same folder, synced, then renamed over the target, so a failure — or a
 * kill at any moment — leaves the old file or none, never a part or a
 * temporary. VOLUX_ERR_WRITE naming the file (a refused path too). */
VOLUX_API volux_status volux_file_save(volux_context *ctx, const char *path, const void *bytes, size_t n);
/* Removes the named temporary files of writes in progress (used only where
 * the file system cannot create unnamed files). Async-signal-safe: for a
 * handler that ends the process at once (a second Ctrl-C). */
VOLUX_API void volux_file_abandon_writes(void);
/* Image details (see src/io/image_formats.h): PNG reads 8/16-bit gray, RGB,
 * palette, with alpha dropped, decoding sRGB to linear; PNG writes 8-bit RGB.
 * PFM reads PF/Pf of either endianness and writes little-endian PF. EXR reads
 * part 0 (scanline or tiled, half/float/uint, R,G,B or Y) and writes scanline
 * R,G,B float32 with ZIP compression. Unknown extensions are
 * VOLUX_ERR_INVALID; a failed save is VOLUX_ERR_WRITE and leaves no file. */

/* The sRGB transfer function (IEC 61966-2-1 piecewise curve), used by the
 * PNG reader/writer and for false-colour maps: linear → encoded and back.
 * Values are not clamped. */
VOLUX_API float volux_srgb_encode(float linear);
VOLUX_API float volux_srgb_decode(float encoded);

/* The tone mapping of PNG output as 8-bit sRGB: ×2^exposure, the sRGB
 * curve, clamp to [0,1], round; NaN and negatives are black. `out` holds
 * width·height·3 bytes, rows from the top. */
VOLUX_API void volux_image_to_srgb8(const volux_image *img, float exposure, unsigned char *out);
/* Encodes an image in memory as the file volux_image_save would write:
 * format "png" (tone-mapped with `exposure`), "pfm" or "exr" (linear).
 * *out is allocated through ctx; free with volux_encoded_free. */
VOLUX_API volux_status volux_image_encode(volux_context *ctx, const volux_image *img, const char *format,
                                          float exposure, unsigned char **out, size_t *size);
/* Same, with metadata (PNG text chunks, EXR attributes; NULL: none). */
VOLUX_API volux_status volux_image_encode_meta(volux_context *ctx, const volux_image *img, const char *format,
                                               float exposure, const volux_image_meta *meta, unsigned char **out,
                                               size_t *size);
VOLUX_API void volux_encoded_free(volux_context *ctx, unsigned char *data, size_t size);

/* Scenes. Loads a scene file; `overrides` are "dotted.path=VALUE" strings
 * applied to the JSON before validation (e.g. "render.width=64",
 * "lights.0.irradiance=2", "render.technique=shaded"): VALUE is one JSON
 * value, or a bare string when it is not JSON; a numeric segment indexes
 * an array and one past its end appends; missing keys are created.
 * Relative paths resolve against the scene's folder (a preset named in a
 * TF file, against the TF file's folder). Unknown, duplicate and
 * inapplicable keys are VOLUX_ERR_INVALID naming their path; NUL bytes,
 * "\u0000" escapes and nesting deeper than 64 levels are rejected. Every
 * message starts with the scene's file name. */
VOLUX_API volux_status volux_scene_load(volux_context *ctx, const char *path, const char *const *overrides,
                                        int n_overrides, volux_scene **out);
/* Same, from a JSON string; `base_dir` resolves relative paths ("." if NULL)
 * and `name` is used in messages. */
VOLUX_API volux_status volux_scene_load_string(volux_context *ctx, const char *json, const char *base_dir,
                                               const char *name, const char *const *overrides,
                                               int n_overrides, volux_scene **out);
/* Same, with the volume supplied by the caller (e.g. from
 * volux_volume_from_memory) instead of the scene's "volume" key: the key
 * may be absent, and if present it is not read (no file is opened for it).
 * The scene retains `volume`; a TF preset with preset_rescale is rescaled
 * to its range. */
VOLUX_API volux_status volux_scene_load_string_with_volume(volux_context *ctx, const char *json,
                                                           const char *base_dir, const char *name,
                                                           const char *const *overrides, int n_overrides,
                                                           volux_volume *volume, volux_scene **out);

/* The general loader. Give `path` (a scene file; relative names resolve
 * against its folder) or `json` (text; against `base_dir`, "." if NULL;
 * `name` labels messages). File names may start with "$VOLUX_DATA/": the
 * shared data root `data_dir` (NULL: the VOLUX_DATA environment variable;
 * docs/CONVENTIONS.md). An --set override that reaches into a key given by
 * file reference (transfer_function: "tf.json") first reads that file into
 * the scene, whose names keep resolving against the file's folder. A scene
 * without a transfer_function gets the quick-look default
 * (volux_transfer_auto_from_volume) and a note (volux_scene_notes). */
typedef struct volux_scene_load_options {
    const char *path;
    const char *json;
    const char *base_dir, *name;
    const char *const *overrides;
    int n_overrides;
    const char *data_dir;
    /* A volume the caller already loaded from `volume_file`: used when the
     * scene's volume is exactly {"file": volume_file} (no layout keys). */
    volux_volume *volume;
    const char *volume_file;
    /* Optional out: the scene as read (after overrides and defaults) as
     * JSON text, its file names rebased to `effective_dir` (NULL:
     * absolute); free with volux_scene_json_free. */
    char **effective_json;
    const char *effective_dir;
    /* Non-NULL: load only this brick of the scene's volume (a file or a
     * procedural volume; not a time series): data-parallel rendering. */
    const volux_volume_region *region;
} volux_scene_load_options;

VOLUX_API volux_status volux_scene_load_ex(volux_context *ctx, const volux_scene_load_options *options,
                                           volux_scene **out);
VOLUX_API void volux_scene_json_free(volux_context *ctx, char *json);

/* The quick-look scene of a volume as JSON text (free with
 * volux_scene_json_free): `volume_json` is the scene's "volume" value as
 * JSON text (e.g. {"file": "head.nii"}), `vol` that volume, loaded. The
 * scene: the default transfer function (volux_transfer_auto_from_volume),
 * an orbit camera framing the volume (up = the file's superior direction
 * when it has one: "z_up": true for the usual axial stacks), one key light
 * over the viewer's left shoulder, a ParaView-like background, `shaded` at
 * 512×512. */
VOLUX_API volux_status volux_scene_default_json(volux_context *ctx, const char *volume_json,
                                                const volux_volume *vol, char **json);

/* ---- Scene documents --------------------------------------------------
 *
 * A scene together with the JSON it was read from, so that a long-running
 * front end (the viewer, `volux serve`) can apply edits in the --set form
 * to a LIVE scene. An edit ("lights.0.irradiance=2") is applied to a copy
 * of the JSON, the copy is read by the same strict reader as
 * volux_scene_load (so every message is the one the CLI prints), and only
 * when all of it is valid is the live scene brought to it through its
 * setters, section by section: only what really changed bumps a version,
 * so techniques see the incremental change set of the edit (a light edit
 * bumps that light's slot only). Files (volumes, maps, presets) are read
 * again only when their section changed.
 *
 * Files an edit names must resolve, with symbolic links followed, inside
 * the data root (or be files the loaded document already named): an
 * edit from a browser cannot make the process read arbitrary files.
 *
 * DOES NOT: check technique names or parameters (io cannot see the
 * registry): pass a `validate` callback for that. Not thread-safe: the
 * caller serialises edits and keeps renders off the scene while editing.
 *
 * STEP BY STEP
 *     volux_scene_doc *doc;
 *     volux_scene_doc_load(ctx, "scene.json", NULL, 0, NULL, &doc);
 *     volux_scene *s = volux_scene_doc_scene(doc);     // render it
 *     const char *set[] = {"lights.0.irradiance=2"};
 *     if (volux_scene_doc_edit(doc, set, 1, NULL) != VOLUX_OK)
 *         puts(volux_context_error(ctx));              // scene unchanged
 *     volux_scene_doc_destroy(doc);
 */
typedef struct volux_scene_doc volux_scene_doc;

typedef struct volux_scene_doc_options {
    /* Folder that files named by edits must lie in; NULL = the scene
     * file's folder. Must exist. */
    const char *data_root;
    /* Called with the fully read candidate scene of the load and of every
     * edit before the live scene changes; a non-OK status (with its message
     * recorded in ctx, e.g. by volux_context_set_error) rejects the edit;
     * the message is then prefixed with the scene's file name. May be NULL. */
    volux_status (*validate)(void *user, volux_context *ctx, const volux_scene *candidate);
    void *validate_user;
} volux_scene_doc_options;

/* What an edit changed (bits of *changed in volux_scene_doc_edit). */
enum {
    VOLUX_DOC_VOLUME = 1u << 0,
    VOLUX_DOC_TRANSFER = 1u << 1,
    VOLUX_DOC_CAMERA = 1u << 2,
    VOLUX_DOC_LIGHTS = 1u << 3,
    VOLUX_DOC_OTHER = 1u << 4 /* render settings, background, parameters */
};

/* Loads a scene file with --set overrides (as volux_scene_load) and keeps
 * its JSON. options may be NULL. Caller destroys. */
VOLUX_API volux_status volux_scene_doc_load(volux_context *ctx, const char *path, const char *const *overrides,
                                            int n_overrides, const volux_scene_doc_options *options,
                                            volux_scene_doc **out);
/* The same, with `name` (NULL: path) standing for the file in every
 * message: `volux view` serves a generated scene from a temporary file
 * and names it after the volume the user gave. */
VOLUX_API volux_status volux_scene_doc_load_named(volux_context *ctx, const char *path, const char *name,
                                                  const char *const *overrides, int n_overrides,
                                                  const volux_scene_doc_options *options, volux_scene_doc **out);
VOLUX_API void volux_scene_doc_destroy(volux_scene_doc *doc);
/* The live scene, owned by the document (valid until it is destroyed). */
VOLUX_API volux_scene *volux_scene_doc_scene(const volux_scene_doc *doc);
/* The absolute data root in use. */
VOLUX_API const char *volux_scene_doc_data_root(const volux_scene_doc *doc);
/* Number of edits applied since the load (a version for clients). */
VOLUX_API uint64_t volux_scene_doc_version(const volux_scene_doc *doc);

/* Applies "dotted.path=VALUE" assignments, all or none: on any error (bad
 * path, bad value, unknown key, missing file, outside the data root, the
 * validate callback) the document and the scene are unchanged and the
 * message, prefixed with the scene's file name, is in ctx. *changed (may
 * be NULL) receives VOLUX_DOC_* bits. Only VOLUX_ERR_NOMEM while the live
 * scene is being updated can leave it partly edited (the document then
 * keeps its old JSON; the next successful edit re-applies the sections it
 * touches). */
VOLUX_API volux_status volux_scene_doc_edit(volux_scene_doc *doc, const char *const *assignments, int n,
                                            uint32_t *changed);
/* The same edits as a JSON text: [{"path": "lights.0.irradiance", "value": 2}, ...]
 * (at most 256 entries; each object has exactly the keys path and value).
 * Messages name the entry ("edit[1].path: ...") or come from the edit. */
VOLUX_API volux_status volux_scene_doc_edit_json(volux_scene_doc *doc, const char *text, size_t n,
                                                 uint32_t *changed);

/* Flags of volux_scene_doc_json. */
enum {
    VOLUX_DOC_JSON_PRETTY = 1u << 0,
    /* Relative file names become absolute, so the text renders the same
     * scene from any folder. */
    VOLUX_DOC_JSON_ABSOLUTE_PATHS = 1u << 1
};
/* The document's JSON after its edits: rendering it with volux_scene_load
 * gives the live scene. *out is NUL-terminated, allocated through ctx;
 * free with volux_scene_doc_json_free. */
VOLUX_API volux_status volux_scene_doc_json(const volux_scene_doc *doc, unsigned flags, char **out, size_t *len);
VOLUX_API void volux_scene_doc_json_free(const volux_scene_doc *doc, char *text, size_t len);

/* ParaView colour-map preset (JSON: a list of presets or one preset object
 * with "RGBPoints" [x,r,g,b,...]; "Points" opacity optional). Picks the
 * preset called `name` (a single object must carry that Name too), or the
 * first when name is NULL. Points are rescaled
 * to [s_min, s_max] when s_min < s_max (as ParaView applies a preset to the
 * data range), else kept. Output arrays are allocated through ctx. */
typedef struct volux_tf_preset {
    volux_tf_color_point *color;
    int n_color;
    volux_tf_scalar_point *opacity; /* NULL when the preset has none */
    int n_opacity;
    /* Opacity segments whose ParaView sharpness is > 0: drawn piecewise-
     * linear through their midpoint (the curve's shape is not modelled). */
    int n_sharp;
} volux_tf_preset;

VOLUX_API volux_status volux_tf_preset_load(volux_context *ctx, const char *path, const char *name,
                                            double s_min, double s_max, volux_tf_preset *out);
VOLUX_API void volux_tf_preset_free(volux_context *ctx, volux_tf_preset *p);

#ifdef __cplusplus
}
#endif
#endif
