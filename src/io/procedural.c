/*
 * io/procedural.c — volumes defined by a formula, for tests, demos and
 * comparisons with other renderers.
 *
 * Node (i,j,k) maps to p = −1 + i·2/(n−1) per axis, so every volume spans
 * [−1,1]³ in its own normalized coordinates whatever the dims (a size-1
 * axis maps to 0). Values are rounded to the nearest integer and clamped
 * to 0..255 (uint8), except "constant" (float32 1.0). The coordinate and
 * rounding conventions are those of the volume generator the peer
 * renderers (VTK, VolPack, Teem comparisons) use, so that "marschner_lobb"
 * and "phantom" at N³ equal their ml/phantom N³ uint8 volumes value for
 * value.
 */
#include <math.h>
#include <string.h>

#include "core/parallel.h"
#include "core/rng.h"
#include "core/volume_internal.h"
#include "volume_formats.h"

#define PI 3.14159265358979323846

static double clamp01(double v) { return v < 0.0 ? 0.0 : v > 1.0 ? 1.0 : v; }
static double smoothstep01(double t) {
    t = clamp01(t);
    return t * t * (3.0 - 2.0 * t);
}

/* ---------------------------------------------------------------- sphere */

/* A ball touching the box faces whose value falls smoothly from 255 at the
 * centre to 0 at radius 1: a nonzero gradient almost everywhere, so it
 * shades well and every iso-value is a sphere. */
static double sphere(double x, double y, double z, double vox, const void *user) {
    (void)vox;
    (void)user;
    double r = sqrt(x * x + y * y + z * z);
    return 255.0 * (1.0 - smoothstep01(r));
}

/* ---------------------------------------------------------------- Marschner–Lobb */

/* Marschner & Lobb, "An evaluation of reconstruction filters for volume
 * rendering", IEEE Visualization 1994, Eq. 7–8, with f_M = 6, α = 0.25:
 *   ρ_r(r) = cos(2π f_M cos(π r / 2)),
 *   ρ(x,y,z) = (1 − sin(π z / 2) + α (1 + ρ_r(√(x²+y²)))) / (2 (1 + α)),
 * which lies in [0, 1]; scaled by 255. */
static double marschner_lobb(double x, double y, double z, double vox, const void *user) {
    (void)vox;
    (void)user;
    const double f_m = 6.0, alpha = 0.25;
    double r = sqrt(x * x + y * y);
    double rho_r = cos(2.0 * PI * f_m * cos(PI * r / 2.0));
    return 255.0 * ((1.0 - sin(PI * z / 2.0) + alpha * (1.0 + rho_r)) / (2.0 * (1.0 + alpha)));
}

/* ---------------------------------------------------------------- phantom */

/* An object with a soft skin: outside, the value ramps from 0 to `base`
 * over the last 2 voxels; inside, it rises linearly from `base` at the
 * surface to `top` at depth `depth` voxels, so no region is flat. */
static double shell(double d_vox, double depth, double base, double top) {
    if (d_vox >= 0.0) return base * clamp01(1.0 - d_vox / 2.0);
    return base + (top - base) * clamp01(-d_vox / depth);
}

/* The peers' orientation phantom, objects given by signed distances
 * (negative inside), the largest value wins:
 *   torus about +Y, radii 0.45 / 0.16 ........ 60 → 120
 *   sphere at (0.72, 0, 0), radius 0.2 ......... 140 → 170   (+X)
 *   sphere at (0, 0.72, 0), radius 0.12 ........ 190 → 220   (+Y)
 *   cube at (0, 0, 0.72), half size 0.12 ....... 240 → 255   (+Z)
 * The distinct bands let a transfer function tell the axes apart. */
