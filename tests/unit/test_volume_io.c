/*
 * tests/unit/test_volume_io.c — every volume reader on valid files written
 * by the test: each scalar type, both byte orders, raw and compressed,
 * attached and detached; exact values, spacing and origin.
 */
#include <ctype.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/volume_formats.h"
#include "tu_volume.h"

#define NX 4
#define NY 3
#define NZ 2
#define N (NX * NY * NZ)

static const volux_scalar_type all_types[] = {VOLUX_UINT8,   VOLUX_INT8,  VOLUX_UINT16, VOLUX_INT16, VOLUX_FLOAT32,
                                              VOLUX_FLOAT64, VOLUX_INT32, VOLUX_UINT32, VOLUX_INT64, VOLUX_UINT64};

/* Values that use the whole range of each type (and are exact in float;
 * the wide integers on float32's grid near the ends of their range, plus
 * one small odd value to catch a byte-order slip). */
static void make_values(volux_scalar_type t, double *v) {
    for (int i = 0; i < N; i++) {
        switch (t) {
        case VOLUX_UINT8: v[i] = (i * 37) % 256; break;
        case VOLUX_INT8: v[i] = (i * 37) % 256 - 128; break;
        case VOLUX_UINT16: v[i] = (i * 2731) % 65536; break;
        case VOLUX_INT16: v[i] = (i * 2731) % 65536 - 32768; break;
        case VOLUX_FLOAT32: v[i] = i * 0.25 - 3.5; break;
        case VOLUX_FLOAT64: v[i] = i * 1e3 - 7.25; break;
        case VOLUX_INT32: v[i] = i == 1 ? 12345 : ((i * 2731) % 65536 - 32768) * 65536.0; break;
        case VOLUX_UINT32: v[i] = i == 1 ? 12345 : ((i * 2731) % 65536) * 65536.0; break;
        case VOLUX_INT64: v[i] = i == 1 ? -12345 : ((i * 2731) % 65536 - 32768) * 281474976710656.0; break;
        case VOLUX_UINT64: v[i] = i == 1 ? 12345 : ((i * 2731) % 65536) * 281474976710656.0; break;
        }
    }
}

static volux_volume *load_ok(volux_context *ctx, const char *path, const volux_volume_load_options *o) {
    volux_volume *v = NULL;
    volux_status st = volux_volume_load(ctx, path, o, &v);
    if (st != VOLUX_OK) fail_msg("loading %s failed: %s", path, volux_context_error(ctx));
    return v;
}

static void assert_values(const volux_volume *v, const double *expect) {
    int d[3];
    volux_volume_dims(v, d);
    assert_int_equal(d[0], NX);
    assert_int_equal(d[1], NY);
    assert_int_equal(d[2], NZ);
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                double want = expect[(k * NY + j) * NX + i];
                float got = volux_volume_value_at(v, i, j, k);
                if ((double)got != (double)(float)want)
                    fail_msg("value at (%d,%d,%d) = %.9g, expected %.9g", i, j, k, got, want);
            }
}

/* ------------------------------------------------------------------ NRRD */

static const char *nrrd_type(volux_scalar_type t) {
    static const char *names[] = {"uint8", "int8", "uint16", "int16", "float",
                                  "double", "int", "unsigned int", "int64", "ulonglong"};
    return names[t];
}

static void test_nrrd_every_type_endian_encoding_layout(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    for (size_t t = 0; t < sizeof all_types / sizeof all_types[0]; t++)
        for (int big = 0; big < 2; big++)
            for (int gz = 0; gz < 2; gz++)
                for (int detached = 0; detached < 2; detached++) {
                    volux_scalar_type type = all_types[t];
                    double values[N];
                    unsigned char raw[N * 8];
                    make_values(type, values);
                    size_t n = tu_encode(type, big, values, N, raw), zn = n;
                    unsigned char *z = gz ? tu_deflate(raw, n, 1, &zn) : NULL;
                    const void *data = gz ? (const void *)z : raw;
                    char header[512], dataname[64];
                    snprintf(dataname, sizeof dataname, "nrrd_%zu_%d_%d.%s", t, big, gz, gz ? "raw.gz" : "raw");
                    snprintf(header, sizeof header,
                             "NRRD0004\n# comment\ntype: %s\ndimension: 3\nsizes: %d %d %d\nendian: %s\n"
                             "encoding: %s\nspacings: 0.5 1 2\nkinds: domain domain domain\nfoo:=bar\n%s%s%s",
                             nrrd_type(type), NX, NY, NZ, big ? "big" : "little", gz ? "gzip" : "raw",
                             detached ? "data file: " : "", detached ? dataname : "", detached ? "\n" : "\n");
                    const char *path;
                    if (detached) {
                        tu_write_file(dataname, data, zn);
                        path = tu_write_parts("v.nhdr", header, NULL, 0);
                    } else {
                        path = tu_write_parts("v.nrrd", header, data, zn);
                    }
                    volux_volume *v = load_ok(ctx, path, NULL);
                    assert_values(v, values);
                    assert_int_equal(volux_volume_type(v), type);
                    double s[3];
                    volux_volume_spacing(v, s);
                    assert_true(s[0] == 0.5 && s[1] == 1.0 && s[2] == 2.0);
                    volux_volume_release(v);
                    free(z);
                }
    volux_context_destroy(ctx);
}

