/*
 * io/dicom.c — DICOM series as volumes: which files make the series, in
 * which order, with which spacing, values and orientation. The files
 * themselves are read by GDCM through dicom_adapter.h (the only C++).
 *
 * A folder (its own files, not its subfolders) or one file of a series
 * opens as a volume:
 *   - series: files are grouped by SeriesInstanceUID. A file given by name
 *     selects its own series (the files beside it that share the UID); a
 *     folder selects the series with the most slices, and when it holds
 *     several a warning lists them with one file of each, which is how
 *     another one is chosen.
 *   - order and spacing (PS3.3 C.7.6.2.1.1): the slice normal is
 *     row × column of Image Orientation (Patient); slices are sorted by
 *     their Image Position (Patient) projected on the normal, and the
 *     spacing is the distance between neighbours — SliceThickness says how
 *     thick the excitation was, not where the slices are. Positions that
 *     do not step evenly (a missing slice, a duplicate), step off the
 *     normal (gantry tilt: the grid is sheared), or files whose size,
 *     pixel type or orientation differ are refused with a message naming
 *     two files; volux grids are regular and unsheared.
 *   - values: Rescale Slope/Intercept (e.g. CT numbers to Hounsfield
 *     units). Integer slope 1 and an integer intercept that keeps the
 *     stored range inside int16 (the CT case) stay int16; anything else,
 *     or a scale that differs between slices, is stored as float32.
 *   - orientation: like NIfTI and NRRD (nifti.c, nrrd.c) the grid axes are
 *     the world's, and the one orientation fact kept is where anatomical
 *     superior points in the grid: the z (superior) component of the row,
 *     column and normal directions in the patient's LPS space. The origin
 *     is the first slice's position (used with use_file_origin).
 *   - multi-frame: one file whose frames are the slices, spaced as GDCM
 *     derives from the per-frame positions, SpacingBetweenSlices or the
 *     GridFrameOffsetVector.
 *
 * Without GDCM at build time every entry point says DICOM was not built.
 */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "dicom_adapter.h"
#include "core/volume_internal.h"
#include "header_text.h"
#include "volume_formats.h"

#define MAX_FOLDER_FILES 100000
#define MAX_PATH 4096

static int has_dicm_magic(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    unsigned char b[132];
    size_t got = fread(b, 1, sizeof b, f);
    fclose(f);
    return got == sizeof b && memcmp(b + 128, "DICM", 4) == 0;
}

static int is_folder(const char *path) {
    struct stat sb;
    return stat(path, &sb) == 0 && S_ISDIR(sb.st_mode);
}

int volux_dicom_path_is_dicom(const char *path) {
    if (!path || !*path) return 0;
    if (is_folder(path)) return 1;
    if (volux_text_ends_with_ci(path, ".dcm") || volux_text_ends_with_ci(path, ".dicom")) return 1;
    return has_dicm_magic(path);
}

#ifndef VOLUX_HAVE_GDCM

volux_status volux_dicom_load(volux_context *ctx, const char *path, const volux_volume_load_options *options,
                              volux_volume **out) {
    (void)options;
    (void)out;
    return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                       "%s: a DICOM %s, but this volux was built without DICOM support (install libgdcm-dev and "
                       "rebuild)",
                       path, is_folder(path) ? "folder" : "file");
}

volux_status volux_dicom_load_memory(volux_context *ctx, const void *bytes, size_t n, const char *name,
                                     const volux_volume_load_options *options, volux_volume **out) {
    (void)bytes;
    (void)n;
    (void)options;
    (void)out;
    return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: this volux was built without DICOM support", name);
}

#else

typedef struct dcm_file {
    char *path; /* NULL for the in-memory file */
    const char *label; /* for messages: the name under the folder */
    volux_dicom_info info;
    double key; /* position along the normal */
} dcm_file;

typedef struct dcm_set {
    volux_context *ctx;
    const char *name; /* what the user gave */
    dcm_file *files;
    int count, cap;
    const void *mem; /* one in-memory file */
    size_t mem_n;
} dcm_set;

static void set_free(dcm_set *s) {
    for (int i = 0; i < s->count; i++) free(s->files[i].path);
    free(s->files);
    s->files = NULL;
    s->count = s->cap = 0;
}