static double phantom(double x, double y, double z, double vox, const void *user) {
    (void)user;
    double v = 0.0;
    double ring = sqrt(x * x + z * z) - 0.45;
    double d = sqrt(ring * ring + y * y) - 0.16;
    v = fmax(v, shell(d / vox, 0.16 / vox, 60.0, 120.0));
    d = sqrt((x - 0.72) * (x - 0.72) + y * y + z * z) - 0.2;
    v = fmax(v, shell(d / vox, 0.2 / vox, 140.0, 170.0));
    d = sqrt(x * x + (y - 0.72) * (y - 0.72) + z * z) - 0.12;
    v = fmax(v, shell(d / vox, 0.12 / vox, 190.0, 220.0));
    /* Box distance: length of the outside part plus the (negative) largest
     * inside component. */
    double q[3] = {fabs(x) - 0.12, fabs(y) - 0.12, fabs(z - 0.72) - 0.12};
    double out2 = 0.0, inside = fmax(q[0], fmax(q[1], q[2]));
    for (int a = 0; a < 3; a++)
        if (q[a] > 0.0) out2 += q[a] * q[a];
    d = sqrt(out2) + fmin(inside, 0.0);
    v = fmax(v, shell(d / vox, 0.12 / vox, 240.0, 255.0));
    return v;
}

/* ---------------------------------------------------------------- cloud */

/* Value noise: random values at integer lattice points, blended with the
 * quintic fade 6t⁵ − 15t⁴ + 10t³ (Perlin, "Improving noise", SIGGRAPH 2002)
 * so the field has continuous gradients; summed over octaves (fBm). The
 * lattice values are a hash of (seed, octave, point): deterministic. */
static double lattice(uint64_t key, int64_t x, int64_t y, int64_t z) {
    uint64_t h = volux_mix64(key ^ ((uint64_t)x * 0x9e3779b97f4a7c15ull));
    h = volux_mix64(h ^ ((uint64_t)y * 0xc2b2ae3d27d4eb4full));
    h = volux_mix64(h ^ ((uint64_t)z * 0x165667b19e3779f9ull));
    return (double)(h >> 11) * (1.0 / 9007199254740992.0);
}

static double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

static double value_noise(uint64_t key, double x, double y, double z) {
    double fx = floor(x), fy = floor(y), fz = floor(z);
    int64_t ix = (int64_t)fx, iy = (int64_t)fy, iz = (int64_t)fz;
    double u = fade(x - fx), v = fade(y - fy), w = fade(z - fz);
    double c[2][2];
    for (int k = 0; k < 2; k++)
        for (int j = 0; j < 2; j++) {
            double a = lattice(key, ix, iy + j, iz + k), b = lattice(key, ix + 1, iy + j, iz + k);
            c[k][j] = a + (b - a) * u;
        }
    double c0 = c[0][0] + (c[0][1] - c[0][0]) * v, c1 = c[1][0] + (c[1][1] - c[1][0]) * v;
    return c0 + (c1 - c0) * w;
}

/* What the field functions read: the seed, and the time of the animated
 * cloud. */
typedef struct field_params {
    uint64_t seed;
    double time;
} field_params;

/* Five octaves from 4 lattice cells across the box; a threshold below the
 * mean leaves empty gaps between puffs, and a soft spherical envelope keeps
 * the cloud off the box faces.
 *
 * Animation: at time t octave o is advected by t·(0.6 + 0.4·o) lattice
 * cells of its own frequency along a fixed direction u_o (a hash of the
 * seed and o). The octaves drift at different speeds and in different
 * directions, so the puffs change shape instead of only moving, smoothly
 * in t; the envelope stays put, so the cloud never leaves the box. At t = 0
 * the field is exactly the static cloud. */
static double cloud(double x, double y, double z, double vox, const void *user) {
    (void)vox;
    const field_params *fp = user;
    double sum = 0.0, amp = 1.0, norm = 0.0, freq = 2.0;
    for (int o = 0; o < 5; o++) {
        uint64_t key = volux_mix64(fp->seed * 0x9e3779b97f4a7c15ull + (uint64_t)o + 1);
        double px = (x + 1.0) * freq, py = (y + 1.0) * freq, pz = (z + 1.0) * freq;
        if (fp->time != 0.0) {
            /* u_o: uniform on the sphere from two hashed numbers */
            uint64_t h = volux_mix64(key ^ 0x5bd1e995ull);
            double uz = 1.0 - 2.0 * (double)(h >> 40) / 16777216.0;
            double phi = 2.0 * PI * (double)(h & 0xffffffull) / 16777216.0, ur = sqrt(fmax(0.0, 1.0 - uz * uz));
            double shift = fp->time * (0.6 + 0.4 * o);
            px += shift * ur * cos(phi);
            py += shift * ur * sin(phi);
            pz += shift * uz;
        }
        sum += amp * value_noise(key, px, py, pz);
        norm += amp;
        amp *= 0.5;
        freq *= 2.0;
    }
    double fbm = sum / norm; /* in [0, 1], mean 0.5 */
    double r = sqrt(x * x + y * y + z * z);
    double envelope = 1.0 - smoothstep01((r - 0.5) / 0.45);
    return 255.0 * clamp01((fbm - 0.36) * 3.0) * envelope;
}