static void test_nrrd_space_directions_and_origin(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    double values[N];
    unsigned char raw[N];
    make_values(VOLUX_UINT8, values);
    tu_encode(VOLUX_UINT8, 0, values, N, raw);
    /* 4-D with a size-1 first axis (one component per voxel); rotated
     * directions keep their lengths as spacing. */
    const char *path = tu_write_parts("dirs.nrrd",
                                      "NRRD0005\ntype: uchar\ndimension: 4\nspace: right-anterior-superior\n"
                                      "sizes: 1 4 3 2\nspace directions: none (0,0.5,0) (2, 0, 0) (0,0,-3)\n"
                                      "space origin: (10,-20,30.5)\nencoding: raw\n\n",
                                      raw, N);
    volux_volume_load_options o = {0};
    o.use_file_origin = 1;
    volux_volume *v = load_ok(ctx, path, &o);
    assert_values(v, values);
    double s[3];
    volux_volume_spacing(v, s);
    assert_near(s[0], 0.5, 0);
    assert_near(s[1], 2.0, 0);
    assert_near(s[2], 3.0, 0);
    volux_vec3 org = volux_volume_origin(v);
    assert_near(org.x, 10.0, 0);
    assert_near(org.y, -20.0, 0);
    assert_near(org.z, 30.5, 0);
    volux_volume_release(v);

    /* Without use_file_origin the volume is centred (DESIGN §2). */
    v = load_ok(ctx, path, NULL);
    org = volux_volume_origin(v);
    assert_near(org.x, -(NX - 1) * 0.5 / 2, 1e-6);
    assert_near(org.y, -(NY - 1) * 2.0 / 2, 1e-6);
    assert_near(org.z, -(NZ - 1) * 3.0 / 2, 1e-6);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_nrrd_skips(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    double values[N];
    unsigned char raw[N * 2], file[200 + N * 2];
    make_values(VOLUX_UINT16, values);
    size_t n = tu_encode(VOLUX_UINT16, 1, values, N, raw);

    /* line skip 2, then byte skip 3, then data */
    size_t off = 0;
    memcpy(file, "junk line\nmore\nABC", 18);
    off = 18;
    memcpy(file + off, raw, n);
    tu_write_file("skip.raw", file, off + n);
    char h[256];
    snprintf(h, sizeof h,
             "NRRD0004\ntype: ushort\ndimension: 3\nsizes: %d %d %d\nendian: big\nencoding: raw\n"
             "line skip: 2\nbyte skip: 3\ndata file: skip.raw\n",
             NX, NY, NZ);
    volux_volume *v = load_ok(ctx, tu_write_parts("skip.nhdr", h, NULL, 0), NULL);
    assert_values(v, values);
    volux_volume_release(v);

    /* byte skip -1: the data is whatever ends the file */
    snprintf(h, sizeof h,
             "NRRD0004\ntype: ushort\ndimension: 3\nsizes: %d %d %d\nendian: big\nencoding: raw\n"
             "byte skip: -1\ndata file: skip.raw\n",
             NX, NY, NZ);
    v = load_ok(ctx, tu_write_parts("end.nhdr", h, NULL, 0), NULL);
    assert_values(v, values);
    volux_volume_release(v);

    /* gzip: byte skip counts decoded bytes */
    size_t zn;
    unsigned char *z = tu_deflate(file + 15, 3 + n, 1, &zn);
    snprintf(h, sizeof h,
             "NRRD0004\ntype: ushort\ndimension: 3\nsizes: %d %d %d\nendian: big\nencoding: gz\n"
             "byte skip: 3\n\n",
             NX, NY, NZ);
    v = load_ok(ctx, tu_write_parts("skipgz.nrrd", h, z, zn), NULL);
    assert_values(v, values);
    volux_volume_release(v);
    free(z);
    volux_context_destroy(ctx);
}

static void test_nrrd_detached_in_subfolder_and_outside_when_allowed(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    double values[N];
    unsigned char raw[N];
    make_values(VOLUX_UINT8, values);
    tu_encode(VOLUX_UINT8, 0, values, N, raw);
    char dir[600];
    snprintf(dir, sizeof dir, "mkdir -p %s %s", tu_temp_path("sub"), tu_temp_path("hdrs"));
    assert_int_equal(system(dir), 0);
    tu_write_file("sub/d.raw", raw, N);
    char h[256];
    snprintf(h, sizeof h, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: %d %d %d\nencoding: raw\ndata file: sub/d.raw\n",
             NX, NY, NZ);
    volux_volume *v = load_ok(ctx, tu_write_parts("in.nhdr", h, NULL, 0), NULL);
    assert_values(v, values);
    volux_volume_release(v);

    snprintf(h, sizeof h, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: %d %d %d\nencoding: raw\ndata file: ../sub/d.raw\n",
             NX, NY, NZ);
    const char *path = tu_write_parts("hdrs/out.nhdr", h, NULL, 0);
    volux_volume_load_options o = {0};
    o.allow_outside_dir = 1;
    v = load_ok(ctx, path, &o);
    assert_values(v, values);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_nrrd_parse_from_memory(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char text[] = "NRRD0004\r\ntype: short\r\ndimension: 3\r\nsizes: 5 6 7\r\nendian: big\r\n"
                        "encoding: gzip\r\nspacings: nan -2 3\r\nbyte skip: 4\r\n\r\nBINARY";
    volux_volume_header h;
    assert_int_equal(volux_nrrd_parse_header(ctx, text, sizeof text - 1, "mem.nrrd", &h), VOLUX_OK);
    assert_int_equal(h.dims[0], 5);
    assert_int_equal(h.dims[2], 7);
    assert_int_equal(h.type, VOLUX_INT16);
    assert_int_equal(h.big_endian, 1);
    assert_int_equal(h.encoding, VOLUX_ENCODING_ZLIB);
    assert_near(h.spacing[0], 1.0, 0); /* NaN = unknown */
    assert_near(h.spacing[1], 2.0, 0);
    assert_int_equal(h.byte_skip, 4);
    assert_int_equal(h.data_offset, strstr(text, "BINARY") - text);
    assert_string_equal(h.data_file, "");
    volux_context_destroy(ctx);
}

/* A decimal-comma LC_NUMERIC (Qt applications set the user's locale at
 * start-up) must not change how header numbers parse. The locale is
 * compiled into a temporary directory with localedef (glibc reads LOCPATH
 * at each setlocale); skipped where the de_DE sources are not installed. */
static void test_header_numbers_ignore_a_decimal_comma_locale(void **state) {
    (void)state;
    char dir[] = "/tmp/volux_locale_XXXXXX", cmd[256];
    if (!mkdtemp(dir)) skip();
    snprintf(cmd, sizeof cmd, "localedef -i de_DE -f UTF-8 %s/de_DE.UTF-8 >/dev/null 2>&1", dir);
    int built = system(cmd) == 0;
    setenv("LOCPATH", dir, 1);
    int comma = built && setlocale(LC_NUMERIC, "de_DE.UTF-8") && localeconv()->decimal_point[0] == ',';
    if (!comma) {
        setlocale(LC_NUMERIC, "C");
        unsetenv("LOCPATH");
        snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
        if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", dir);
        fprintf(stderr, "  (no de_DE locale could be built: skipped)\n");
        skip();
    }
    volux_context *ctx = tu_context(1);
    const char nrrd[] = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
                        "spacings: 0.5 1.25 2.5e-1\n\n";
    const char mhd[] = "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
                       "ElementSpacing = 0.5 1.25 2.5e-1\nElementDataFile = LOCAL\n";
    const char vti[] = "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"0 1 0 1 0 1\" "
                       "Spacing=\"0.5 1.25 2.5e-1\"><Piece Extent=\"0 1 0 1 0 1\"><PointData>"
                       "<DataArray type=\"UInt8\" format=\"ascii\">0 1 2 3 4 5 6 7</DataArray>"
                       "</PointData></Piece></ImageData></VTKFile>";
    volux_source vti_src;
    volux_source_memory(vti, sizeof vti - 1, "mem.vti", &vti_src);
    volux_volume_header h[3];
    volux_status st[3] = {volux_nrrd_parse_header(ctx, nrrd, sizeof nrrd - 1, "mem.nrrd", &h[0]),
                          volux_metaimage_parse_header(ctx, mhd, sizeof mhd - 1, "mem.mhd", &h[1]),
                          volux_vti_parse_header(ctx, &vti_src, &h[2])};
    setlocale(LC_NUMERIC, "C");
    unsetenv("LOCPATH");
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", dir);
    for (int i = 0; i < 3; i++) {
        assert_int_equal(st[i], VOLUX_OK);
        assert_near(h[i].spacing[0], 0.5, 0);
        assert_near(h[i].spacing[1], 1.25, 0);
        assert_near(h[i].spacing[2], 0.25, 0);
    }
    volux_context_destroy(ctx);
}

static void test_load_memory_attached(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    double values[N];
    unsigned char file[256];
    make_values(VOLUX_INT8, values);
    int t = snprintf((char *)file, 128, "NRRD0004\ntype: int8\ndimension: 3\nsizes: %d %d %d\nencoding: raw\n\n", NX,
                     NY, NZ);
    tu_encode(VOLUX_INT8, 0, values, N, file + t);
    volux_volume *v;
    assert_int_equal(volux_volume_load_memory(ctx, file, (size_t)t + N, "mem.nrrd", VOLUX_FORMAT_NRRD, NULL, &v),
                     VOLUX_OK);
    assert_values(v, values);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ MetaImage */

static const char *met_type(volux_scalar_type t) {
    static const char *names[] = {"MET_UCHAR", "MET_CHAR", "MET_USHORT", "MET_SHORT",     "MET_FLOAT",
                                  "MET_DOUBLE", "MET_INT", "MET_UINT",   "MET_LONG_LONG", "MET_ULONG_LONG"};
    return names[t];
}

static void test_metaimage_every_type_endian_layout(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    for (size_t t = 0; t < sizeof all_types / sizeof all_types[0]; t++)
        for (int big = 0; big < 2; big++)
            for (int layout = 0; layout < 4; layout++) { /* mha raw, mha zlib, mhd raw + HeaderSize, mhd zlib */
                volux_scalar_type type = all_types[t];
                int zlib = layout == 1 || layout == 3, detached = layout >= 2;
                double values[N];
                unsigned char raw[N * 8 + 16];
                make_values(type, values);
                size_t n = tu_encode(type, big, values, N, raw + 16), zn = n;
                unsigned char *z = zlib ? tu_deflate(raw + 16, n, 0, &zn) : NULL;
                memset(raw, 'x', 16);
                char header[512];
                snprintf(header, sizeof header,
                         "ObjectType = Image\nNDims = 3\nDimSize = %d %d %d\nElementType = %s\n"
                         "ElementSpacing = 0.25 0.5 4\nOffset = 1 2 -3\n%s = %s\nCompressedData = %s\n"
                         "AnatomicalOrientation = RAI\n%sElementDataFile = %s\n",
                         NX, NY, NZ, met_type(type), t % 2 ? "BinaryDataByteOrderMSB" : "ElementByteOrderMSB",
                         big ? "True" : "False", zlib ? "True" : "False",
                         detached && !zlib ? "HeaderSize = 16\n" : "", detached ? "mi.raw" : "LOCAL");
                const char *path;
                if (detached) {
                    if (zlib) tu_write_file("mi.raw", z, zn);
                    else tu_write_file("mi.raw", raw, 16 + n);
                    path = tu_write_parts("v.mhd", header, NULL, 0);
                } else {
                    path = tu_write_parts("v.mha", header, zlib ? z : raw + 16, zn);
                }
                volux_volume_load_options o = {0};
                o.use_file_origin = 1;
                volux_volume *v = load_ok(ctx, path, &o);
                assert_values(v, values);
                double s[3];
                volux_volume_spacing(v, s);
                assert_true(s[0] == 0.25 && s[1] == 0.5 && s[2] == 4.0);
                volux_vec3 org = volux_volume_origin(v);
                assert_true(org.x == 1.0f && org.y == 2.0f && org.z == -3.0f);
                volux_volume_release(v);
                free(z);
            }
    volux_context_destroy(ctx);
}

static void test_metaimage_element_size_and_header_size_minus_one(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    double values[N];
    unsigned char raw[N + 7];
    make_values(VOLUX_UINT8, values);
    memset(raw, 0xee, 7);
    tu_encode(VOLUX_UINT8, 0, values, N, raw + 7);
    tu_write_file("tail.raw", raw, sizeof raw);
    char header[256];
    snprintf(header, sizeof header,
             "NDims = 3\nDimSize = %d %d %d\nElementType = MET_UCHAR\nElementSize = 3 3 3\nHeaderSize = -1\n"
             "ElementDataFile = tail.raw\n",
             NX, NY, NZ);
    volux_volume *v = load_ok(ctx, tu_write_parts("tail.mhd", header, NULL, 0), NULL);
    assert_values(v, values);
    double s[3];
    volux_volume_spacing(v, s);
    assert_true(s[0] == 3.0 && s[2] == 3.0);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ NIfTI */

static int nifti_code(volux_scalar_type t) {
    static const int codes[] = {2, 256, 512, 4, 16, 64, 8, 768, 1024, 1280};
    return codes[t];
}

static void test_nifti_every_type_endian_layout(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    static const int dims[3] = {NX, NY, NZ};
    for (size_t t = 0; t < sizeof all_types / sizeof all_types[0]; t++)
        for (int big = 0; big < 2; big++)
            for (int layout = 0; layout < 3; layout++) { /* .nii, .nii.gz, .hdr + .img */
                volux_scalar_type type = all_types[t];
                double values[N];
                unsigned char file[352 + N * 8];
                make_values(type, values);
                tu_nifti_header(file, big, dims, nifti_code(type), (int)volux_scalar_type_size(type) * 8);
                tu_put_f32(file, 80, -0.5f, big); /* pixdim[1] negative: a flip, spacing 0.5 */
                tu_put_f32(file, 84, 2.0f, big);
                tu_put_f32(file, 88, 3.0f, big);
                tu_put_i16(file, 252, 1, big); /* qform_code */
                tu_put_f32(file, 268, -7.0f, big);
                tu_put_f32(file, 272, 8.0f, big);
                tu_put_f32(file, 276, 9.5f, big);
                size_t n = tu_encode(type, big, values, N, file + 352);
                const char *path;
                if (layout == 0) {
                    path = tu_write_file("v.nii", file, 352 + n);
                } else if (layout == 1) {
                    size_t zn;
                    unsigned char *z = tu_deflate(file, 352 + n, 1, &zn);
                    path = tu_write_file("v.nii.gz", z, zn);
                    free(z);
                } else {
                    memcpy(file + 344, "ni1", 4);
                    tu_put_f32(file, 108, 0.0f, big);
                    tu_write_file("pair.img", file + 352, n);
                    path = tu_write_file("pair.hdr", file, 348);
                }
                volux_volume_load_options o = {0};
                o.use_file_origin = 1;
                volux_volume *v = load_ok(ctx, path, &o);
                assert_values(v, values);
                double s[3];
                volux_volume_spacing(v, s);
                assert_true(s[0] == 0.5 && s[1] == 2.0 && s[2] == 3.0);
                volux_vec3 org = volux_volume_origin(v);
                assert_true(org.x == -7.0f && org.y == 8.0f && org.z == 9.5f);
                volux_volume_release(v);
            }
    volux_context_destroy(ctx);
}

static void test_nifti_scaling_gives_float32(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    static const int dims[3] = {NX, NY, NZ};
    for (int big = 0; big < 2; big++) {
        double values[N], scaled[N];
        unsigned char file[352 + N * 2];
        make_values(VOLUX_INT16, values);
        for (int i = 0; i < N; i++) scaled[i] = (float)(0.5 * values[i] - 100.0);
        tu_nifti_header(file, big, dims, 4, 16);
        tu_put_i16(file, 40, 4, big); /* dim[0] = 4 with dim[4] = 1 */
        tu_put_f32(file, 112, 0.5f, big);
        tu_put_f32(file, 116, -100.0f, big);
        tu_encode(VOLUX_INT16, big, values, N, file + 352);
        volux_volume *v = load_ok(ctx, tu_write_file("scaled.nii", file, sizeof file), NULL);
        assert_int_equal(volux_volume_storage_kind(v), VOLUX_STORE_F32);
        assert_int_equal(volux_volume_type(v), VOLUX_FLOAT32);
        assert_values(v, scaled);
        volux_volume_release(v);
    }
    /* (slope, inter) = (1, 0) is "no scaling": storage stays integer. */
    unsigned char file[352 + N];
    tu_nifti_header(file, 0, dims, 2, 8);
    tu_put_f32(file, 112, 1.0f, 0);
    memset(file + 352, 7, N);
    volux_volume *v = load_ok(ctx, tu_write_file("unscaled.nii", file, sizeof file), NULL);
    assert_int_equal(volux_volume_storage_kind(v), VOLUX_STORE_U8);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ raw */

static void test_raw_with_description(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    for (size_t t = 0; t < sizeof all_types / sizeof all_types[0]; t++)
        for (int big = 0; big < 2; big++) {
            double values[N];
            unsigned char file[5 + N * 8];
            make_values(all_types[t], values);
            memcpy(file, "HEAD!", 5);
            size_t n = tu_encode(all_types[t], big, values, N, file + 5);
            const char *path = tu_write_file("v.bin", file, 5 + n);
            volux_raw_desc d = {{NX, NY, NZ}, all_types[t], big, {1.5, 0, 2}, 5};
            volux_volume_load_options o = {0};
            o.raw = &d;
            volux_volume *v = load_ok(ctx, path, &o);
            assert_values(v, values);
            double s[3];
            volux_volume_spacing(v, s);
            assert_true(s[0] == 1.5 && s[1] == 1.0 && s[2] == 2.0);
            volux_volume_release(v);
        }
    volux_context_destroy(ctx);
}

static void test_unknown_extension_is_sniffed(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    unsigned char data[N] = {0};
    char h[256];
    snprintf(h, sizeof h, "NRRD0001\ntype: uint8\ndimension: 3\nsizes: %d %d %d\nencoding: raw\n\n", NX, NY, NZ);
    volux_volume *v = load_ok(ctx, tu_write_parts("volume.dat", h, data, N), NULL);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* Every extension the help texts list is one the loader recognises, and
 * the ones it must not claim (raw needs a description; scenes) are not. */
static void test_known_extensions_match_the_listed_ones(void **state) {
    (void)state;
    char list[] = VOLUX_VOLUME_EXTENSIONS, name[64];
    int n = 0;
    /* the list ends in words ("or a DICOM folder"): only the extensions */
    for (char *ext = strtok(list, " "); ext && ext[0] == '.'; ext = strtok(NULL, " "), n++) {
        snprintf(name, sizeof name, "dir/ct%s", ext);
        assert_true(volux_volume_path_is_known(name));
        for (char *c = name; *c; c++) *c = (char)toupper((unsigned char)*c);
        assert_true(volux_volume_path_is_known(name));
    }
    assert_int_equal(n, 9);
    assert_false(volux_volume_path_is_known("ct.raw"));
    assert_false(volux_volume_path_is_known("scene.json"));
    assert_false(volux_volume_path_is_known("ct.gz"));
    assert_false(volux_volume_path_is_known(NULL));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nrrd_every_type_endian_encoding_layout),
        cmocka_unit_test(test_nrrd_space_directions_and_origin),
        cmocka_unit_test(test_nrrd_skips),
        cmocka_unit_test(test_nrrd_detached_in_subfolder_and_outside_when_allowed),
        cmocka_unit_test(test_nrrd_parse_from_memory),
        cmocka_unit_test(test_load_memory_attached),
        cmocka_unit_test(test_header_numbers_ignore_a_decimal_comma_locale),
        cmocka_unit_test(test_metaimage_every_type_endian_layout),
        cmocka_unit_test(test_metaimage_element_size_and_header_size_minus_one),
        cmocka_unit_test(test_nifti_every_type_endian_layout),
        cmocka_unit_test(test_nifti_scaling_gives_float32),
        cmocka_unit_test(test_raw_with_description),
        cmocka_unit_test(test_unknown_extension_is_sniffed),
        cmocka_unit_test(test_known_extensions_match_the_listed_ones),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
