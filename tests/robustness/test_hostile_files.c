/*
 * tests/robustness/test_hostile_files.c — the library's side of issue 34:
 * outputs that leave nothing behind even when the process is killed while
 * writing, readers that refuse what is not a regular file without blocking,
 * a table header that claims gigabytes refused before anything is
 * allocated, and NaN images that compare as an error, not as a match.
 * (The CLI's side: hostile_files.sh.)
 */
#include <dirent.h>
#include <math.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "core/context_internal.h"
#include "io/ambient_table_file.h"
#include "io/cache_folder.h"
#include "io/output_file.h"
#include "test_util.h"
#include "tu_volume.h"

/* Entries of `dir` other than . and .. */
static int entries(const char *dir) {
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    for (struct dirent *e; (e = readdir(d));) n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    return n;
}

static const char *fresh_dir(const char *name) {
    const char *dir = tu_temp_path(name);
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    assert_int_equal(system(cmd), 0);
    assert_int_equal(mkdir(dir, 0700), 0);
    return dir;
}

/* A process killed (SIGKILL: no handler runs) half-way through a write
 * leaves no file at all; a finished write is there whole. */
static void test_killed_writer_leaves_nothing(void **state) {
    (void)state;
    const char *dir = fresh_dir("hostile_kill");
    char path[1100];
    snprintf(path, sizeof path, "%s/image.pfm", dir);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        volux_context *ctx = NULL;
        if (volux_context_create(NULL, &ctx)) _exit(3);
        volux_output_file out;
        if (volux_output_begin(ctx, path, &out)) _exit(4);
        static char block[1 << 16];
        for (int i = 0; i < 64; i++) fwrite(block, 1, sizeof block, out.f);
        fflush(out.f);
        raise(SIGKILL);
        _exit(5);
    }
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
    assert_int_equal(entries(dir), 0);

    volux_context *ctx = tu_context(1);
    static const char text[] = "whole";
    assert_int_equal(volux_file_save(ctx, path, text, sizeof text - 1), VOLUX_OK);
    assert_int_equal(entries(dir), 1);
    struct stat sb;
    assert_int_equal(stat(path, &sb), 0);
    assert_int_equal((int)sb.st_size, (int)sizeof text - 1);
    volux_context_destroy(ctx);
}

/* The second-signal handler's clean-up removes a named temporary (the
 * path taken where unnamed files are not available). */
static void test_abandon_removes_named_temporaries(void **state) {
    (void)state;
    /* Nothing in flight: a no-op that must not touch anything. */
    const char *dir = fresh_dir("hostile_abandon");
    char keep[1100];
    snprintf(keep, sizeof keep, "%s/keep.txt", dir);
    volux_context *ctx = tu_context(1);
    assert_int_equal(volux_file_save(ctx, keep, "k", 1), VOLUX_OK);
    volux_file_abandon_writes();
    assert_int_equal(entries(dir), 1);
    volux_context_destroy(ctx);
}

/* Devices, FIFOs and folders are never outputs; links leave no folder. */
static void test_output_admission(void **state) {
    (void)state;
    const char *dir = fresh_dir("hostile_admit");
    volux_context *ctx = tu_context(1);
    char p[1100], q[1100];
    snprintf(p, sizeof p, "%s/fifo.png", dir);
    assert_int_equal(mkfifo(p, 0600), 0);
    assert_int_equal(volux_file_check_output(ctx, p), VOLUX_ERR_IO);
    tu_assert_error_mentions(ctx, "fifo.png", "not a regular file", NULL);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_file_save(ctx, p, "x", 1), VOLUX_ERR_WRITE);
    volux_context_clear_error(ctx);
    struct stat sb;
    assert_int_equal(lstat(p, &sb), 0);
    assert_true(S_ISFIFO(sb.st_mode));
    assert_int_equal(volux_file_check_output(ctx, "/dev/null"), VOLUX_ERR_IO);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_file_check_output(ctx, dir), VOLUX_ERR_IO);
    tu_assert_error_mentions(ctx, "folder", NULL);
    volux_context_clear_error(ctx);
    snprintf(q, sizeof q, "%s/out.png", dir);
    assert_int_equal(symlink("/etc/hostname", q), 0);
    assert_int_equal(volux_file_check_output(ctx, q), VOLUX_ERR_IO);
    tu_assert_error_mentions(ctx, "out of its folder", NULL);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_file_check_output(ctx, ""), VOLUX_ERR_INVALID);
    volux_context_clear_error(ctx);
    volux_context_destroy(ctx);
}

