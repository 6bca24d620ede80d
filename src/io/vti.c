/*
 * io/vti.c — VTK XML ImageData (.vti), ParaView's own volume format.
 *
 * The file (VTK User's Guide, "VTK XML File Formats"):
 *
 *   <VTKFile type="ImageData" byte_order="LittleEndian" header_type="UInt64"
 *            compressor="vtkZLibDataCompressor">
 *     <ImageData WholeExtent="x0 x1 y0 y1 z0 z1" Origin="…" Spacing="…"
 *                Direction="…">
 *       <Piece Extent="…">
 *         <PointData Scalars="density">
 *           <DataArray type="UInt8" Name="density" format="ascii|binary|appended"
 *                      offset="…">…</DataArray>
 *         </PointData>
 *       </Piece>
 *     </ImageData>
 *     <AppendedData encoding="raw|base64">_…bytes…</AppendedData>
 *   </VTKFile>
 *
 * Binary data (inline base64, or appended raw/base64) is framed. Without a
 * compressor: one header integer (header_type, default UInt32) holding the
 * byte count, then the bytes. With vtkZLibDataCompressor: the header
 * [number of blocks, block size, size of the last block (0 = a full one),
 * compressed size of each block], then each block's zlib stream in turn.
 * VTK's writer encodes the header and the data as separate padded base64
 * runs when compressed; the decoder below accepts any concatenation of
 * padded runs, so both layouts read the same.
 *
 * Expat parses the XML (DESIGN §5). The chosen array (PointData's Scalars,
 * else its first DataArray) is decoded as it streams past — ascii numbers,
 * base64 text or appended bytes — through the framing and zlib into the
 * volume's storage: no whole-file or whole-array temporary. The volume is
 * allocated at the array's start tag, after its size was checked against
 * the limits and against what the file's size can hold. Appended data is
 * binary and not XML: parsing stops at <AppendedData> and the bytes are
 * read from the source directly.
 *
 * Not supported (each refused with a message naming the attribute): several
 * pieces, multi-component arrays, a Direction that
 * is not the identity, compressors other than zlib.
 */
#include <expat.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "core/volume_internal.h"
#include "header_text.h"
#include "volume_formats.h"

#define VTI_CHUNK (64u << 10)    /* source bytes per read, inflate output per step */
#define VTI_MAX_BLOCKS (1u << 24) /* compressed blocks per array (VTK: 32 KiB each) */
#define VTI_ASCII_BATCH 4096      /* ascii values converted per store call */

typedef enum { FMT_ASCII, FMT_BINARY, FMT_APPENDED } vti_format;
typedef enum { FRAME_HEAD, FRAME_RAW, FRAME_ZLIB, FRAME_DONE } frame_state;

typedef struct vti {
    volux_context *ctx;
    const char *name;
    volux_source *src;
    XML_Parser xp;
    volux_status st;  /* first error; parsing stops there */
    int header_only;  /* stop at the chosen array's start tag */
    int stopped;      /* we stopped expat on purpose */
    int parsing;      /* inside XML_Parse (handlers may stop it) */

    /* <VTKFile> */
    int big_endian, header_bytes, zlib;
    /* element nesting: which of the elements we care about we are in */
    int depth, image_depth, piece_depth, point_depth, array_depth;
    int pieces;
    int64_t extent[6];
    volux_volume_header h;
    char scalars[256]; /* PointData Scalars= (the active array), "" = first */
    int arrays_seen;   /* DataArray elements inside PointData */

    /* the chosen array */
    int found, in_array;
    vti_format format;
    uint64_t offset; /* appended: bytes after the '_' */
    int appended_base64;
    uint64_t appended_start; /* source offset of the byte after '_' */
    int appended_seen;

    /* element sink */
    volux_volume *v;
    size_t count, done, esize, progress_mark;
    unsigned char carry[8];
    size_t ncarry;

    /* ascii tokens */
    char tok[96];
    size_t ntok;
    unsigned char *batch; /* VTI_ASCII_BATCH native elements */
    size_t nbatch;

    /* base64 */
    unsigned char group[4];
    int ngroup, npad;

    /* framing */
    frame_state frame;
    unsigned char head[8];
    size_t nhead;
    uint64_t ints_needed, ints_got;
    uint64_t raw_left;
    uint64_t nblocks, block_size, last_size, block;
    uint64_t *csize;
    uint64_t in_left, out_left;
    int block_ended;
    z_stream z;
    int z_live;
    unsigned char *out; /* VTI_CHUNK inflate output */
} vti;

static void fail(vti *p, volux_status st) {
    if (!p->st) p->st = st;
    if (p->parsing) XML_StopParser(p->xp, XML_FALSE);
}

static const char *attr(const XML_Char **a, const char *key) {
    for (; a && a[0]; a += 2)
        if (strcmp(a[0], key) == 0) return a[1];
    return NULL;
}