static const char *base_name(const char *p) {
    const char *slash = strrchr(p, '/');
    return slash && slash[1] ? slash + 1 : p;
}

static int name_order(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* The regular files of `folder` (not hidden, not below it), sorted by name. */
static volux_status list_folder(volux_context *ctx, const char *folder, char ***names_out, int *n_out,
                                int *subfolders) {
    DIR *d = opendir(folder);
    if (!d) return volux_error(ctx, VOLUX_ERR_IO, "%s: cannot open the folder: %s", folder, strerror(errno));
    char **names = NULL;
    int n = 0, cap = 0;
    volux_status st = VOLUX_OK;
    struct dirent *e;
    *subfolders = 0;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        char path[MAX_PATH];
        if (snprintf(path, sizeof path, "%s/%s", folder, e->d_name) >= (int)sizeof path) continue;
        struct stat sb;
        if (stat(path, &sb) != 0) continue;
        if (S_ISDIR(sb.st_mode)) {
            (*subfolders)++;
            continue;
        }
        if (!S_ISREG(sb.st_mode)) continue;
        if (n == MAX_FOLDER_FILES) {
            st = volux_error(ctx, VOLUX_ERR_LIMIT, "%s: more than %d files in the folder", folder, MAX_FOLDER_FILES);
            break;
        }
        if (n == cap) {
            int nc = cap ? 2 * cap : 256;
            char **grown = realloc(names, (size_t)nc * sizeof *names);
            if (!grown) {
                st = volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory listing the folder", folder);
                break;
            }
            names = grown;
            cap = nc;
        }
        if (!(names[n] = strdup(path))) {
            st = volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory listing the folder", folder);
            break;
        }
        n++;
    }
    closedir(d);
    if (st) {
        for (int i = 0; i < n; i++) free(names[i]);
        free(names);
        return st;
    }
    if (n) qsort(names, (size_t)n, sizeof *names, name_order);
    *names_out = names;
    *n_out = n;
    return VOLUX_OK;
}

static volux_status add_file(dcm_set *s, char *path, const volux_dicom_info *info) {
    if (s->count == s->cap) {
        int nc = s->cap ? 2 * s->cap : 64;
        dcm_file *grown = realloc(s->files, (size_t)nc * sizeof *grown);
        if (!grown) {
            free(path);
            return volux_error(s->ctx, VOLUX_ERR_NOMEM, "%s: out of memory for the file list", s->name);
        }
        s->files = grown;
        s->cap = nc;
    }
    dcm_file *f = &s->files[s->count++];
    memset(f, 0, sizeof *f);
    f->path = path;
    f->label = path ? base_name(path) : s->name;
    f->info = *info;
    return VOLUX_OK;
}

/* What reading one file's header gave. */
typedef struct scan_result {
    int status;
    volux_dicom_info info;
    char why[200];
} scan_result;

#define SCAN_TIMEOUT_MS 3000

static int read_full(int fd, void *buf, size_t n) {
    unsigned char *p = buf;
    while (n) {
        struct pollfd pfd = {fd, POLLIN, 0};
        int r = poll(&pfd, 1, SCAN_TIMEOUT_MS);
        if (r <= 0) return r == 0 ? -1 : 0; /* -1: timed out */
        ssize_t got = read(fd, p, n);
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0) return 0; /* the child ended: it aborted */
        p += got;
        n -= (size_t)got;
    }
    return 1;
}

/* The headers of `n` files, read by GDCM in a child process: GDCM 3.0
 * aborts on some malformed objects (an assert in Debian's build) and loops
 * forever on others (pydicom's SC_rgb_jpeg.dcm hangs gdcmdump too), and a
 * folder scan must survive the odd file it did not ask for. A file the
 * child does not finish within SCAN_TIMEOUT_MS, or dies on, is skipped
 * with its reason; a new child goes on from the next one. Without fork
 * the headers are read in this process. */
