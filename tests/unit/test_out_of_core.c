/*
 * tests/unit/test_out_of_core.c — volux_context_set_out_of_core: a file
 * whose data is stored as the volume stores it is mapped, not read, and
 * gives the same volume (values, range, macrocells, bricked copy, image) as
 * the ordinary loader; any other file is read with a warning; the sweeps
 * over a mapped volume leave its pages dropped behind them (resident set
 * bounded by a window, not by the file).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/volume_internal.h"
#include "io/volume_formats.h"
#include "tu_volume.h"

/* Not multiples of the 8-cell bricks nor of a page: every border case of
 * the mapping offset and of the bricked copy's apron. */
#define NX 37
#define NY 29
#define NZ 23
#define N (NX * NY * NZ)

static void make_values(volux_scalar_type t, double *v) {
    for (int i = 0; i < N; i++) {
        unsigned h = (unsigned)i * 2654435761u;
        switch (t) {
        case VOLUX_UINT8: v[i] = (h >> 24) & 255; break;
        case VOLUX_INT16: v[i] = (double)((h >> 16) & 65535) - 32768.0; break;
        case VOLUX_UINT16: v[i] = (h >> 16) & 65535; break;
        default: v[i] = ((double)(h >> 8) / 16777216.0 - 0.5) * 1000.0; break; /* exact in float */
        }
    }
}

/* Everything a technique reads of the volume must agree. */
static void assert_same_volume(volux_volume *a, volux_volume *b) {
    assert_int_equal(a->storage, b->storage);
    assert_int_equal(a->data_bytes, b->data_bytes);
    assert_memory_equal(a->data, b->data, a->data_bytes);
    assert_true(a->vmin == b->vmin && a->vmax == b->vmax);
    assert_true(a->origin.x == b->origin.x && a->origin.y == b->origin.y && a->origin.z == b->origin.z);
    assert_int_equal(a->cell_bytes, b->cell_bytes);
    assert_memory_equal(a->cell_min, b->cell_min, a->cell_bytes);
    assert_memory_equal(a->cell_max, b->cell_max, a->cell_bytes);
    assert_int_equal(volux_volume_build_bricks(a), VOLUX_OK);
    assert_int_equal(volux_volume_build_bricks(b), VOLUX_OK);
    assert_int_equal(a->brick_bytes, b->brick_bytes);
    assert_memory_equal(a->bricks, b->bricks, a->brick_bytes);
}

typedef struct loaded {
    volux_volume *v;
    int warnings;
    char warning[512];
} loaded;

static loaded load(const char *path, int out_of_core, const volux_volume_load_options *o) {
    tu_messages m = {0};
    volux_context *ctx = tu_context(2);
    volux_context_set_message(ctx, tu_collect_messages, &m);
    volux_context_set_out_of_core(ctx, out_of_core);
    loaded r = {0};
    if (volux_volume_load(ctx, path, o, &r.v)) fail_msg("loading %s: %s", path, volux_context_error(ctx));
    r.warnings = m.warnings;
    snprintf(r.warning, sizeof r.warning, "%s", m.last);
    /* the volume keeps its context: destroyed with the volume below */
    return r;
}

static void release(loaded *l) {
    volux_context *ctx = l->v->ctx;
    volux_volume_release(l->v);
    volux_context_destroy(ctx);
}

/* Loads `path` both ways and compares; `mapped` says whether the
 * out-of-core load must have mapped it (else: read, with a warning naming
 * `why`). */
static void compare(const char *path, int mapped, const char *why) {
    loaded a = load(path, 0, NULL), b = load(path, 1, NULL);
    assert_int_equal(a.v->mapped, 0);
    if (b.v->mapped != mapped) fail_msg("%s: mapped %d, expected %d (%s)", path, b.v->mapped, mapped, b.warning);
    if (mapped) {
        assert_int_equal(b.warnings, 0);
    } else {
        assert_int_equal(b.warnings, 1);
        if (!strstr(b.warning, "out of core") || !strstr(b.warning, why))
            fail_msg("%s: warning '%s' does not name '%s'", path, b.warning, why);
    }
    assert_same_volume(a.v, b.v);
    release(&a);
    release(&b);
}