/* Exactly `n` finite numbers separated by white space, read in the C
 * locale like every header number (header_text.c). 0 on anything else. */
static int parse_numbers(const char *s, int n, double *out) {
    volux_text rest = {s, strlen(s)}, tok;
    for (int i = 0; i < n; i++)
        if (!volux_text_token(&rest, &tok) || !volux_text_to_double(tok, &out[i]) || !isfinite(out[i])) return 0;
    return !volux_text_token(&rest, &tok);
}

/* The extent's six integers (a string of whole numbers within ±2^31). */
static int parse_extent(const char *s, int64_t e[6]) {
    double d[6];
    if (!s || !parse_numbers(s, 6, d)) return 0;
    for (int i = 0; i < 6; i++) {
        if (d[i] != floor(d[i]) || fabs(d[i]) > 2147483647.0) return 0;
        e[i] = (int64_t)d[i];
    }
    return 1;
}

/* ------------------------------------------------------------------ */
/* Element sink: file-order bytes → storage                             */
/* ------------------------------------------------------------------ */

static void progress(vti *p) {
    if (p->done - p->progress_mark < (1u << 20) && p->done < p->count) return;
    p->progress_mark = p->done;
    if (volux_progress(p->ctx, "load volume", (double)p->done / (double)p->count))
        fail(p, volux_error(p->ctx, VOLUX_ERR_CANCELLED, "%s: loading cancelled", p->name));
}

/* Bytes of decoded array data, in the file's byte order. */
static void sink(vti *p, unsigned char *b, size_t n) {
    if (p->ncarry) {
        size_t take = p->esize - p->ncarry < n ? p->esize - p->ncarry : n;
        memcpy(p->carry + p->ncarry, b, take);
        p->ncarry += take;
        b += take;
        n -= take;
        if (p->ncarry < p->esize) return;
        volux_volume_store_elements(&p->h, p->v, p->done++, p->carry, 1);
        p->ncarry = 0;
    }
    size_t k = n / p->esize;
    if (k) {
        volux_volume_store_elements(&p->h, p->v, p->done, b, k);
        p->done += k;
    }
    p->ncarry = n - k * p->esize;
    memcpy(p->carry, b + k * p->esize, p->ncarry);
    progress(p);
}

/* ------------------------------------------------------------------ */
/* Framing (header integers, raw bytes, zlib blocks)                    */
/* ------------------------------------------------------------------ */

static uint64_t head_value(const vti *p) {
    uint64_t v = 0;
    for (int i = 0; i < p->header_bytes; i++) {
        int k = p->big_endian ? i : p->header_bytes - 1 - i;
        v = v << 8 | p->head[k];
    }
    return v;
}

static void start_block(vti *p) {
    p->in_left = p->csize[p->block];
    p->out_left = p->block + 1 == p->nblocks && p->last_size ? p->last_size : p->block_size;
    p->block_ended = 0;
    if (inflateReset(&p->z) != Z_OK) fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: zlib reset failed", p->name));
}

/* One complete header integer. */
static void header_int(vti *p, uint64_t value) {
    volux_context *ctx = p->ctx;
    uint64_t need = (uint64_t)p->count * p->esize;
    uint64_t i = p->ints_got++;
    if (!p->zlib) {
        if (value != need)
            fail(p, volux_error(ctx, VOLUX_ERR_FORMAT,
                                "%s: DataArray: the data header gives %llu bytes, the extent and type need %llu",
                                p->name, (unsigned long long)value, (unsigned long long)need));
        p->frame = FRAME_RAW;
        p->raw_left = need;
        return;
    }
    if (i == 0) p->nblocks = value;
    else if (i == 1) p->block_size = value;
    else if (i == 2) {
        p->last_size = value;
        /* The blocks must cover exactly the array: checked before the
         * table of compressed sizes is allocated. */
        uint64_t bs = p->block_size, nb = p->nblocks;
        int ok = bs >= 1 && nb >= 1 && nb <= VTI_MAX_BLOCKS && p->last_size <= bs;
        if (ok) {
            uint64_t full = p->last_size ? nb - 1 : nb;
            ok = full <= need / bs && full * bs + p->last_size == need;
        }
        if (!ok) {
            fail(p, volux_error(ctx, VOLUX_ERR_FORMAT,
                                "%s: DataArray: compression header (%llu blocks of %llu bytes, last %llu) does not "
                                "cover the %llu bytes the extent and type need",
                                p->name, (unsigned long long)nb, (unsigned long long)bs,
                                (unsigned long long)p->last_size, (unsigned long long)need));
            return;
        }
        p->csize = volux_malloc(ctx, (size_t)nb * sizeof *p->csize);
        if (!p->csize) {
            fail(p, volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for %llu block sizes", p->name,
                                (unsigned long long)nb));
            return;
        }
        p->ints_needed = 3 + nb;
    } else {
        /* zlib never expands a block past 1032:1 (plus a small header). */
        uint64_t out = i - 3 + 1 == p->nblocks && p->last_size ? p->last_size : p->block_size;
        if (value == 0 || value > p->src->size || value * 1032 + 64 < out) {
            fail(p, volux_error(ctx, VOLUX_ERR_FORMAT, "%s: DataArray: compressed block %llu has an impossible size %llu",
                                p->name, (unsigned long long)(i - 3), (unsigned long long)value));
            return;
        }
        p->csize[i - 3] = value;
    }
    if (p->zlib && p->ints_got == p->ints_needed) {
        p->frame = FRAME_ZLIB;
        p->block = 0;
        start_block(p);
    }
}