/* ---------------------------------------------------------------- row intervals */

/* Where a field can be nonzero along one row (fixed y, z): up to
 * ROW_SPANS closed x intervals (normalized coordinates) outside which the
 * field is exactly 0, so the generator writes 0 there without evaluating
 * it. Conservative by construction: an interval may be too wide, never too
 * narrow, so the volume is bit-identical to evaluating every node. */
#define ROW_SPANS 6
typedef int (*row_span_fn)(double y, double z, double vox, double span[ROW_SPANS][2]);

/* The x interval of a ball of radius r about c on the row, or 0 if the row
 * misses it: |p − c| ≤ r ⇔ |x − cx| ≤ √(r² − (y−cy)² − (z−cz)²). */
static int ball_span(double y, double z, const double c[3], double r, double span[2]) {
    double h = r * r - (y - c[1]) * (y - c[1]) - (z - c[2]) * (z - c[2]);
    if (h < 0.0) return 0;
    h = sqrt(h);
    span[0] = c[0] - h;
    span[1] = c[0] + h;
    return 1;
}

/* Skin margin: shell() is exactly 0 at d ≥ 2 voxels; a little more for the
 * rounding of the distances (|coordinates| ≤ 1, errors ~1e−15). */
static double skin(double vox) { return 2.0 * vox + 1e-9; }

/* phantom: each object's value is 0 where its distance exceeds the skin,
 * and fmax(v, 0) = v, so outside every object's interval the value is 0.
 * Torus about +Y (radii 0.45/0.16): at height y the tube's cross-section
 * is the annulus 0.45 ± w, w = √((0.16+m)² − y²), in the xz plane. */
static int phantom_spans(double y, double z, double vox, double span[ROW_SPANS][2]) {
    double m = skin(vox);
    int n = 0;
    double w2 = (0.16 + m) * (0.16 + m) - y * y;
    if (w2 >= 0.0) {
        double w = sqrt(w2), ro = 0.45 + w, ri = 0.45 - w;
        double ho = ro * ro - z * z;
        if (ho >= 0.0) {
            double xo = sqrt(ho), hi = ri > 0.0 ? ri * ri - z * z : -1.0;
            if (hi > 0.0) { /* the hole splits the row in two */
                double xi = sqrt(hi);
                span[n][0] = -xo, span[n++][1] = -xi;
                span[n][0] = xi, span[n++][1] = xo;
            } else {
                span[n][0] = -xo, span[n++][1] = xo;
            }
        }
    }
    static const double c1[3] = {0.72, 0.0, 0.0}, c2[3] = {0.0, 0.72, 0.0};
    n += ball_span(y, z, c1, 0.2 + m, span[n]);
    n += ball_span(y, z, c2, 0.12 + m, span[n]);
    /* cube at (0, 0, 0.72), half size 0.12: its distance exceeds the
     * largest axis excess, so outside the slab box it is beyond the skin */
    double hc = 0.12 + m;
    if (fabs(y) <= hc && fabs(z - 0.72) <= hc) span[n][0] = -hc, span[n++][1] = hc;
    return n;
}

/* cloud: the envelope 1 − smoothstep((r − 0.5)/0.45) is exactly 0 for
 * r ≥ 0.95, and 255·clamp01(·)·0 = 0. */
static int cloud_spans(double y, double z, double vox, double span[ROW_SPANS][2]) {
    static const double c[3] = {0.0, 0.0, 0.0};
    return ball_span(y, z, c, 0.95 + skin(vox), span[0]);
}

/* ---------------------------------------------------------------- driver */