static const char *nrrd_type(volux_scalar_type t) {
    return t == VOLUX_UINT8 ? "uint8" : t == VOLUX_UINT16 ? "uint16" : t == VOLUX_INT16 ? "int16" : "float";
}

/* NRRD: attached (the header's length decides the alignment), detached,
 * gzip, big endian, every stored type and a converted one. */
static void test_nrrd_mapped_equals_read(void **state) {
    (void)state;
    static const volux_scalar_type types[] = {VOLUX_UINT8, VOLUX_UINT16, VOLUX_FLOAT32, VOLUX_INT16};
    static double values[N];
    static unsigned char raw[N * 4];
    for (size_t t = 0; t < 4; t++)
        for (int variant = 0; variant < 6; variant++) {
            /* 0 detached, 1 attached aligned, 2 attached misaligned, 3 gzip, 4 big endian, 5 split in 2 files */
            volux_scalar_type type = types[t];
            int big = variant == 4, gz = variant == 3;
            make_values(type, values);
            size_t n = tu_encode(type, big, values, N, raw), zn = n;
            unsigned char *z = gz ? tu_deflate(raw, n, 1, &zn) : NULL;
            char header[1024];
            int len = snprintf(header, sizeof header,
                               "NRRD0004\ntype: %s\ndimension: 3\nsizes: %d %d %d\nendian: %s\nencoding: %s\n"
                               "spacings: 0.5 1 2\n",
                               nrrd_type(type), NX, NY, NZ, big ? "big" : "little", gz ? "gzip" : "raw");
            const char *path;
            if (variant == 0 || variant == 3 || variant == 4) {
                tu_write_file("ooc.raw", gz ? z : raw, zn);
                snprintf(header + len, sizeof header - (size_t)len, "data file: ooc.raw\n");
                path = tu_write_parts("ooc.nhdr", header, NULL, 0);
            } else if (variant == 5) {
                /* one file per slice, as NRRD's LIST form has it */
                len += snprintf(header + len, sizeof header - (size_t)len, "data file: LIST\n");
                for (int k = 0; k < NZ; k++) {
                    char name[32];
                    snprintf(name, sizeof name, "ooc_z%d.raw", k);
                    tu_write_file(name, raw + n / NZ * (size_t)k, n / NZ);
                    len += snprintf(header + len, sizeof header - (size_t)len, "%s\n", name);
                }
                path = tu_write_parts("ooc_split.nhdr", header, NULL, 0);
            } else {
                /* the blank line ends the header: a comment line of k
                 * bytes + 2 puts the data at a multiple of 4 (aligned) or
                 * one byte past it (misaligned) */
                int target = variant == 2 ? 1 : 0, k = ((target - len - 3) % 4 + 8) % 4;
                len += snprintf(header + len, sizeof header - (size_t)len, "#%.*s\n", k, "xxxx");
                snprintf(header + len, sizeof header - (size_t)len, "\n");
                path = tu_write_parts("ooc.nrrd", header, raw, n);
            }
            int esize = (int)volux_scalar_type_size(type);
            /* one-byte values have no byte order and no alignment */
            int mappable = type != VOLUX_INT16 && (variant == 0 || variant == 1 || ((variant == 2 || variant == 4) && esize == 1));
            /* the first reason in why_not_mapped's order */
            const char *why = variant == 3          ? "compressed"
                              : variant == 5        ? "several files"
                              : type == VOLUX_INT16 ? "only uint8, uint16 and float32"
                              : variant == 4        ? "byte order"
                              : variant == 2        ? "multiple of its element size"
                                                    : "";
            compare(path, mappable, why);
            free(z);
        }
}

/* NIfTI (vox_offset 352), MetaImage (detached raw) and a described raw
 * file: the mapped path of each reader. */