static void inflate_bytes(vti *p, unsigned char *b, size_t n) {
    p->z.next_in = b;
    p->z.avail_in = (uInt)n;
    while (!p->st) {
        if (p->block_ended) {
            if (p->z.avail_in)
                fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT,
                                    "%s: DataArray: compressed block %llu has bytes after its end", p->name,
                                    (unsigned long long)p->block));
            return;
        }
        p->z.next_out = p->out;
        p->z.avail_out = VTI_CHUNK;
        int r = inflate(&p->z, Z_NO_FLUSH);
        size_t made = VTI_CHUNK - p->z.avail_out;
        if (r != Z_OK && r != Z_STREAM_END && !(r == Z_BUF_ERROR && made == 0)) {
            fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: DataArray: compressed block %llu is corrupt (%s)",
                                p->name, (unsigned long long)p->block, p->z.msg ? p->z.msg : "zlib error"));
            return;
        }
        if (made > p->out_left) {
            fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT,
                                "%s: DataArray: compressed block %llu decompresses to more than its declared size",
                                p->name, (unsigned long long)p->block));
            return;
        }
        p->out_left -= made;
        if (made) sink(p, p->out, made);
        if (r == Z_STREAM_END) p->block_ended = 1;
        else if (p->z.avail_in == 0 && made < VTI_CHUNK) return; /* wants more input */
    }
}

/* Bytes of the decoded data stream (header + data) of the chosen array. */
static void frame_push(vti *p, unsigned char *b, size_t n) {
    while (n && !p->st) {
        switch (p->frame) {
        case FRAME_HEAD: {
            size_t take = (size_t)p->header_bytes - p->nhead < n ? (size_t)p->header_bytes - p->nhead : n;
            memcpy(p->head + p->nhead, b, take);
            p->nhead += take;
            b += take;
            n -= take;
            if (p->nhead == (size_t)p->header_bytes) {
                p->nhead = 0;
                header_int(p, head_value(p));
            }
            break;
        }
        case FRAME_RAW: {
            size_t take = p->raw_left < n ? (size_t)p->raw_left : n;
            sink(p, b, take);
            p->raw_left -= take;
            b += take;
            n -= take;
            if (!p->raw_left) p->frame = FRAME_DONE;
            break;
        }
        case FRAME_ZLIB: {
            size_t take = p->in_left < n ? (size_t)p->in_left : n;
            inflate_bytes(p, b, take);
            p->in_left -= take;
            b += take;
            n -= take;
            if (p->st || p->in_left) break;
            if (!p->block_ended || p->out_left) {
                fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT,
                                    "%s: DataArray: compressed block %llu ends before its declared size", p->name,
                                    (unsigned long long)p->block));
                break;
            }
            if (++p->block == p->nblocks) p->frame = FRAME_DONE;
            else start_block(p);
            break;
        }
        case FRAME_DONE:
            fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: DataArray: more data than the extent and type need",
                                p->name));
            break;
        }
    }
}

/* ------------------------------------------------------------------ */
/* base64 (RFC 4648) and ascii decoding                                 */
/* ------------------------------------------------------------------ */

static int b64_value(unsigned char c) {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
}

/* Feeds base64 text; decoded bytes go to frame_push. An appended array
 * stops at the group where its framing is done (the next array's text
 * follows). */
static void b64_push(vti *p, const unsigned char *s, size_t n) {
    unsigned char out[3 * 256];
    size_t nout = 0;
    for (size_t i = 0; i < n && !p->st; i++) {
        unsigned char c = s[i];
        if (c == ' ' || c == '\t' || c == '\r' || c == '\n') continue;
        int v = c == '=' ? 0 : b64_value(c);
        if (v < 0 || (c != '=' && p->npad) || (c == '=' && p->ngroup < 2)) {
            fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: DataArray: invalid base64 text (character 0x%02x)",
                                p->name, c));
            break;
        }
        p->npad += c == '=';
        p->group[p->ngroup++] = (unsigned char)v;
        if (p->ngroup < 4) continue;
        unsigned char *g = p->group;
        unsigned char bytes[3] = {(unsigned char)(g[0] << 2 | g[1] >> 4), (unsigned char)(g[1] << 4 | g[2] >> 2),
                                  (unsigned char)(g[2] << 6 | g[3])};
        memcpy(out + nout, bytes, (size_t)(3 - p->npad));
        nout += (size_t)(3 - p->npad);
        p->ngroup = p->npad = 0;
        /* An appended array's text is followed by the next array's: push
         * group by group so the framing sees exactly where it ends. */
        if (nout > sizeof out - 3 || p->format == FMT_APPENDED) {
            frame_push(p, out, nout);
            nout = 0;
        }
        if (p->frame == FRAME_DONE && p->format == FMT_APPENDED) break;
    }
    if (nout && !p->st) frame_push(p, out, nout);
}