typedef double (*field_fn)(double x, double y, double z, double vox, const void *user);

static const struct {
    const char *name;
    field_fn fn;
    row_span_fn spans; /* NULL: evaluate every node */
} fields[] = {
    {"sphere", sphere, NULL},   {"marschner_lobb", marschner_lobb, NULL}, {"cloud", cloud, cloud_spans},
    {"phantom", phantom, phantom_spans}, {"constant", NULL, NULL},
};

/* The fields that change with time (the others ignore it). */
static int animated(field_fn fn) { return fn == cloud; }

const char *volux_procedural_names(void) { return "sphere, marschner_lobb, cloud, phantom, constant"; }

/* One row, slice or whole volume of uint8 nodes: the nodes from `lo` of a
 * whole grid of n nodes (a brick, or the whole at 0), filled with
 * round(fn) clamped to 0..255. */
typedef struct fill_job {
    volux_volume *v;
    int n[3], lo[3];
    double step[3], vox;
    field_fn fn;
    row_span_fn spans;
    const void *user;
} fill_job;

static void fill_node(const fill_job *jb, uint8_t *row, int ii, double y, double z) {
    int i = jb->lo[0] + ii;
    double x = jb->n[0] > 1 ? -1.0 + i * jb->step[0] : 0.0;
    long w = lround(jb->fn(x, y, z, jb->vox, jb->user));
    row[ii] = (uint8_t)(w < 0 ? 0 : w > 255 ? 255 : w);
}

/* One slice kk: every node is a pure function of its index, so slices run
 * in any order on any number of threads with the same bytes. */
static void fill_slice(void *user, int64_t kk, int thread) {
    (void)thread;
    const fill_job *jb = user;
    volux_volume *v = jb->v;
    int nx = v->dims[0];
    int k = jb->lo[2] + (int)kk;
    double z = jb->n[2] > 1 ? -1.0 + k * jb->step[2] : 0.0;
    for (int jj = 0; jj < v->dims[1]; jj++) {
        int j = jb->lo[1] + jj;
        double y = jb->n[1] > 1 ? -1.0 + j * jb->step[1] : 0.0;
        uint8_t *row = (uint8_t *)v->data + volux_volume_index(v, 0, jj, (int)kk);
        if (!jb->spans || jb->n[0] < 2) {
            for (int ii = 0; ii < nx; ii++) fill_node(jb, row, ii, y, z);
            continue;
        }
        /* mark the nodes inside any interval (one node of slack each side),
         * zero the rest */
        double span[ROW_SPANS][2];
        int ns = jb->spans(y, z, jb->vox, span);
        memset(row, 0, (size_t)nx);
        for (int s = 0; s < ns; s++) {
            /* x = −1 + i·step: i = (x + 1)/step */
            double a = floor((span[s][0] + 1.0) / jb->step[0]) - 1.0 - jb->lo[0];
            double b = ceil((span[s][1] + 1.0) / jb->step[0]) + 1.0 - jb->lo[0];
            int i0 = a < 0.0 ? 0 : a > nx ? nx : (int)a;
            int i1 = b < 0.0 ? -1 : b > nx - 1 ? nx - 1 : (int)b;
            /* overlapping intervals evaluate a node twice: same value */
            for (int ii = i0; ii <= i1; ii++) fill_node(jb, row, ii, y, z);
        }
    }
}

static void fill_u8(volux_volume *v, const int n[3], const int lo[3], field_fn fn, row_span_fn spans,
                    const void *user, int threads) {
    fill_job jb = {.v = v, .fn = fn, .spans = spans, .user = user};
    for (int a = 0; a < 3; a++) {
        jb.n[a] = n[a];
        jb.lo[a] = lo[a];
        jb.step[a] = n[a] > 1 ? 2.0 / (n[a] - 1) : 0.0;
    }
    /* Skin widths are in voxels of the finest axis (all equal for N³). */
    jb.vox = 2.0;
    for (int a = 0; a < 3; a++)
        if (n[a] > 1 && jb.step[a] < jb.vox) jb.vox = jb.step[a];
    volux_parallel_for(threads, v->dims[2], fill_slice, &jb);
}