static void test_nifti_metaimage_raw_mapped(void **state) {
    (void)state;
    static double values[N];
    static unsigned char file[352 + N * 4];
    static const int dims[3] = {NX, NY, NZ};
    make_values(VOLUX_UINT16, values);
    tu_nifti_header(file, 0, dims, 512, 16);
    size_t n = tu_encode(VOLUX_UINT16, 0, values, N, file + 352);
    compare(tu_write_file("ooc.nii", file, 352 + n), 1, "");

    make_values(VOLUX_FLOAT32, values);
    n = tu_encode(VOLUX_FLOAT32, 0, values, N, file);
    tu_write_file("ooc_f.raw", file, n);
    char header[256];
    snprintf(header, sizeof header,
             "ObjectType = Image\nNDims = 3\nDimSize = %d %d %d\nElementType = MET_FLOAT\n"
             "ElementDataFile = ooc_f.raw\n",
             NX, NY, NZ);
    compare(tu_write_parts("ooc.mhd", header, NULL, 0), 1, "");

    volux_raw_desc d = {.dims = {NX, NY, NZ}, .type = VOLUX_FLOAT32};
    volux_volume_load_options o = {.raw = &d};
    const char *path = tu_temp_path("ooc_f.raw");
    loaded a = load(path, 0, &o), b = load(path, 1, &o);
    assert_int_equal(b.v->mapped, 1);
    assert_same_volume(a.v, b.v);
    release(&a);
    release(&b);
}

/* A read-only mapping cannot replace NaN: refused (exit 2 in the CLI)
 * even when allowed, naming out-of-core; the ordinary load repairs it. */
static void test_nonfinite_float_is_refused(void **state) {
    (void)state;
    static float f[N];
    for (int i = 0; i < N; i++) f[i] = (float)i;
    f[N / 2] = NAN;
    volux_raw_desc d = {.dims = {NX, NY, NZ}, .type = VOLUX_FLOAT32};
    volux_volume_load_options o = {.raw = &d, .allow_nonfinite = 1};
    const char *path = tu_write_file("ooc_nan.raw", f, sizeof f);
    volux_context *ctx = tu_context(1);
    volux_context_set_out_of_core(ctx, 1);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, path, &o, &v), VOLUX_ERR_UNSUPPORTED);
    assert_null(v);
    tu_assert_error_mentions(ctx, "non-finite", "out-of-core", NULL);
    volux_context_set_out_of_core(ctx, 0);
    assert_int_equal(volux_volume_load(ctx, path, &o, &v), VOLUX_OK);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* The techniques of the out-of-core option (ea and shaded read the bricked
 * copy, single the data itself) render the same image from a mapped
 * volume as from one in memory. */