static void ascii_flush(vti *p) {
    if (!p->nbatch) return;
    /* batch holds native-order values: store them as such */
    volux_volume_header native = p->h;
    native.big_endian = volux_host_big_endian();
    volux_volume_store_elements(&native, p->v, p->done, p->batch, p->nbatch);
    p->done += p->nbatch;
    p->nbatch = 0;
    progress(p);
}

/* Stores the integer d as one element of integer type t at e (native
 * order); 0 if d is not an integer in t's range. The upper bounds are
 * exclusive powers of two: 2^63 − 1 is not a double. */
static int ascii_integer(double d, volux_scalar_type t, unsigned char *e) {
    if (d != floor(d)) return 0;
    switch (t) {
    case VOLUX_UINT8:
    case VOLUX_INT8: {
        int s = t == VOLUX_INT8;
        if (d < (s ? -128 : 0) || d > (s ? 127 : 255)) return 0;
        *e = s ? (unsigned char)(int8_t)d : (uint8_t)d;
        return 1;
    }
    case VOLUX_UINT16:
    case VOLUX_INT16: {
        int s = t == VOLUX_INT16;
        if (d < (s ? -32768 : 0) || d > (s ? 32767 : 65535)) return 0;
        uint16_t u = s ? (uint16_t)(int16_t)d : (uint16_t)d;
        memcpy(e, &u, 2);
        return 1;
    }
    case VOLUX_INT32: {
        if (d < -2147483648.0 || d >= 2147483648.0) return 0;
        int32_t x = (int32_t)d;
        memcpy(e, &x, 4);
        return 1;
    }
    case VOLUX_UINT32: {
        if (d < 0 || d >= 4294967296.0) return 0;
        uint32_t x = (uint32_t)d;
        memcpy(e, &x, 4);
        return 1;
    }
    case VOLUX_INT64: {
        if (d < -9223372036854775808.0 || d >= 9223372036854775808.0) return 0;
        int64_t x = (int64_t)d;
        memcpy(e, &x, 8);
        return 1;
    }
    case VOLUX_UINT64: {
        if (d < 0 || d >= 18446744073709551616.0) return 0;
        uint64_t x = (uint64_t)d;
        memcpy(e, &x, 8);
        return 1;
    }
    default: return 0;
    }
}

static void ascii_value(vti *p) {
    p->tok[p->ntok] = '\0';
    p->ntok = 0;
    double d;
    if (!volux_text_to_double((volux_text){p->tok, strlen(p->tok)}, &d)) {
        fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: DataArray: '%s' is not a number", p->name, p->tok));
        return;
    }
    if (p->done + p->nbatch >= p->count) {
        fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: DataArray: more than the %zu values the extent needs",
                            p->name, p->count));
        return;
    }
    volux_scalar_type t = p->h.type;
    unsigned char *e = p->batch + p->nbatch * p->esize;
    if (t == VOLUX_FLOAT32) {
        float f = (float)d;
        memcpy(e, &f, 4);
    } else if (t == VOLUX_FLOAT64) {
        memcpy(e, &d, 8);
    } else if (!ascii_integer(d, t, e)) {
        fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: DataArray: value '%s' does not fit type %s", p->name,
                            p->tok, volux_scalar_type_name(t)));
        return;
    }
    if (++p->nbatch == VTI_ASCII_BATCH) ascii_flush(p);
}

static void ascii_push(vti *p, const char *s, size_t n) {
    for (size_t i = 0; i < n && !p->st; i++) {
        char c = s[i];
        if (c == ' ' || c == '\t' || c == '\r' || c == '\n') {
            if (p->ntok) ascii_value(p);
            continue;
        }
        if (p->ntok + 1 >= sizeof p->tok) {
            fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: DataArray: a value longer than %zu characters",
                                p->name, sizeof p->tok - 2));
            return;
        }
        p->tok[p->ntok++] = c;
    }
}

/* ------------------------------------------------------------------ */
/* XML handlers                                                        */
/* ------------------------------------------------------------------ */

