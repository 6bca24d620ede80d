/*
 * io/volume_formats.h — private plumbing shared by the volume readers.
 *
 * Every format is read in two steps (DESIGN §5):
 *
 *   1. A parse-from-memory entry point turns the header bytes into a
 *      volux_volume_header. It never touches the file system, never
 *      allocates more than a few bytes, and enforces the limits: text
 *      headers ≤ VOLUX_MAX_HEADER_BYTES, each axis ≤ VOLUX_MAX_DIM, the
 *      voxel count ≤ VOLUX_MAX_VOXELS, the storage size ≤ the context's
 *      max_bytes and a data file name ≤ VOLUX_MAX_DATA_NAME characters.
 *      All size arithmetic is checked, so an accepted header describes a
 *      volume we can afford to allocate.
 *   2. volux_volume_read_data() (volume_data.c), shared by all formats,
 *      checks the header against the bytes actually present (file size for
 *      raw data, the exact decompressed size for zlib/gzip data) before or
 *      while filling the storage, converts byte order and types, and
 *      finalizes the volume.
 *
 * Messages have the form "NAME: field: problem, got VALUE", with NAME the
 * `name` argument (the path as the user gave it).
 *
 * DOES NOT: resolve detached data paths (volume_load.c does, because the
 * policy depends on volux_volume_load_options), print, or keep files open.
 */
#ifndef VOLUX_IO_VOLUME_FORMATS_H
#define VOLUX_IO_VOLUME_FORMATS_H

#include <stdio.h>

#include "core/context_internal.h"
#include "volux/io.h"
#include "volux/volume.h"

/* Longest text header (NRRD, MetaImage) we read; real ones are < 4 KiB. */
#define VOLUX_MAX_HEADER_BYTES (1u << 20)
/* Longest detached data file name; Teem 1.12 aborts on long ones (§5). */
#define VOLUX_MAX_DATA_NAME 1024
/* Most data files one volume may be split into (one per slice of the
 * largest axis). */
#define VOLUX_MAX_DATA_FILES VOLUX_MAX_DIM

typedef enum volux_encoding {
    VOLUX_ENCODING_RAW,
    VOLUX_ENCODING_ZLIB /* a gzip or zlib stream (detected by its header) */
} volux_encoding;

/* What a header says about its data; the common currency of the readers. */
typedef struct volux_volume_header {
    int dims[3];            /* x fastest; each in [1, VOLUX_MAX_DIM]        */
    volux_scalar_type type; /* type of the values in the file               */
    int big_endian;         /* byte order of multi-byte values in the file  */
    volux_encoding encoding;
    double spacing[3]; /* > 0, finite                                  */
    double origin[3];  /* world position of node (0,0,0)...            */
    int has_origin;    /* ...if the header gives one                   */
    /* Anatomical superior in the grid's axes (unit-free; the loader
     * normalises), if the header gives an anatomical orientation. */
    double superior[3];
    int has_superior;
    /* Linear value map (NIfTI scl_slope/scl_inter): when set, a value is
     * slope·stored + inter and the volume is stored as float32. */
    int apply_scale;
    double scale_slope, scale_inter;
    /* Where the data is. data_file "" means "in the header's own file". */
    char data_file[VOLUX_MAX_DATA_NAME + 1];
    uint64_t data_offset; /* byte offset of the data region in that file   */
    uint64_t line_skip;   /* lines skipped from data_offset, before...     */
    int64_t byte_skip;    /* ...bytes skipped: raw: file bytes, -1 = the
                             data ends at the end of the file; zlib: bytes
                             of the decoded stream                          */
    int trailing_ok;      /* raw data may be followed by more bytes (NRRD,
                             as Teem: ignored with a warning)               */
    /* Data split over several files (NRRD "data file: FMT MIN MAX STEP" or
     * "data file: LIST"): file_count > 0 files, each holding an equal,
     * consecutive share of the values (x fastest). Pattern form: data_file
     * is a printf format with one integer conversion, file i's number is
     * file_first + i·file_step. LIST form (file_list): the names are the
     * lines of the header file from byte list_offset on. Skips apply to
     * every file. */
    int file_count;
    int file_list;
    int64_t file_first, file_step;
    uint64_t list_offset;
    uint64_t compressed_size; /* bytes of compressed data the header declares
                                 (MetaImage CompressedDataSize); 0 = not given */
} volux_volume_header;