/* Readers refuse a FIFO at once instead of blocking for a writer. */
static void test_fifo_inputs_refused(void **state) {
    (void)state;
    const char *dir = fresh_dir("hostile_fifo");
    char p[1100];
    snprintf(p, sizeof p, "%s/table.vxat", dir);
    assert_int_equal(mkfifo(p, 0600), 0);
    volux_context *ctx = tu_context(1);
    alarm(20); /* a blocking open would hang the test: end it instead */
    volux_ambient_table t;
    assert_int_equal(volux_ambient_table_load(ctx, p, &t), VOLUX_ERR_IO);
    tu_assert_error_mentions(ctx, "table.vxat", "not a regular file", NULL);
    volux_context_clear_error(ctx);
    volux_image img;
    snprintf(p, sizeof p, "%s/image.pfm", dir);
    assert_int_equal(mkfifo(p, 0600), 0);
    assert_int_equal(volux_image_load(ctx, p, &img), VOLUX_ERR_IO);
    tu_assert_error_mentions(ctx, "not a regular file", NULL);
    volux_context_clear_error(ctx);
    alarm(0);
    volux_context_destroy(ctx);
}

/* A header that claims far more data than the file holds is refused
 * before anything of that size is allocated. */
typedef struct largest_request {
    size_t largest;
} largest_request;

static void *counting_alloc(void *user, void *ptr, size_t old_size, size_t new_size) {
    (void)old_size;
    largest_request *r = user;
    if (new_size > r->largest) r->largest = new_size;
    if (!new_size) {
        free(ptr);
        return NULL;
    }
    return realloc(ptr, new_size);
}

static void put_u32(unsigned char *p, uint32_t v) {
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}

static void test_table_header_cannot_claim_memory(void **state) {
    (void)state;
    largest_request req = {0};
    volux_context_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.threads = 1;
    desc.alloc = counting_alloc;
    desc.alloc_user = &req;
    desc.cache_dir = "";
    volux_context *ctx = NULL;
    assert_int_equal(volux_context_create(&desc, &ctx), VOLUX_OK);
    /* A small valid table, then its header's dims raised to 1024 each
     * (≈ 4 GiB of floats) and the body cut. */
    volux_ambient_table_desc d;
    volux_ambient_table_desc_defaults(&d);
    d.n_theta = d.n_sigma = d.n_g = 2;
    d.paths = 1;
    const char *path = tu_temp_path("hostile_small.vxat");
    assert_int_equal(volux_ambient_table_write(ctx, &d, path, NULL), VOLUX_OK);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    unsigned char bytes[4096];
    size_t n = fread(bytes, 1, sizeof bytes, f);
    fclose(f);
    assert_true(n > 128); /* the 128-byte header (ambient_table_file.h) and a body */
    for (int a = 0; a < 3; a++) put_u32(bytes + 16 + 4 * a, 1024);
    req.largest = 0;
    volux_ambient_table t;
    assert_int_equal(volux_ambient_table_load_memory(ctx, bytes, n, "claims.vxat", &t), VOLUX_ERR_FORMAT);
    tu_assert_error_mentions(ctx, "claims.vxat", "truncated", NULL);
    assert_true(req.largest < (1u << 20));
    volux_context_clear_error(ctx);
    volux_context_destroy(ctx);
}

/* A cancel reaches a table build inside a column: table_paths = 10^9
 * (within the parameter's range) used to run for hours after the cancel. */
static int cancel_at_once(void *user, const char *task, double fraction) {
    (void)task;
    (void)fraction;
    ++*(int *)user;
    return 1;
}

static void test_table_build_cancels_inside_a_column(void **state) {
    (void)state;
    int calls = 0;
    volux_context_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.threads = 2;
    desc.progress = cancel_at_once;
    desc.progress_user = &calls;
    desc.cache_dir = "";
    volux_context *ctx = NULL;
    assert_int_equal(volux_context_create(&desc, &ctx), VOLUX_OK);
    volux_ambient_table_desc d;
    volux_ambient_table_desc_defaults(&d);
    d.n_theta = d.n_sigma = d.n_g = 2;
    d.paths = 1000000000ull;
    const char *path = tu_temp_path("hostile_cancelled.vxat");
    unlink(path);
    alarm(120); /* the old build would run for hours: fail instead of hanging */
    assert_int_equal(volux_ambient_table_write(ctx, &d, path, NULL), VOLUX_ERR_CANCELLED);
    alarm(0);
    assert_true(calls >= 1);
    assert_int_equal(access(path, F_OK), -1);
    volux_context_destroy(ctx);
}

/* Header values that cannot be honoured are said, not swallowed: a NaN
 * NRRD spacing (1 assumed), a negative one (not mirrored), a NIfTI sform
 * that is NaN or all zero (ignored). */