static int type_from_name(const char *s, volux_scalar_type *t) {
    static const struct {
        const char *name;
        volux_scalar_type t;
    } types[] = {{"UInt8", VOLUX_UINT8},     {"Int8", VOLUX_INT8},       {"UInt16", VOLUX_UINT16},
                 {"Int16", VOLUX_INT16},     {"Float32", VOLUX_FLOAT32}, {"Float64", VOLUX_FLOAT64},
                 {"Int32", VOLUX_INT32},     {"UInt32", VOLUX_UINT32},   {"Int64", VOLUX_INT64},
                 {"UInt64", VOLUX_UINT64}};
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        if (strcmp(s, types[i].name) == 0) {
            *t = types[i].t;
            return 1;
        }
    return 0;
}

static void start_file(vti *p, const XML_Char **a) {
    volux_context *ctx = p->ctx;
    const char *type = attr(a, "type"), *order = attr(a, "byte_order"), *ht = attr(a, "header_type"),
               *comp = attr(a, "compressor");
    if (!type || strcmp(type, "ImageData") != 0) {
        fail(p, volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: VTKFile type: '%s' is not ImageData (only .vti volumes)",
                            p->name, type ? type : "(missing)"));
        return;
    }
    if (order && strcmp(order, "LittleEndian") != 0 && strcmp(order, "BigEndian") != 0) {
        fail(p, volux_error(ctx, VOLUX_ERR_FORMAT, "%s: VTKFile byte_order: '%s' (LittleEndian or BigEndian)", p->name,
                            order));
        return;
    }
    p->big_endian = order && strcmp(order, "BigEndian") == 0;
    p->header_bytes = 4;
    if (ht && strcmp(ht, "UInt64") == 0) p->header_bytes = 8;
    else if (ht && strcmp(ht, "UInt32") != 0) {
        fail(p, volux_error(ctx, VOLUX_ERR_FORMAT, "%s: VTKFile header_type: '%s' (UInt32 or UInt64)", p->name, ht));
        return;
    }
    if (comp && *comp && strcmp(comp, "vtkZLibDataCompressor") != 0) {
        fail(p, volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                            "%s: VTKFile compressor: '%s' is not supported (save with zlib or no compression)",
                            p->name, comp));
        return;
    }
    p->zlib = comp && *comp;
    p->h.big_endian = p->big_endian;
}

static void start_image(vti *p, const XML_Char **a) {
    volux_context *ctx = p->ctx;
    if (!parse_extent(attr(a, "WholeExtent"), p->extent)) {
        fail(p, volux_error(ctx, VOLUX_ERR_FORMAT, "%s: ImageData WholeExtent: missing or not six integers", p->name));
        return;
    }
    for (int i = 0; i < 3; i++) {
        int64_t n = p->extent[2 * i + 1] - p->extent[2 * i] + 1;
        if (n < 1 || n > VOLUX_MAX_DIM) {
            fail(p, volux_error(ctx, n < 1 ? VOLUX_ERR_FORMAT : VOLUX_ERR_LIMIT,
                                "%s: ImageData WholeExtent: axis %d has %lld samples, outside [1, %d]", p->name, i,
                                (long long)n, VOLUX_MAX_DIM));
            return;
        }
        p->h.dims[i] = (int)n;
    }
    double origin[3] = {0, 0, 0}, dir[9];
    const char *s;
    if ((s = attr(a, "Spacing")) && !parse_numbers(s, 3, p->h.spacing)) {
        fail(p, volux_error(ctx, VOLUX_ERR_FORMAT, "%s: ImageData Spacing: not three finite numbers", p->name));
        return;
    }
    if ((s = attr(a, "Origin")) && !parse_numbers(s, 3, origin)) {
        fail(p, volux_error(ctx, VOLUX_ERR_FORMAT, "%s: ImageData Origin: not three finite numbers", p->name));
        return;
    }
    if ((s = attr(a, "Direction"))) {
        if (!parse_numbers(s, 9, dir)) {
            fail(p, volux_error(ctx, VOLUX_ERR_FORMAT, "%s: ImageData Direction: not nine finite numbers", p->name));
            return;
        }
        for (int i = 0; i < 9; i++)
            if (fabs(dir[i] - (i % 4 == 0)) > 1e-6) {
                fail(p, volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                                    "%s: ImageData Direction: only the identity is supported (resample the image "
                                    "to axis-aligned first)",
                                    p->name));
                return;
            }
    }
    /* Node (i, j, k) of the extent lies at Origin + (i, j, k)·Spacing, so
     * our node (0, 0, 0) is the extent's first one. */
    for (int i = 0; i < 3; i++) p->h.origin[i] = origin[i] + (double)p->extent[2 * i] * p->h.spacing[i];
    p->h.has_origin = 1;
}