static void scan_isolated(char **paths, int n, scan_result *res) {
    int i = 0;
    while (i < n) {
        int fd[2];
        if (pipe(fd) != 0) break;
        fflush(NULL);
        pid_t pid = fork();
        if (pid < 0) {
            close(fd[0]);
            close(fd[1]);
            break;
        }
        if (pid == 0) {
            close(fd[0]);
            for (int k = i; k < n; k++) {
                scan_result r;
                memset(&r, 0, sizeof r);
                r.status = volux_dicom_adapter_info(paths[k], NULL, 0, &r.info, r.why, sizeof r.why);
                const unsigned char *p = (const unsigned char *)&r;
                size_t left = sizeof r;
                while (left) {
                    ssize_t w = write(fd[1], p, left);
                    if (w < 0 && errno == EINTR) continue;
                    if (w <= 0) _exit(1);
                    p += w;
                    left -= (size_t)w;
                }
            }
            _exit(0);
        }
        close(fd[1]);
        int k = i, how = 1;
        while (k < n && (how = read_full(fd[0], &res[k], sizeof res[k])) == 1) k++;
        close(fd[0]);
        if (k < n) {
            kill(pid, SIGKILL);
            memset(&res[k], 0, sizeof res[k]);
            res[k].status = VOLUX_DICOM_BAD;
            snprintf(res[k].why, sizeof res[k].why, "GDCM %s reading this file (skipped)",
                     how < 0 ? "did not finish within 3 s" : "aborted");
            k++;
        }
        while (waitpid(pid, NULL, 0) < 0 && errno == EINTR) {
        }
        i = k;
    }
    for (; i < n; i++) {
        memset(&res[i], 0, sizeof res[i]);
        res[i].status = volux_dicom_adapter_info(paths[i], NULL, 0, &res[i].info, res[i].why, sizeof res[i].why);
    }
}

/* Reads the headers of the DICOM images in `folder`. Files that are not
 * DICOM, or DICOM without an image (DICOMDIR, reports), are skipped; the
 * first unreadable DICOM image is remembered for the message when no
 * series is found. */
static volux_status scan_folder(dcm_set *s, const char *folder) {
    volux_context *ctx = s->ctx;
    char **names = NULL;
    int n = 0, subfolders = 0;
    volux_status st = list_folder(ctx, folder, &names, &n, &subfolders);
    if (st) return st;
    char first_bad[300] = "";
    /* Only files that say they are DICOM (the PS3.10 prefix, or .dcm) go
     * to GDCM. */
    int m = 0, listed = n;
    for (int i = 0; i < n; i++) {
        if (has_dicm_magic(names[i]) || volux_text_ends_with_ci(names[i], ".dcm")) names[m++] = names[i];
        else free(names[i]);
    }
    n = m;
    scan_result *res = n ? calloc((size_t)n, sizeof *res) : NULL;
    if (n && !res) st = volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for %d headers", folder, n);
    if (res) scan_isolated(names, n, res);
    for (int i = 0; i < n && !st; i++) {
        char *path = names[i];
        names[i] = NULL;
        if (res[i].status != VOLUX_DICOM_OK) {
            if (res[i].status == VOLUX_DICOM_BAD && !first_bad[0])
                snprintf(first_bad, sizeof first_bad, "%s: %s", base_name(path), res[i].why);
            if (res[i].status == VOLUX_DICOM_BAD && strstr(res[i].why, "(skipped)"))
                volux_warn(ctx, "%s: %s: %s", folder, base_name(path), res[i].why);
            free(path);
            continue;
        }
        st = add_file(s, path, &res[i].info);
    }
    free(res);
    for (int i = 0; i < n; i++) free(names[i]);
    free(names);
    if (st) return st;
    if (s->count == 0) {
        if (first_bad[0])
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: no readable DICOM image in the folder (%s)", folder,
                               first_bad);
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: no DICOM image in the folder (%d files%s)", folder, listed,
                           subfolders ? "; its subfolders are not searched: pass one of them" : "");
    }
    return VOLUX_OK;
}

typedef struct series {
    const char *uid;
    int files, slices, first; /* first: index of one of its files */
} series;

