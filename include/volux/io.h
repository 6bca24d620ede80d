/*
 * volux/io.h — files ⇄ core objects.
 *
 * Volumes: NRRD (.nrrd attached, .nhdr detached; raw and gzip encodings),
 * MetaImage (.mhd/.mha), NIfTI-1 (.nii, .nii.gz), raw with an explicit
 * description, and procedural volumes by name. Every reader validates the
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

typedef struct volux_volume_load_options {
    const volux_raw_desc *raw; /* non-NULL: read `path` as raw with this  */
    int use_file_origin;       /* 1: origin from the header, else centred  */
    int allow_outside_dir;     /* 1: detached data may lie outside the
                                  header's folder (else a data file must
                                  resolve inside it, symbolic links
                                  followed)                                 */
    int allow_nonfinite;       /* 1: NaN/Inf values become the lowest
                                  value, with a warning; 0: they are
                                  VOLUX_ERR_FORMAT (count, first voxel)     */
} volux_volume_load_options;

/* Loads a volume file, choosing the reader by extension (.nrrd .nhdr .mhd
 * .mha .nii .nii.gz .raw). options may be NULL. Errors name the file and
 * the problem; VOLUX_ERR_IO when missing/unreadable, VOLUX_ERR_FORMAT when
 * malformed, VOLUX_ERR_UNSUPPORTED, VOLUX_ERR_LIMIT. Caller releases. */
VOLUX_API volux_status volux_volume_load(volux_context *ctx, const char *path,
                                         const volux_volume_load_options *options, volux_volume **out);

/* Procedural volumes: "sphere", "marschner_lobb", "cloud", "phantom",
 * "constant" (all 1.0 — a homogeneous box). uint8 except "constant"
 * (float32). Spacing 1. */
VOLUX_API volux_status volux_volume_procedural(volux_context *ctx, const char *name, const int dims[3],
                                               uint64_t seed, volux_volume **out);
/* Comma-separated list of procedural names (for messages). */
VOLUX_API const char *volux_procedural_names(void);

/* Images. Format by extension: .png .pfm .exr .hdr (read only). */
VOLUX_API volux_status volux_image_load(volux_context *ctx, const char *path, volux_image *out);
/* Writes atomically (temp file + rename): a failed write leaves no file.
 * exposure applies to PNG only (2^exposure, then sRGB, clamp, 8 bit). */
VOLUX_API volux_status volux_image_save(volux_context *ctx, const char *path, const volux_image *img,
                                        float exposure);
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
} volux_tf_preset;

VOLUX_API volux_status volux_tf_preset_load(volux_context *ctx, const char *path, const char *name,
                                            double s_min, double s_max, volux_tf_preset *out);
VOLUX_API void volux_tf_preset_free(volux_context *ctx, volux_tf_preset *p);

#ifdef __cplusplus
}
#endif
#endif