static void start_piece(vti *p, const XML_Char **a) {
    int64_t e[6];
    if (++p->pieces > 1) {
        fail(p, volux_error(p->ctx, VOLUX_ERR_UNSUPPORTED,
                            "%s: Piece: the file has several pieces; only single-piece .vti files are supported "
                            "(ParaView: save without splitting)",
                            p->name));
        return;
    }
    if (!parse_extent(attr(a, "Extent"), e) || memcmp(e, p->extent, sizeof e) != 0)
        fail(p, volux_error(p->ctx, VOLUX_ERR_UNSUPPORTED,
                            "%s: Piece Extent: must equal the ImageData's WholeExtent (a partial piece)", p->name));
}

/* The chosen array's start tag: checks everything about it, then
 * allocates the volume (or stops, for a header-only parse). */
static void start_array(vti *p, const XML_Char **a) {
    volux_context *ctx = p->ctx;
    const char *type = attr(a, "type"), *comps = attr(a, "NumberOfComponents"), *format = attr(a, "format"),
               *name = attr(a, "Name");
    const char *aname = name ? name : "(unnamed)";
    if (!type || !type_from_name(type, &p->h.type)) {
        fail(p, volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                            "%s: DataArray '%s' type: '%s' (supported: UInt8 Int8 UInt16 Int16 Int32 UInt32 "
                            "Int64 UInt64 Float32 Float64)",
                            p->name, aname, type ? type : "(missing)"));
        return;
    }
    if (comps && strcmp(comps, "1") != 0) {
        fail(p, volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                            "%s: DataArray '%s' NumberOfComponents: %s (volux reads scalar arrays only)", p->name,
                            aname, comps));
        return;
    }
    if (!format || (strcmp(format, "ascii") && strcmp(format, "binary") && strcmp(format, "appended"))) {
        fail(p, volux_error(ctx, VOLUX_ERR_FORMAT, "%s: DataArray '%s' format: '%s' (ascii, binary or appended)",
                            p->name, aname, format ? format : "(missing)"));
        return;
    }
    p->format = format[0] == 'a' && format[1] == 's' ? FMT_ASCII : format[0] == 'b' ? FMT_BINARY : FMT_APPENDED;
    if (p->format == FMT_APPENDED) {
        const char *off = attr(a, "offset");
        char *end;
        unsigned long long o = off ? strtoull(off, &end, 10) : 0;
        if (!off || end == off || *end || off[0] == '-') {
            fail(p, volux_error(ctx, VOLUX_ERR_FORMAT, "%s: DataArray '%s' offset: missing or not a whole number",
                                p->name, aname));
            return;
        }
        p->offset = o;
    }
    volux_status st = volux_volume_header_check(ctx, p->name, &p->h);
    if (st) {
        fail(p, st);
        return;
    }
    p->found = 1;
    p->esize = volux_scalar_type_size(p->h.type);
    p->count = (size_t)p->h.dims[0] * (size_t)p->h.dims[1] * (size_t)p->h.dims[2];
    if (p->header_only) {
        p->stopped = 1;
        XML_StopParser(p->xp, XML_FALSE);
        return;
    }
    /* A file too short to hold the array is refused before the volume is
     * allocated: ascii needs a character per value, uncompressed binary
     * its bytes, zlib data at least 1/1032 of them. */
    uint64_t need = (uint64_t)p->count * p->esize, size = p->src->size;
    int short_file = p->format == FMT_ASCII ? size < p->count
                     : p->zlib              ? size < UINT64_MAX / 1032 && size * 1032 + 4096 < need
                                            : size < need;
    if (short_file) {
        fail(p, volux_error(ctx, VOLUX_ERR_FORMAT,
                            "%s: data is truncated: the file (%llu bytes) cannot hold %dx%dx%d %s values", p->name,
                            (unsigned long long)size, p->h.dims[0], p->h.dims[1], p->h.dims[2],
                            volux_scalar_type_name(p->h.type)));
        return;
    }
    if ((st = volux_volume_create_storage(ctx, p->h.dims, p->h.spacing, p->h.type, &p->v))) {
        volux_error_prefix(ctx, "%s: ", p->name);
        fail(p, st);
        return;
    }
    if (p->format == FMT_ASCII && !(p->batch = volux_malloc(ctx, VTI_ASCII_BATCH * p->esize))) {
        fail(p, volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory", p->name));
        return;
    }
    p->in_array = p->format != FMT_APPENDED;
    p->ints_needed = p->zlib ? 3 : 1;
}