static int collect_series(dcm_set *s, series **out, int *n_out) {
    series *list = calloc((size_t)s->count, sizeof *list);
    if (!list) return -1;
    int n = 0;
    for (int i = 0; i < s->count; i++) {
        const volux_dicom_info *in = &s->files[i].info;
        int k = 0;
        while (k < n && strcmp(list[k].uid, in->series_uid) != 0) k++;
        if (k == n) {
            list[n].uid = in->series_uid;
            list[n].first = i;
            n++;
        }
        list[k].files++;
        list[k].slices += in->frames > 0 ? in->frames : 1;
    }
    *out = list;
    *n_out = n;
    return 0;
}

/* Keeps only the files of series `uid`. */
static void keep_series(dcm_set *s, const char *uid_in) {
    char uid[VOLUX_DICOM_TEXT];
    snprintf(uid, sizeof uid, "%s", uid_in);
    int w = 0;
    for (int i = 0; i < s->count; i++) {
        if (strcmp(s->files[i].info.series_uid, uid) == 0) s->files[w++] = s->files[i];
        else free(s->files[i].path);
    }
    s->count = w;
}

static void describe_series(const dcm_set *s, const series *se, char *out, size_t n) {
    const volux_dicom_info *in = &s->files[se->first].info;
    char number[24] = "";
    if (in->series_number) snprintf(number, sizeof number, " #%d", in->series_number);
    snprintf(out, n, "%s%s%s%.40s%s %dx%dx%d (%s)", in->modality[0] ? in->modality : "?", number,
             in->description[0] ? " '" : "", in->description, in->description[0] ? "'" : "", in->columns, in->rows,
             se->slices, s->files[se->first].label);
}

/* Folder: the largest series (most slices; ties: the first found), with a
 * warning listing all when there are several. `uid` non-NULL: that one. */
static volux_status choose_series(dcm_set *s, const char *uid) {
    series *list;
    int n;
    if (collect_series(s, &list, &n))
        return volux_error(s->ctx, VOLUX_ERR_NOMEM, "%s: out of memory grouping series", s->name);
    int pick = 0;
    if (uid) {
        for (int k = 0; k < n; k++)
            if (strcmp(list[k].uid, uid) == 0) pick = k;
    } else {
        for (int k = 1; k < n; k++)
            if (list[k].slices > list[pick].slices) pick = k;
    }
    if (n > 1) {
        char text[2048], one[400];
        describe_series(s, &list[pick], one, sizeof one);
        int w = snprintf(text, sizeof text, "%s: %d DICOM series; loading %s%s; to open another, give one of its files:",
                         s->name, n, uid ? "" : "the largest, ", one);
        for (int k = 0; k < n && w > 0 && (size_t)w < sizeof text; k++) {
            if (k == pick) continue;
            describe_series(s, &list[k], one, sizeof one);
            w += snprintf(text + w, sizeof text - (size_t)w, " %s;", one);
        }
        volux_warn(s->ctx, "%s", text);
    }
    keep_series(s, list[pick].uid);
    free(list);
    return VOLUX_OK;
}

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static int key_order(const void *a, const void *b) {
    const dcm_file *x = a, *y = b;
    return x->key < y->key ? -1 : x->key > y->key;
}

static volux_scalar_type file_type(const volux_dicom_info *in) {
    if (in->pixel_float) return in->bits_allocated == 64 ? VOLUX_FLOAT64 : VOLUX_FLOAT32;
    switch (in->bits_allocated) {
    case 8: return in->pixel_signed ? VOLUX_INT8 : VOLUX_UINT8;
    case 16: return in->pixel_signed ? VOLUX_INT16 : VOLUX_UINT16;
    default: return in->pixel_signed ? VOLUX_INT32 : VOLUX_UINT32;
    }
}

/* The checks that make the series one regular grid; fills h (dims,
 * spacing, type, origin, superior) and sorts s->files into slice order. */