/* Sets the defaults every parser starts from: spacing 1, little endian,
 * raw, attached, no offsets, no scale. */
void volux_volume_header_init(volux_volume_header *h);

/* Shared final validation of a parsed header: dims within limits, storage
 * bytes (checked multiply) within volux_context_max_bytes(ctx), spacing
 * positive and finite, skip values consistent with the encoding. Every
 * parse entry point ends with it. VOLUX_ERR_LIMIT / VOLUX_ERR_FORMAT. */
volux_status volux_volume_header_check(volux_context *ctx, const char *name, const volux_volume_header *h);

/* ------------------------------------------------------------------ */
/* Field helpers shared by the text formats (header_fields.c). `field` */
/* names the header field in messages.                                 */
/* ------------------------------------------------------------------ */

struct volux_text;

/* Parses exactly `count` axis sizes (integers ≥ 1); > VOLUX_MAX_DIM is
 * VOLUX_ERR_LIMIT, anything else wrong VOLUX_ERR_FORMAT. */
volux_status volux_header_sizes(volux_context *ctx, const char *name, const char *field, struct volux_text value,
                                int count, int64_t *sizes);
/* Parses exactly `count` numbers (nan/inf allowed: callers judge). */
/* 1 if three axis vectors do not span 3-D space: one is zero (or not
 * finite) or they are (nearly) coplanar — |det| ≤ 1e-6·|a|·|b|·|c|, i.e.
 * the parallelepiped they span is flatter than about 1e-4 degrees. */
int volux_header_axes_degenerate(const double a[3], const double b[3], const double c[3]);

volux_status volux_header_numbers(volux_context *ctx, const char *name, const char *field, struct volux_text value,
                                  int count, double *out);
/* Chooses the three spatial axes of an ndim-axis array: ndim 3, or 4 with
 * a size-1 first axis (one component per voxel) or a size-1 last axis (one
 * time step). Fills h->dims and axes[3] (indices into sizes).
 * VOLUX_ERR_UNSUPPORTED for other shapes. */
volux_status volux_header_axes(volux_context *ctx, const char *name, const char *field, const int64_t *sizes,
                               int ndim, volux_volume_header *h, int axes[3]);
/* Validates a detached data file name and copies it into h->data_file:
 * empty is VOLUX_ERR_FORMAT, longer than VOLUX_MAX_DATA_NAME is
 * VOLUX_ERR_LIMIT, "LIST" and "PATTERN MIN MAX STEP" multi-file forms are
 * VOLUX_ERR_UNSUPPORTED. Folder policy is checked later, by the loader. */
volux_status volux_header_data_file(volux_context *ctx, const char *name, const char *field, struct volux_text value,
                                    volux_volume_header *h);

/* ------------------------------------------------------------------ */
/* Parse-from-memory entry points. `bytes` need not be NUL-terminated; */
/* `n` is how many bytes are valid. *out is written on success only.  */
/* ------------------------------------------------------------------ */

/* NRRD (NRRD0001..NRRD0005). For an attached file pass the whole file (or
 * at least its header); the header ends at the first empty line and
 * out->data_offset points just past it. A detached header (.nhdr) may end at
 * the end of the buffer. */
volux_status volux_nrrd_parse_header(volux_context *ctx, const char *bytes, size_t n, const char *name,
                                     volux_volume_header *out);

/* MetaImage (.mhd/.mha). The header ends with the ElementDataFile line;
 * "LOCAL" data starts right after it (out->data_offset). */
volux_status volux_metaimage_parse_header(volux_context *ctx, const char *bytes, size_t n, const char *name,
                                          volux_volume_header *out);