static void XMLCALL on_start(void *user, const XML_Char *el, const XML_Char **a) {
    vti *p = user;
    int d = ++p->depth;
    if (p->st) return;
    if (d == 1) {
        if (strcmp(el, "VTKFile") != 0) {
            fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: root element <%s>: not a VTK XML file", p->name, el));
            return;
        }
        start_file(p, a);
    } else if (d == 2 && strcmp(el, "ImageData") == 0) {
        p->image_depth = d;
        start_image(p, a);
    } else if (d == 2 && strcmp(el, "AppendedData") == 0) {
        const char *enc = attr(a, "encoding");
        if (!enc || (strcmp(enc, "raw") && strcmp(enc, "base64"))) {
            fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: AppendedData encoding: '%s' (raw or base64)", p->name,
                                enc ? enc : "(missing)"));
            return;
        }
        p->appended_base64 = strcmp(enc, "base64") == 0;
        /* The rest of the file is not XML: we read it ourselves, from the
         * '_' that follows the start tag. */
        p->appended_start = (uint64_t)XML_GetCurrentByteIndex(p->xp) + (uint64_t)XML_GetCurrentByteCount(p->xp);
        p->appended_seen = 1;
        p->stopped = 1;
        XML_StopParser(p->xp, XML_FALSE);
    } else if (d == 3 && p->image_depth == 2 && strcmp(el, "Piece") == 0) {
        p->piece_depth = d;
        start_piece(p, a);
    } else if (d == 4 && p->piece_depth == 3 && strcmp(el, "PointData") == 0) {
        p->point_depth = d;
        const char *s = attr(a, "Scalars");
        if (s && strlen(s) < sizeof p->scalars) strcpy(p->scalars, s);
        else if (s)
            fail(p, volux_error(p->ctx, VOLUX_ERR_LIMIT, "%s: PointData Scalars: name longer than %zu bytes", p->name,
                                sizeof p->scalars - 1));
    } else if (d == 5 && p->point_depth == 4 && strcmp(el, "DataArray") == 0 && !p->found) {
        const char *name = attr(a, "Name");
        int first = p->arrays_seen++ == 0;
        if (p->scalars[0] ? name && strcmp(name, p->scalars) == 0 : first) {
            p->array_depth = d;
            start_array(p, a);
        }
    }
}

static void XMLCALL on_end(void *user, const XML_Char *el) {
    vti *p = user;
    (void)el;
    int d = p->depth--;
    if (p->st) return;
    if (d == p->array_depth && p->in_array) {
        p->in_array = 0;
        if (p->format == FMT_ASCII) {
            if (p->ntok) ascii_value(p);
            if (!p->st) ascii_flush(p);
            if (!p->st && p->done != p->count)
                fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: DataArray: %zu values, the extent needs %zu",
                                    p->name, p->done, p->count));
        } else if (p->ngroup || p->frame != FRAME_DONE) {
            fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: DataArray: data is truncated (%zu of %zu values)",
                                p->name, p->done, p->count));
        }
    }
    if (d == p->point_depth) p->point_depth = 0;
    if (d == p->piece_depth) p->piece_depth = 0;
    if (d == p->image_depth) p->image_depth = 0;
}

static void XMLCALL on_text(void *user, const XML_Char *s, int len) {
    vti *p = user;
    if (p->st || !p->in_array || len <= 0) return;
    if (p->format == FMT_ASCII) ascii_push(p, s, (size_t)len);
    else b64_push(p, (const unsigned char *)s, (size_t)len);
}

/* A document type declaration could declare entities; VTK never writes
 * one, so none is accepted. */
static void XMLCALL on_doctype(void *user, const XML_Char *name, const XML_Char *sysid, const XML_Char *pubid,
                               int has_internal) {
    vti *p = user;
    (void)name, (void)sysid, (void)pubid, (void)has_internal;
    fail(p, volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: a DOCTYPE is not allowed in a .vti file", p->name));
}

/* ------------------------------------------------------------------ */
/* Driving the parse                                                   */
/* ------------------------------------------------------------------ */

static volux_status xml_error(vti *p) {
    enum XML_Error e = XML_GetErrorCode(p->xp);
    return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: XML error at line %lu: %s", p->name,
                       (unsigned long)XML_GetCurrentLineNumber(p->xp), XML_ErrorString(e));
}

/* Runs expat over the source until the end, an error, or a deliberate
 * stop (the chosen array for header-only parses, <AppendedData>). */
static volux_status parse_xml(vti *p, unsigned char *buf) {
    uint64_t off = 0;
    for (;;) {
        size_t got;
        volux_status st = volux_source_read(p->ctx, p->src, off, buf, VTI_CHUNK, &got);
        if (st) return st;
        off += got;
        int final = off >= p->src->size;
        p->parsing = 1;
        enum XML_Status xs = XML_Parse(p->xp, (const char *)buf, (int)got, final);
        p->parsing = 0;
        if (xs != XML_STATUS_OK) {
            if (p->st) return p->st;
            if (p->stopped) return VOLUX_OK;
            return xml_error(p);
        }
        if (p->st) return p->st;
        if (p->stopped) return VOLUX_OK; /* a stop from the last handler of the buffer */
        if (final) return VOLUX_OK;
    }
}