static volux_status arrange(dcm_set *s, volux_volume_header *h) {
    volux_context *ctx = s->ctx;
    const char *name = s->name;
    dcm_file *f = s->files;
    const volux_dicom_info *a = &f[0].info;
    if (a->samples != 1)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: %s: %d samples per pixel (colour): volux reads one value "
                           "per voxel", name, f[0].label, a->samples);
    if (!a->pixel_float && a->bits_allocated != 8 && a->bits_allocated != 16 && a->bits_allocated != 32)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: %s: BitsAllocated %d (expected 8, 16 or 32)", name,
                           f[0].label, a->bits_allocated);
    if (a->pixel_float && a->bits_allocated != 32 && a->bits_allocated != 64)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: %s: float pixels of %d bits", name, f[0].label,
                           a->bits_allocated);
    if (a->columns < 1 || a->rows < 1 || a->frames < 1 || a->columns > VOLUX_MAX_DIM || a->rows > VOLUX_MAX_DIM ||
        a->frames > VOLUX_MAX_DIM)
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %s: image size %dx%d with %d frames, outside [1, %d]", name,
                           f[0].label, a->columns, a->rows, a->frames, VOLUX_MAX_DIM);
    for (int i = 1; i < s->count; i++) {
        const volux_dicom_info *b = &f[i].info;
        if (b->columns != a->columns || b->rows != a->rows)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: mixed sizes in one series: %s is %dx%d, %s is %dx%d", name,
                               f[0].label, a->columns, a->rows, f[i].label, b->columns, b->rows);
        if (b->samples != a->samples || b->bits_allocated != a->bits_allocated ||
            b->pixel_signed != a->pixel_signed || b->pixel_float != a->pixel_float)
            return volux_error(ctx, VOLUX_ERR_FORMAT,
                               "%s: mixed pixel types in one series: %s and %s (BitsAllocated %d/%d, signed %d/%d)",
                               name, f[0].label, f[i].label, a->bits_allocated, b->bits_allocated, a->pixel_signed,
                               b->pixel_signed);
        if (b->frames != 1)
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                               "%s: %s holds %d frames: a series of several multi-frame files (open one file)", name,
                               f[i].label, b->frames);
    }
    if (s->count > 1 && a->frames != 1)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                           "%s: %s holds %d frames: a series of several multi-frame files (open one file)", name,
                           f[0].label, a->frames);
    double sx = a->spacing[0], sy = a->spacing[1];
    if (!(sx > 0) || !(sy > 0)) {
        volux_warn(ctx, "%s: no pixel spacing: 1 mm assumed", name);
        sx = sy = 1.0;
    }
    double row[3] = {1, 0, 0}, col[3] = {0, 1, 0}, nrm[3];
    if (a->has_orientation) {
        memcpy(row, a->orientation, sizeof row);
        memcpy(col, a->orientation + 3, sizeof col);
        double lr = sqrt(dot3(row, row)), lc = sqrt(dot3(col, col));
        if (!(lr > 0.5 && lr < 1.5 && lc > 0.5 && lc < 1.5) || fabs(dot3(row, col)) > 1e-3 * lr * lc)
            return volux_error(ctx, VOLUX_ERR_FORMAT,
                               "%s: %s: ImageOrientationPatient is not two perpendicular unit vectors", name,
                               f[0].label);
        for (int c = 0; c < 3; c++) {
            row[c] /= lr;
            col[c] /= lc;
        }
    }
    nrm[0] = row[1] * col[2] - row[2] * col[1];
    nrm[1] = row[2] * col[0] - row[0] * col[2];
    nrm[2] = row[0] * col[1] - row[1] * col[0];
    double sz = 1.0;
    if (s->count == 1) {
        if (a->frames > 1) {
            sz = a->spacing[2];
            if (!(sz > 0)) {
                volux_warn(ctx, "%s: %d frames but no spacing between them: 1 mm assumed", name, a->frames);
                sz = 1.0;
            }
        } else {
            sz = sx < sy ? sx : sy; /* one slice: any thickness draws it */
        }
    } else {
        int positions = 1;
        for (int i = 0; i < s->count; i++)
            if (!f[i].info.has_position || !f[i].info.has_orientation) positions = 0;
        if (positions) {
            for (int i = 1; i < s->count; i++)
                for (int c = 0; c < 6; c++)
                    if (fabs(f[i].info.orientation[c] - a->orientation[c]) > 1e-4)
                        return volux_error(ctx, VOLUX_ERR_FORMAT,
                                           "%s: the slices are not parallel: %s and %s differ in "
                                           "ImageOrientationPatient",
                                           name, f[0].label, f[i].label);
            for (int i = 0; i < s->count; i++) f[i].key = dot3(f[i].info.position, nrm);
        } else {
            int numbered = 1;
            for (int i = 0; i < s->count; i++)
                if (!f[i].info.has_instance) numbered = 0;
            if (!numbered)
                return volux_error(ctx, VOLUX_ERR_FORMAT,
                                   "%s: %s has neither ImagePositionPatient/ImageOrientationPatient nor "
                                   "InstanceNumber: the slice order is unknown",
                                   name, f[0].label);
            volux_warn(ctx, "%s: no ImagePositionPatient: slices ordered by InstanceNumber, 1 mm apart", name);
            for (int i = 0; i < s->count; i++) f[i].key = f[i].info.instance_number;
        }
        qsort(f, (size_t)s->count, sizeof *f, key_order);
        a = &f[0].info;
        double step_min = INFINITY, step_max = 0.0;
        int at_min = 1, at_max = 1;
        for (int i = 1; i < s->count; i++) {
            double d = f[i].key - f[i - 1].key;
            if (d < step_min) step_min = d, at_min = i;
            if (d > step_max) step_max = d, at_max = i;
        }
        if (!(step_min > 1e-4))
            return volux_error(ctx, VOLUX_ERR_FORMAT,
                               "%s: two slices at the same position: %s and %s (%s; several acquisitions in one "
                               "series?)",
                               name, f[at_min - 1].label, f[at_min].label,
                               positions ? "ImagePositionPatient" : "InstanceNumber");
        if (positions) {
            /* Missing slices: the steps must agree (1 % and 0.01 mm slack
             * for rounded positions). */
            if (step_max - step_min > 0.01 * step_min + 0.01)
                return volux_error(ctx, VOLUX_ERR_FORMAT,
                                   "%s: missing slices: a gap of %.4g mm between %s and %s where the smallest step "
                                   "is %.4g mm (%d files)",
                                   name, step_max, f[at_max - 1].label, f[at_max].label, step_min, s->count);
            /* Gantry tilt: the positions step off the normal. */
            double d[3], along = f[s->count - 1].key - f[0].key;
            for (int c = 0; c < 3; c++) d[c] = f[s->count - 1].info.position[c] - f[0].info.position[c];
            double off2 = dot3(d, d) - along * along, off = off2 > 0 ? sqrt(off2) : 0.0;
            double deg = atan2(off, along) * 180.0 / 3.14159265358979323846;
            if (deg > 0.05)
                return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                                   "%s: gantry tilt: the slice positions step %.3g degrees off the slice normal "
                                   "(GantryDetectorTilt %g): a sheared grid, which volux cannot represent "
                                   "(resample the series first)",
                                   name, deg, a->gantry_tilt);
            sz = along / (s->count - 1);
        }
    }
    volux_volume_header_init(h);
    h->dims[0] = a->columns;
    h->dims[1] = a->rows;
    h->dims[2] = s->count == 1 ? a->frames : s->count;
    h->spacing[0] = sx;
    h->spacing[1] = sy;
    h->spacing[2] = sz;
    h->type = file_type(a);
    h->big_endian = volux_host_big_endian();
    if (a->has_position) {
        memcpy(h->origin, a->position, sizeof h->origin);
        h->has_origin = 1;
    }
    if (a->has_orientation) {
        /* LPS: +z is superior. */
        h->superior[0] = row[2];
        h->superior[1] = col[2];
        h->superior[2] = nrm[2];
        h->has_superior = fabs(row[2]) + fabs(col[2]) + fabs(nrm[2]) > 1e-9;
    }
    return VOLUX_OK;
}