static void expect_warning(const char *name, const void *bytes, size_t n, const char *what) {
    volux_context *ctx = tu_context(1);
    tu_messages m;
    memset(&m, 0, sizeof m);
    volux_context_set_message(ctx, tu_collect_messages, &m);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, tu_write_file(name, bytes, n), NULL, &v), VOLUX_OK);
    if (m.warnings < 1 || !strstr(m.last, what)) fail_msg("%s: no warning about '%s' (last: '%s')", name, what, m.last);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_header_values_not_honoured_are_said(void **state) {
    (void)state;
    char nrrd[256];
    int n = snprintf(nrrd, sizeof nrrd,
                     "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nspacings: nan 1 1\nencoding: raw\n\n");
    memset(nrrd + n, 7, 8);
    expect_warning("nan_spacing.nrrd", nrrd, (size_t)n + 8, "axis 0 is NaN");
    n = snprintf(nrrd, sizeof nrrd,
                 "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nspacings: 1 -2 1\nencoding: raw\n\n");
    memset(nrrd + n, 7, 8);
    expect_warning("negative_spacing.nrrd", nrrd, (size_t)n + 8, "axis 1 is negative");
    static const int dims[3] = {2, 2, 2};
    unsigned char h[352 + 8];
    tu_nifti_header(h, 0, dims, 2, 8);
    memset(h + 352, 1, 8);
    tu_put_i16(h, 254, 1, 0); /* sform_code 1, srow all zero */
    expect_warning("zero_sform.nii", h, sizeof h, "sform is all zero");
    tu_put_f32(h, 280, NAN, 0);
    expect_warning("nan_sform.nii", h, sizeof h, "sform is not finite");
}

/* The cache folder is capped: the least recently used of volux's own
 * entries make room; anything else in the folder is left alone. */
static void make_entry(const char *dir, const char *name, size_t bytes, time_t mtime) {
    char p[1200];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    FILE *f = fopen(p, "wb");
    assert_non_null(f);
    assert_int_equal(ftruncate(fileno(f), (off_t)bytes), 0);
    fclose(f);
    struct timespec t[2] = {{mtime, 0}, {mtime, 0}};
    assert_int_equal(utimensat(AT_FDCWD, p, t, 0), 0);
}

static int exists_in(const char *dir, const char *name) {
    char p[1200];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    return access(p, F_OK) == 0;
}

static void test_cache_folder_is_capped(void **state) {
    (void)state;
    const char *dir = fresh_dir("hostile_cache");
    volux_context_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.threads = 1;
    desc.cache_dir = dir;
    volux_context *ctx = NULL;
    assert_int_equal(volux_context_create(&desc, &ctx), VOLUX_OK);
    const size_t MB = 1u << 20;
    make_entry(dir, "ambient-v2-old.vxat", MB, 1000);
    make_entry(dir, "ambient-v2-mid.vxat", MB, 2000);
    make_entry(dir, "ambient-v2-new.vxat", MB, 3000);
    make_entry(dir, "notes.txt", 3 * MB, 500); /* not ours: never removed */
    setenv("VOLUX_CACHE_MB", "2", 1);
    volux_cache_file_touch(tu_temp_path("hostile_cache/ambient-v2-old.vxat")); /* a hit: now the newest */
    assert_int_equal(volux_cache_folder_make_room(ctx, MB), 1);
    assert_true(exists_in(dir, "ambient-v2-old.vxat"));
    assert_false(exists_in(dir, "ambient-v2-mid.vxat"));
    assert_false(exists_in(dir, "ambient-v2-new.vxat"));
    assert_true(exists_in(dir, "notes.txt"));
    assert_int_equal(volux_cache_folder_make_room(ctx, 3 * MB), 0); /* larger than the cap */
    unsetenv("VOLUX_CACHE_MB");
    volux_context_destroy(ctx);
}

/* A NaN or an infinity in either image is an error, not a perfect match. */
static void test_compare_refuses_nonfinite(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image a, b;
    assert_int_equal(volux_image_create(ctx, 2, 2, &a), VOLUX_OK);
    assert_int_equal(volux_image_create(ctx, 2, 2, &b), VOLUX_OK);
    for (int i = 0; i < 12; i++) a.rgb[i] = b.rgb[i] = 0.5f;
    volux_image_error e;
    assert_int_equal(volux_image_compare(ctx, &a, &b, &e), VOLUX_OK);
    a.rgb[7] = NAN;
    assert_int_equal(volux_image_compare(ctx, &a, &b, &e), VOLUX_ERR_INVALID);
    tu_assert_error_mentions(ctx, "test image", "1 non-finite value", "pixel 0,1", NULL);
    volux_context_clear_error(ctx);
    a.rgb[7] = 0.5f;
    b.rgb[0] = INFINITY;
    assert_int_equal(volux_image_compare(ctx, &a, &b, &e), VOLUX_ERR_INVALID);
    tu_assert_error_mentions(ctx, "reference", NULL);
    volux_context_clear_error(ctx);
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_context_destroy(ctx);
}