/* Reads the chosen array from the appended section. */
static volux_status read_appended(vti *p, unsigned char *buf) {
    volux_context *ctx = p->ctx;
    /* White space, then the '_' that marks the start of the data. */
    uint64_t pos = p->appended_start;
    for (;;) {
        size_t got;
        volux_status st = volux_source_read(ctx, p->src, pos, buf, 1, &got);
        if (st) return st;
        if (!got || (buf[0] != ' ' && buf[0] != '\t' && buf[0] != '\r' && buf[0] != '\n' && buf[0] != '_') ||
            pos - p->appended_start > 4096)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: AppendedData: the data must start with '_'", p->name);
        pos++;
        if (buf[0] == '_') break;
    }
    if (p->offset > p->src->size - pos)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: DataArray offset: %llu is past the end of the file", p->name,
                           (unsigned long long)p->offset);
    pos += p->offset;
    while (!p->st && p->frame != FRAME_DONE) {
        size_t got;
        volux_status st = volux_source_read(ctx, p->src, pos, buf, VTI_CHUNK, &got);
        if (st) return st;
        if (!got)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: AppendedData: data is truncated (%zu of %zu values)",
                               p->name, p->done, p->count);
        pos += got;
        if (p->appended_base64) {
            b64_push(p, buf, got);
            continue;
        }
        /* raw: feed the framing no more than it still wants (one header
         * integer, the rest of the data or of a block), since the next
         * array's bytes follow ours directly */
        size_t at = 0;
        while (at < got && !p->st && p->frame != FRAME_DONE) {
            size_t step = got - at;
            uint64_t want = p->frame == FRAME_HEAD  ? (uint64_t)p->header_bytes - p->nhead
                            : p->frame == FRAME_RAW ? p->raw_left
                                                    : p->in_left;
            if (want < step) step = (size_t)want;
            frame_push(p, buf + at, step);
            at += step;
        }
    }
    return p->st;
}

static void vti_cleanup(vti *p, unsigned char *buf) {
    if (p->xp) XML_ParserFree(p->xp);
    if (p->z_live) inflateEnd(&p->z);
    volux_free(p->ctx, p->csize, (size_t)p->nblocks * sizeof *p->csize);
    volux_free(p->ctx, p->batch, VTI_ASCII_BATCH * p->esize);
    volux_free(p->ctx, p->out, VTI_CHUNK);
    volux_free(p->ctx, buf, VTI_CHUNK);
}

static volux_status vti_run(volux_context *ctx, volux_source *src, int header_only, vti *p, unsigned char **buf) {
    memset(p, 0, sizeof *p);
    p->ctx = ctx;
    p->name = src->name;
    p->src = src;
    p->header_only = header_only;
    volux_volume_header_init(&p->h);
    *buf = volux_malloc(ctx, VTI_CHUNK);
    p->out = header_only ? NULL : volux_malloc(ctx, VTI_CHUNK);
    if (!*buf || (!header_only && !p->out))
        return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for a read buffer", p->name);
    if (!header_only) {
        if (inflateInit(&p->z) != Z_OK) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: zlib init failed", p->name);
        p->z_live = 1;
    }
    if (!(p->xp = XML_ParserCreate(NULL)))
        return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for the XML parser", p->name);
    XML_SetUserData(p->xp, p);
    XML_SetElementHandler(p->xp, on_start, on_end);
    XML_SetCharacterDataHandler(p->xp, on_text);
    XML_SetStartDoctypeDeclHandler(p->xp, on_doctype);
    volux_status st = parse_xml(p, *buf);
    if (st) return st;
    if (!p->found) {
        if (p->scalars[0])
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: PointData Scalars: no DataArray named '%s'", p->name,
                               p->scalars);
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: no point data: the file has no <ImageData><Piece><PointData><DataArray>", p->name);
    }
    if (header_only) return VOLUX_OK;
    if (p->format == FMT_APPENDED) {
        if (!p->appended_seen)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: DataArray format 'appended' but no <AppendedData>",
                               p->name);
        if ((st = read_appended(p, *buf))) return st;
        if (p->ngroup)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: AppendedData: invalid base64 text (a partial group)",
                               p->name);
    }
    if (p->done != p->count)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: data is truncated (%zu of %zu values)", p->name, p->done,
                           p->count);
    return VOLUX_OK;
}

volux_status volux_vti_parse_header(volux_context *ctx, volux_source *src, volux_volume_header *out) {
    vti p;
    unsigned char *buf = NULL;
    volux_status st = vti_run(ctx, src, 1, &p, &buf);
    if (!st) *out = p.h;
    vti_cleanup(&p, buf);
    return st;
}

volux_status volux_vti_read(volux_context *ctx, volux_source *src, const volux_volume_load_options *options,
                            volux_volume **out) {
    vti p;
    unsigned char *buf = NULL;
    volux_status st = vti_run(ctx, src, 0, &p, &buf);
    vti_cleanup(&p, buf);
    if (!st) st = volux_volume_read_finish(ctx, &p.h, src->name, options, p.v);
    if (st) {
        volux_volume_release(p.v);
        return st;
    }
    *out = p.v;
    return VOLUX_OK;
}