/* Integer range of the stored values (BitsStored, signedness). */
static void stored_range(const volux_dicom_info *in, double *lo, double *hi) {
    int bits = in->bits_stored > 0 && in->bits_stored <= in->bits_allocated ? in->bits_stored : in->bits_allocated;
    if (in->pixel_signed) {
        *lo = -ldexp(1.0, bits - 1);
        *hi = ldexp(1.0, bits - 1) - 1.0;
    } else {
        *lo = 0.0;
        *hi = ldexp(1.0, bits) - 1.0;
    }
}

static double element_at(const unsigned char *b, volux_scalar_type t, size_t i) {
    switch (t) {
    case VOLUX_UINT8: return b[i];
    case VOLUX_INT8: return (int8_t)b[i];
    case VOLUX_UINT16: {
        uint16_t v;
        memcpy(&v, b + 2 * i, 2);
        return v;
    }
    case VOLUX_INT16: {
        int16_t v;
        memcpy(&v, b + 2 * i, 2);
        return v;
    }
    case VOLUX_UINT32: {
        uint32_t v;
        memcpy(&v, b + 4 * i, 4);
        return v;
    }
    default: {
        int32_t v;
        memcpy(&v, b + 4 * i, 4);
        return v;
    }
    }
}

static volux_status load_set(dcm_set *s, const volux_volume_load_options *options, volux_volume **out) {
    volux_context *ctx = s->ctx;
    const char *name = s->name;
    if (options && options->region)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: region: one brick of a DICOM series", name);
    volux_volume_header h;
    volux_status st = arrange(s, &h);
    if (st) return st;
    const volux_dicom_info *a = &s->files[0].info;
    /* Value mapping: one scale for the series, or per slice (float). */
    int same = 1;
    for (int i = 1; i < s->count; i++)
        if (s->files[i].info.slope != a->slope || s->files[i].info.intercept != a->intercept) same = 0;
    int to_int16 = 0;
    if (!(same && a->slope == 1.0 && a->intercept == 0.0)) {
        double lo, hi;
        stored_range(a, &lo, &hi);
        if (same && a->slope == 1.0 && a->intercept == floor(a->intercept) && !a->pixel_float &&
            lo + a->intercept >= -32768.0 && hi + a->intercept <= 32767.0)
            to_int16 = 1;
        else {
            h.apply_scale = 1;
            h.scale_slope = a->slope;
            h.scale_inter = a->intercept;
        }
    }
    volux_volume_header hout = h;
    if (to_int16) hout.type = VOLUX_INT16;
    if ((st = volux_volume_header_check(ctx, name, &hout))) return st;
    volux_volume *v = NULL;
    if ((st = volux_volume_create_storage(ctx, hout.dims, hout.spacing, h.apply_scale ? VOLUX_FLOAT32 : hout.type,
                                          &v))) {
        volux_error_prefix(ctx, "%s: ", name);
        return st;
    }
    size_t per_file = (size_t)a->columns * (size_t)a->rows * (size_t)(s->count == 1 ? a->frames : 1);
    size_t esize = (size_t)a->bits_allocated / 8, bytes = per_file * esize;
    unsigned char *buf = volux_malloc(ctx, bytes);
    int16_t *conv = to_int16 ? volux_malloc(ctx, per_file * sizeof *conv) : NULL;
    size_t clipped = 0;
    if (!buf || (to_int16 && !conv)) {
        st = volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for the pixel data", name);
        goto done;
    }
    for (int i = 0; i < s->count; i++) {
        char why[256] = "";
        int r = volux_dicom_adapter_pixels(s->files[i].path, s->mem, s->mem_n, buf, bytes, why, sizeof why);
        if (r != VOLUX_DICOM_OK) {
            st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %s: %s", name, s->files[i].label, why);
            goto done;
        }
        size_t first = (size_t)i * per_file;
        if (to_int16) {
            for (size_t k = 0; k < per_file; k++) {
                double x = element_at(buf, h.type, k) + a->intercept;
                if (x < -32768.0 || x > 32767.0) {
                    clipped++;
                    x = x < 0 ? -32768.0 : 32767.0;
                }
                conv[k] = (int16_t)x;
            }
            volux_volume_store_elements(&hout, v, first, (unsigned char *)conv, per_file);
        } else {
            volux_volume_header hs = h;
            hs.scale_slope = s->files[i].info.slope;
            hs.scale_inter = s->files[i].info.intercept;
            volux_volume_store_elements(&hs, v, first, buf, per_file);
        }
    }
    if (clipped)
        volux_warn(ctx, "%s: %zu stored values lie outside BitsStored and were clipped to int16", name, clipped);
    st = volux_volume_read_finish(ctx, &hout, name, options, v);
done:
    volux_free(ctx, buf, bytes);
    volux_free(ctx, conv, per_file * sizeof *conv);
    if (st) volux_volume_release(v);
    else *out = v;
    return st;
}