static void test_render_mapped_equals_in_memory(void **state) {
    (void)state;
    static double values[N];
    static unsigned char raw[N * 2];
    /* a smooth 16-bit field, so that the images have structure */
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                double x = i / (NX - 1.0) - 0.5, y = j / (NY - 1.0) - 0.5, z = k / (NZ - 1.0) - 0.5;
                double r = sqrt(x * x + y * y + z * z);
                values[(k * NY + j) * NX + i] = floor(65535.0 * fmax(0.0, 1.0 - 2.0 * r));
            }
    size_t n = tu_encode(VOLUX_UINT16, 0, values, N, raw);
    tu_write_file("ooc_r.raw", raw, n);
    char header[256];
    snprintf(header, sizeof header,
             "NRRD0004\ntype: uint16\ndimension: 3\nsizes: %d %d %d\nencoding: raw\nendian: little\n"
             "data file: ooc_r.raw\n",
             NX, NY, NZ);
    tu_write_parts("ooc_r.nhdr", header, NULL, 0);
    static const char *json =
        "{\"volume\": {\"file\": \"ooc_r.nhdr\"},"
        " \"transfer_function\": {\"color\": [[0, 0.2, 0.3, 0.6], [40000, 0.95, 0.9, 0.8], [65535, 1, 1, 1]],"
        "   \"opacity\": [[0, 0], [8000, 0.05], [40000, 0.4], [65535, 0.9]]},"
        " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.5, -0.7, -0.5], \"irradiance\": 1.0}],"
        " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}}, \"background\": [0.3, 0.2, 0.1],"
        " \"render\": {\"width\": 40, \"height\": 32, \"spp\": 1, \"threads\": 2}}";
    static const char *techs[] = {"ea", "shaded", "single"};
    for (int t = 0; t < 3; t++) {
        volux_image img[2];
        volux_context *ctx[2];
        for (int ooc = 0; ooc < 2; ooc++) {
            ctx[ooc] = tu_context(2);
            volux_context_set_out_of_core(ctx[ooc], ooc);
            volux_scene *s = tu_scene(ctx[ooc], json);
            assert_int_equal(volux_scene_volume(s)->mapped, ooc);
            img[ooc] = tu_render(ctx[ooc], s, techs[t]);
            volux_scene_destroy(s);
        }
        print_message("%s: mean luminance %g\n", techs[t], tu_mean_luminance(&img[0]));
        assert_true(tu_mean_luminance(&img[0]) > 0.01);
        assert_true(tu_max_abs_diff(&img[0], &img[1]) == 0.0);
        for (int ooc = 0; ooc < 2; ooc++) {
            volux_image_free(ctx[ooc], &img[ooc]);
            volux_context_destroy(ctx[ooc]);
        }
    }
}

/* Resident file pages of this process (kB), from /proc/self/status. */
static long rss_file_kb(void) {
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kb = -1;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "RssFile: %ld kB", &kb) == 1) break;
    if (f) fclose(f);
    return kb;
}

/* A 48 MB volume: the load's passes (range, macrocells), a histogram and the bricked
 * copy's build drop what they swept, so the resident file pages grow by a
 * few of their windows, not by the file. Without the drops they grow by
 * the whole file (and the bricked copy's 1.42× of it). */
static void test_sweeps_keep_the_resident_set_bounded(void **state) {
    (void)state;
    const int n = 288; /* 288³ uint16 = 47.8 MB */
    size_t bytes = (size_t)n * n * n * 2;
    unsigned char *data = malloc(bytes);
    assert_non_null(data);
    for (size_t i = 0; i < bytes; i++) data[i] = (unsigned char)(i * 131u >> 3);
    tu_write_file("ooc_big.raw", data, bytes);
    free(data);
    volux_raw_desc d = {.dims = {n, n, n}, .type = VOLUX_UINT16};
    volux_volume_load_options o = {.raw = &d};
    volux_context *ctx = tu_context(2);
    volux_context_set_out_of_core(ctx, 1);
    long before = rss_file_kb();
    assert_true(before >= 0);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, tu_temp_path("ooc_big.raw"), &o, &v), VOLUX_OK);
    assert_int_equal(v->mapped, 1);
    uint64_t counts[64];
    volux_volume_histogram(v, 64, counts); /* the quick look's sweep */
    long after_load = rss_file_kb();
    assert_int_equal(volux_volume_build_bricks(v), VOLUX_OK);
    long after_bricks = rss_file_kb();
    print_message("RssFile: %ld kB before, +%ld kB after the load, +%ld kB after the bricked copy (file %zu kB)\n",
                  before, after_load - before, after_bricks - before, bytes / 1024);
    /* the window: a 4 M-element block (8 MB) of the range pass, two 8-slice
     * slabs of macrocells (2.6 MB), a z row of bricks and its slices */
    assert_true(after_load - before < (long)(bytes / 1024 / 3));
    assert_true(after_bricks - before < (long)(bytes / 1024 / 3));
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nrrd_mapped_equals_read),
        cmocka_unit_test(test_nifti_metaimage_raw_mapped),
        cmocka_unit_test(test_nonfinite_float_is_refused),
        cmocka_unit_test(test_render_mapped_equals_in_memory),
        cmocka_unit_test(test_sweeps_keep_the_resident_set_bounded),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