/* The memory limit is a budget over everything the context holds (D5),
 * not only the estimate a render checks up front: with 32 MiB, one 20 MiB
 * volume fits, a second does not (each alone is under the one-allocation
 * cap), and the refusal comes before the allocator is asked, with a message
 * naming the limit. The context never holds more than the limit. */
static void test_memory_limit_is_a_budget(void **state) {
    (void)state;
    tu_alloc_stats stats = {0};
    volux_context *ctx = tu_context_counting(0, &stats);
    const uint64_t limit = 32u << 20;
    volux_context_set_memory_limit(ctx, limit);
    volux_volume_desc d = {.dims = {256, 256, 320}, .type = VOLUX_UINT8}; /* 20 MiB */
    volux_volume *a = NULL, *b = NULL;
    assert_int_equal(volux_volume_create(ctx, &d, &a), VOLUX_OK);
    size_t largest_before = stats.largest;
    assert_int_not_equal(volux_volume_create(ctx, &d, &b), VOLUX_OK);
    assert_int_equal(volux_context_error_status(ctx), VOLUX_ERR_LIMIT); /* the first error: the budget */
    assert_null(b);
    assert_non_null(strstr(volux_context_error(ctx), "memory limit"));
    assert_int_equal(stats.largest, largest_before); /* refused before allocating */
    assert_true(volux_context_bytes_in_use(ctx) <= limit);
    assert_true(stats.live <= limit);
    /* Freeing makes room again, and the refusal is said again afterwards. */
    volux_volume_release(a);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_volume_create(ctx, &d, &b), VOLUX_OK);
    volux_volume_release(b);
    /* A scene whose procedural volume alone passes the limit (512³ u8). */
    volux_scene *scene = NULL;
    volux_context_clear_error(ctx);
    const char *json = "{\"volume\": {\"procedural\": \"phantom\", \"dims\": [512, 512, 512]}}";
    assert_int_not_equal(volux_scene_load_string(ctx, json, NULL, "budget.json", NULL, 0, &scene), VOLUX_OK);
    assert_null(scene);
    assert_non_null(strstr(volux_context_error(ctx), "memory limit"));
    assert_true(stats.live <= limit);
    volux_context_clear_error(ctx);
    volux_context_destroy(ctx);
}

/* Under a data root (the viewer) a volume whose data does not fit its
 * header gets no message that states the file's size (D8); outside one, the
 * CLI user is told the sizes that help fix the header. */
static void test_sizes_withheld_under_data_root(void **state) {
    (void)state;
    const char *dir = fresh_dir("withheld");
    char data[64], header[64];
    snprintf(data, sizeof data, "withheld/d.raw");
    snprintf(header, sizeof header, "withheld/h.nhdr");
    unsigned char bytes[1000] = {0};
    tu_write_file(data, bytes, 300); /* 8³ u8 needs 512 */
    const char *text = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: raw\ndata file: d.raw\n\n";
    const char *path = tu_write_file(header, text, strlen(text));
    volux_context *ctx = tu_context(1);
    volux_volume *v = NULL;
    assert_int_not_equal(volux_volume_load(ctx, path, NULL, &v), VOLUX_OK);
    assert_non_null(strstr(volux_context_error(ctx), "300")); /* the CLI's message helps */
    volux_context_clear_error(ctx);
    char root[1024];
    assert_non_null(realpath(dir, root));
    volux_volume_load_options o = {.data_root = root};
    assert_int_not_equal(volux_volume_load(ctx, path, &o, &v), VOLUX_OK);
    const char *msg = volux_context_error(ctx);
    assert_null(strstr(msg, "300"));
    assert_non_null(strstr(msg, "8x8x8 uint8"));
    assert_null(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_killed_writer_leaves_nothing),
        cmocka_unit_test(test_abandon_removes_named_temporaries),
        cmocka_unit_test(test_output_admission),
        cmocka_unit_test(test_fifo_inputs_refused),
        cmocka_unit_test(test_table_header_cannot_claim_memory),
        cmocka_unit_test(test_table_build_cancels_inside_a_column),
        cmocka_unit_test(test_compare_refuses_nonfinite),
        cmocka_unit_test(test_cache_folder_is_capped),
        cmocka_unit_test(test_header_values_not_honoured_are_said),
        cmocka_unit_test(test_memory_limit_is_a_budget),
        cmocka_unit_test(test_sizes_withheld_under_data_root),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