static void dir_of(const char *path, char *out, size_t n) {
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(out, n, ".");
    else if (slash == path) snprintf(out, n, "/");
    else snprintf(out, n, "%.*s", (int)(slash - path), path);
}


/* The named file alone (its series could not be assembled, or it has no
 * series UID, or it holds frames). */
static volux_status load_one(volux_context *ctx, const char *path, const volux_dicom_info *info,
                             const volux_volume_load_options *options, volux_volume **out) {
    dcm_set s = {.ctx = ctx, .name = path};
    char *copy = strdup(path);
    volux_status st = copy ? add_file(&s, copy, info) : volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory", path);
    if (!st) st = load_set(&s, options, out);
    set_free(&s);
    return st;
}

volux_status volux_dicom_load(volux_context *ctx, const char *path, const volux_volume_load_options *options,
                              volux_volume **out) {
    if (is_folder(path)) {
        dcm_set s = {.ctx = ctx, .name = path};
        volux_status st = scan_folder(&s, path);
        if (!st) st = choose_series(&s, NULL);
        if (!st) st = load_set(&s, options, out);
        set_free(&s);
        return st;
    }
    FILE *probe = fopen(path, "rb");
    if (!probe) return volux_error(ctx, VOLUX_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    fclose(probe);
    scan_result one;
    char *paths[1] = {(char *)path};
    scan_isolated(paths, 1, &one);
    if (one.status != VOLUX_DICOM_OK)
        return volux_error(ctx, one.status == VOLUX_DICOM_NO_IMAGE ? VOLUX_ERR_UNSUPPORTED : VOLUX_ERR_FORMAT,
                           "%s: %s", path, one.why);
    volux_dicom_info info = one.info;
    if (!info.series_uid[0] || info.frames != 1) return load_one(ctx, path, &info, options, out);
    /* The series this file belongs to: the files beside it that share its
     * SeriesInstanceUID. */
    char folder[MAX_PATH];
    dir_of(path, folder, sizeof folder);
    dcm_set s = {.ctx = ctx, .name = path};
    volux_status st = scan_folder(&s, folder);
    if (!st) {
        keep_series(&s, info.series_uid);
        if (s.count <= 1) {
            set_free(&s);
            return load_one(ctx, path, &info, options, out);
        }
        int had_error = volux_context_error(ctx)[0] != 0;
        st = load_set(&s, options, out);
        int files = s.count;
        set_free(&s);
        if (st == VOLUX_ERR_FORMAT || st == VOLUX_ERR_UNSUPPORTED) {
            /* Files that share the UID but do not make one grid (copies of
             * one slice in other encodings, a broken sibling): the file the
             * user named still opens, alone, with the reason. The failed
             * attempt is not the caller's error: its message is taken back
             * (unless an earlier one was already recorded). */
            char reason[512];
            snprintf(reason, sizeof reason, "%s", volux_context_error(ctx));
            if (!had_error) volux_context_clear_error(ctx);
            st = load_one(ctx, path, &info, options, out);
            if (!st)
                volux_warn(ctx, "%s: loading this file alone: its series (%d files beside it) is not one grid: %s",
                           path, files, reason);
        }
        return st;
    }
    set_free(&s);
    return st;
}

volux_status volux_dicom_load_memory(volux_context *ctx, const void *bytes, size_t n, const char *name,
                                     const volux_volume_load_options *options, volux_volume **out) {
    dcm_set s = {.ctx = ctx, .name = name, .mem = bytes, .mem_n = n};
    volux_dicom_info info;
    char why[200] = "";
    int r = volux_dicom_adapter_info(NULL, bytes, n, &info, why, sizeof why);
    if (r != VOLUX_DICOM_OK)
        return volux_error(ctx, r == VOLUX_DICOM_NO_IMAGE ? VOLUX_ERR_UNSUPPORTED : VOLUX_ERR_FORMAT, "%s: %s", name,
                           why);
    volux_status st = add_file(&s, NULL, &info);
    if (!st) st = load_set(&s, options, out);
    set_free(&s);
    return st;
}

#endif