/* NIfTI-1 (the 348-byte header) or NIfTI-2 (540 bytes), either byte
 * order; n is what the file holds (a NIfTI-1 file may be shorter than 540).
 * `name` decides nothing but the messages, except for a "ni1"/"ni2" header
 * (a .hdr/.img pair), whose data_file is the basename of `name` with .hdr
 * replaced by .img. */
#define VOLUX_NIFTI_HEADER_BYTES 348
#define VOLUX_NIFTI2_HEADER_BYTES 540
volux_status volux_nifti_parse_header(volux_context *ctx, const unsigned char *bytes, size_t n,
                                      const char *name, volux_volume_header *out);

/* A raw file described by the caller (volux_raw_desc). Bad descriptions
 * are VOLUX_ERR_INVALID (the caller's fault, not the file's). */
volux_status volux_raw_header_from_desc(volux_context *ctx, const volux_raw_desc *desc, const char *name,
                                        volux_volume_header *out);

/* ------------------------------------------------------------------ */
/* Byte sources and the common data reader (volume_data.c)             */
/* ------------------------------------------------------------------ */

/* Bytes of one file, from disk or from memory. */
typedef struct volux_source {
    const char *name;         /* for messages (borrowed)                  */
    const unsigned char *mem; /* non-NULL: an in-memory file              */
    FILE *file;
    uint64_t size; /* total bytes */
} volux_source;

/* Opens `path` for reading. VOLUX_ERR_IO naming the file when it is missing,
 * a folder, or unreadable. Close with volux_source_close. */
volux_status volux_source_open(volux_context *ctx, const char *path, volux_source *out);
void volux_source_memory(const void *bytes, size_t n, const char *name, volux_source *out);
void volux_source_close(volux_source *s);
/* Reads up to n bytes at `offset`; *got < n only at the end of the source. */
volux_status volux_source_read(volux_context *ctx, volux_source *s, uint64_t offset, void *buf, size_t n,
                               size_t *got);
/* Decodes up to n bytes of the zlib/gzip stream that starts at `offset`
 * (for .nii.gz, whose header is inside the stream). *got < n when the
 * stream ends first. Corrupt data: VOLUX_ERR_FORMAT. */
volux_status volux_source_inflate_prefix(volux_context *ctx, volux_source *s, uint64_t offset, void *buf,
                                         size_t n, size_t *got);

/* Reads the data a checked header describes from `src`, fills a new volume
 * and finalizes it (origin from the header when options->use_file_origin
 * and the header has one, else centred). Rejects data shorter or longer
 * than dims × type size with VOLUX_ERR_FORMAT (longer raw data with
 * h->trailing_ok: a warning), and NaN/Inf values unless
 * options->allow_nonfinite (then a warning). options may be NULL. Caller
 * releases *out. */
/* The same for a volume split over `parts` sources (each holds 1/parts of
 * the values, in order), all sizes checked before allocating. The parts
 * are opened one at a time through ps (twice: sizes, then data); `name`
 * (the header) prefixes messages. */
typedef struct volux_part_source {
    volux_status (*open)(void *user, int k, volux_source *out);
    void (*close)(void *user, volux_source *s);
    void *user;
    const char *name;
} volux_part_source;
volux_status volux_volume_read_parts(volux_context *ctx, const volux_volume_header *h, int parts,
                                     const volux_part_source *ps, const volux_volume_load_options *options,
                                     volux_volume **out);
volux_status volux_volume_read_data(volux_context *ctx, const volux_volume_header *h, volux_source *src,
                                    const volux_volume_load_options *options, volux_volume **out);

/* volux_volume_read_data reads only one brick when options->region is set
 * (only the brick's storage is allocated; not for data split over
 * several files: VOLUX_ERR_UNSUPPORTED). */
/* The stored node box [lo, hi) of a region of a grid, or
 * VOLUX_ERR_INVALID naming `name`. */
volux_status volux_region_box(volux_context *ctx, const char *name, const int dims[3],
                              const volux_volume_region *r, int lo[3], int hi[3]);