static volux_status procedural(volux_context *ctx, const char *name, const int dims[3], uint64_t seed, double time,
                               const volux_volume_region *region, int exhaustive, volux_volume **out) {
    int which = -1;
    for (size_t i = 0; name && i < sizeof fields / sizeof fields[0]; i++)
        if (strcmp(name, fields[i].name) == 0) which = (int)i;
    if (which < 0)
        return volux_error(ctx, VOLUX_ERR_INVALID, "procedural: unknown volume '%s' (known: %s)", name ? name : "(null)",
                           volux_procedural_names());
    field_fn fn = fields[which].fn;
    if (!isfinite(time) || fabs(time) > 1e6)
        return volux_error(ctx, VOLUX_ERR_INVALID, "procedural:%s: time %g is outside [-1e6, 1e6]", name, time);
    if (time != 0.0 && !animated(fn))
        return volux_error(ctx, VOLUX_ERR_INVALID, "procedural:%s: not animated (only cloud has a time)", name);
    int lo[3] = {0, 0, 0}, hi[3] = {dims[0], dims[1], dims[2]}, sub[3];
    volux_status st;
    if (region) {
        char label[64];
        snprintf(label, sizeof label, "procedural:%.40s", name);
        /* the whole grid's dims are checked like a whole volume's */
        for (int a = 0; a < 3; a++)
            if (dims[a] < 1 || dims[a] > VOLUX_MAX_DIM)
                return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: dims[%d] = %d is outside [1, %d]", label, a, dims[a],
                                   VOLUX_MAX_DIM);
        if ((st = volux_region_box(ctx, label, dims, region, lo, hi))) return st;
    }
    for (int a = 0; a < 3; a++) sub[a] = hi[a] - lo[a];
    volux_volume *v;
    st = volux_volume_create_storage(ctx, sub, NULL, fn ? VOLUX_UINT8 : VOLUX_FLOAT32, &v);
    if (st) {
        volux_error_prefix(ctx, "procedural:%s: ", name);
        return st;
    }
    if (fn) {
        field_params fp = {seed, time};
        fill_u8(v, dims, lo, fn, exhaustive ? NULL : fields[which].spans, &fp, volux_context_threads(ctx));
    } else {
        size_t count = (size_t)sub[0] * (size_t)sub[1] * (size_t)sub[2];
        float *f = v->data;
        for (size_t i = 0; i < count; i++) f[i] = 1.0f;
    }
    double whole_origin[3], part_origin[3], one[3] = {1, 1, 1};
    volux_brick_origin(dims, one, NULL, lo, whole_origin, part_origin);
    st = volux_volume_finalize(v, region ? part_origin : NULL);
    if (st) {
        volux_volume_release(v);
        return st;
    }
    if (region) volux_volume_make_part(v, region->count, region->index, dims, lo, whole_origin);
    *out = v;
    return VOLUX_OK;
}

volux_status volux_volume_procedural_at(volux_context *ctx, const char *name, const int dims[3], uint64_t seed,
                                        double time, volux_volume **out) {
    return procedural(ctx, name, dims, seed, time, NULL, 0, out);
}

volux_status volux_volume_procedural_region(volux_context *ctx, const char *name, const int dims[3], uint64_t seed,
                                            const volux_volume_region *region, volux_volume **out) {
    if (!region) return volux_error(ctx, VOLUX_ERR_INVALID, "procedural: region is NULL");
    return procedural(ctx, name, dims, seed, 0.0, region, 0, out);
}

volux_status volux_procedural_exhaustive(volux_context *ctx, const char *name, const int dims[3], uint64_t seed,
                                         const volux_volume_region *region, volux_volume **out) {
    return procedural(ctx, name, dims, seed, 0.0, region, 1, out);
}

volux_status volux_volume_procedural(volux_context *ctx, const char *name, const int dims[3], uint64_t seed,
                                     volux_volume **out) {
    return volux_volume_procedural_at(ctx, name, dims, seed, 0.0, out);
}

int volux_procedural_is_animated(const char *name) {
    for (size_t i = 0; name && i < sizeof fields / sizeof fields[0]; i++)
        if (strcmp(name, fields[i].name) == 0) return animated(fields[i].fn);
    return 0;
}