/* For readers with their own data framing (VTI): stores `count` elements of
 * type h->type in byte order h->big_endian (swapped in place when that is
 * not the host's) into v from element `first`, converted as
 * volux_volume_read_data converts. v comes from volux_volume_create_storage
 * with h->dims and h->type. */
int volux_host_big_endian(void);
void volux_volume_store_elements(const volux_volume_header *h, volux_volume *v, size_t first, unsigned char *bytes,
                                 size_t count);
/* The common last step of every reader: the non-finite policy (NaN/Inf
 * refused with their count and first voxel unless options->allow_nonfinite,
 * then mapped to the lowest value with a warning), then finalizes v (origin
 * from the header when options->use_file_origin and it has one, else
 * centred) and sets its anatomical orientation. options may be NULL. */
volux_status volux_volume_read_finish(volux_context *ctx, const volux_volume_header *h, const char *name,
                                      const volux_volume_load_options *options, volux_volume *v);

/* VTK XML ImageData (.vti, vti.c). The header parse runs the XML up to
 * the chosen point-data array (dims, type, spacing, origin); the read
 * decodes that array (ascii, inline base64 or appended raw/base64,
 * optionally zlib-compressed) straight into a new volume. */
volux_status volux_vti_parse_header(volux_context *ctx, volux_source *src, volux_volume_header *out);
volux_status volux_vti_read(volux_context *ctx, volux_source *src, const volux_volume_load_options *options,
                            volux_volume **out);

/* What a volume file holds, from its header alone. */
typedef struct volux_volume_shape {
    int dims[3];
    volux_scalar_type type; /* as loaded (float32 when the file scales values) */
    double spacing[3];
} volux_volume_shape;

/* Reads only the header of `path` (the same checks as volux_volume_load,
 * none of the data): for checking that the frames of a sequence agree
 * before any of them is loaded. */
volux_status volux_volume_probe(volux_context *ctx, const char *path, const volux_volume_load_options *options,
                                volux_volume_shape *out);

/* DICOM (dicom.c over the GDCM adapter): 1 if `path` is a folder, ends in
 * .dcm/.dicom or starts with the PS3.10 preamble and "DICM". */
int volux_dicom_path_is_dicom(const char *path);
/* A folder (its largest series, or the one a file names) or one file's
 * series as a volume; see dicom.c for the rules. */
volux_status volux_dicom_load(volux_context *ctx, const char *path, const volux_volume_load_options *options,
                              volux_volume **out);
/* One DICOM file held in memory (fuzzing, tests). */
volux_status volux_dicom_load_memory(volux_context *ctx, const void *bytes, size_t n, const char *name,
                                     const volux_volume_load_options *options, volux_volume **out);

/* ------------------------------------------------------------------ */
/* Whole-file loading from memory (fuzzing, tests)                     */
/* ------------------------------------------------------------------ */

typedef enum volux_volume_format {
    VOLUX_FORMAT_NRRD,
    VOLUX_FORMAT_METAIMAGE,
    VOLUX_FORMAT_NIFTI,
    VOLUX_FORMAT_NIFTI_GZ,
    VOLUX_FORMAT_VTI
} volux_volume_format;

/* Loads an attached file held in memory, through the same code as
 * volux_volume_load. A header that names a detached data file is checked
 * (including the folder policy) and then fails with VOLUX_ERR_IO, since
 * there is no folder to read it from. */
volux_status volux_volume_load_memory(volux_context *ctx, const void *bytes, size_t n, const char *name,
                                      volux_volume_format format, const volux_volume_load_options *options,
                                      volux_volume **out);

/* The procedural volume with every node evaluated (no row intervals), as
 * the generator did before they existed: for the test that the intervals
 * change no byte. region may be NULL (the whole volume). */
volux_status volux_procedural_exhaustive(volux_context *ctx, const char *name, const int dims[3], uint64_t seed,
                                         const volux_volume_region *region, volux_volume **out);

#endif
