/*
 * core/transfer_auto.c — the quick-look transfer function: an opacity ramp
 * over the volume's non-background values and ParaView's default "Cool to
 * Warm" colour map, chosen from the histogram.
 *
 * Background: most scanned volumes are dominated by one peak (air around a
 * CT object, the padding of an MRI, the embedding of the tooth at ~80).
 * On a 256-bin histogram, the peak around the fullest bin ends on each
 * side where a 5-bin average falls below 1 % of the peak's height, or on
 * the right where it turns up by 20 % (a second material). It is a
 * background when it holds at least 20 % of the voxels and its core (above
 * 10 % of its height) spans under 1/8 of the bins; values up to its right
 * end, and every value below it, get opacity 0. The ramp runs from
 * there to the 99.5th percentile of the values above it, so a few extreme
 * voxels (metal, saturation) do not squeeze the ramp, and stays at its top
 * beyond. Without a dominant peak the ramp covers the whole value range, as
 * ParaView's default does.
 *
 * Colours: Moreland's diverging map ("Diverging Color Maps for Scientific
 * Visualization", ISVC 2009; ParaView's default "Cool to Warm"), endpoints
 * sRGB (59, 76, 192) and (180, 4, 38), interpolated in his Msh space (§4-5
 * of the paper) and sampled at VOLUX_TF_AUTO_COLORS points over the ramp.
 * The TF holds linear colours (DESIGN §2: PNG output applies the sRGB
 * curve), so the samples are decoded from sRGB: the image shows the colours
 * a ParaView user knows.
 */
#include <math.h>
#include <string.h>

#include "context_internal.h"
#include "volux/transfer.h"
#include "volux/volume.h"

#define PI_D 3.14159265358979323846
#define AUTO_OPACITY_TOP 0.5f /* α per smallest spacing at the ramp's top */

/* ---- Moreland's Msh colour space (CIELAB in polar form, D65 white) ---- */

static const double white_xyz[3] = {0.9505, 1.0, 1.089};

static double srgb_to_linear(double c) { return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4); }

static double lab_f(double t) { return t > 0.008856 ? cbrt(t) : 7.787 * t + 16.0 / 116.0; }
static double lab_f_inv(double f) { return f > 0.206893 ? f * f * f : (f - 16.0 / 116.0) / 7.787; }

/* Linear sRGB → Msh. */
static void linear_to_msh(const double rgb[3], double msh[3]) {
    double x = 0.4124 * rgb[0] + 0.3576 * rgb[1] + 0.1805 * rgb[2];
    double y = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    double z = 0.0193 * rgb[0] + 0.1192 * rgb[1] + 0.9505 * rgb[2];
    double fx = lab_f(x / white_xyz[0]), fy = lab_f(y / white_xyz[1]), fz = lab_f(z / white_xyz[2]);
    double L = 116.0 * fy - 16.0, a = 500.0 * (fx - fy), b = 200.0 * (fy - fz);
    msh[0] = sqrt(L * L + a * a + b * b);
    msh[1] = msh[0] > 0.0 ? acos(L / msh[0]) : 0.0;
    msh[2] = atan2(b, a);
}

/* Msh → linear sRGB, clamped to [0, 1]. */
static void msh_to_linear(const double msh[3], double rgb[3]) {
    double L = msh[0] * cos(msh[1]), a = msh[0] * sin(msh[1]) * cos(msh[2]), b = msh[0] * sin(msh[1]) * sin(msh[2]);
    double fy = (L + 16.0) / 116.0, fx = fy + a / 500.0, fz = fy - b / 200.0;
    double x = white_xyz[0] * lab_f_inv(fx), y = white_xyz[1] * lab_f_inv(fy), z = white_xyz[2] * lab_f_inv(fz);
    rgb[0] = 3.2406 * x - 1.5372 * y - 0.4986 * z;
    rgb[1] = -0.9689 * x + 1.8758 * y + 0.0415 * z;
    rgb[2] = 0.0557 * x - 0.2040 * y + 1.0570 * z;
    for (int c = 0; c < 3; c++) rgb[c] = rgb[c] < 0.0 ? 0.0 : rgb[c] > 1.0 ? 1.0 : rgb[c];
}

/* The hue a desaturated end takes so the interpolation spins towards the
 * saturated one (Moreland 2009, "AdjustHue"). */
static double adjust_hue(const double msh[3], double m_unsat) {
    if (msh[0] >= m_unsat) return msh[2];
    double spin = msh[1] * sqrt(m_unsat * m_unsat - msh[0] * msh[0]) / (msh[0] * sin(msh[1]));
    return msh[2] > -PI_D / 3.0 ? msh[2] + spin : msh[2] - spin;
}

/* Moreland's diverging interpolation between two colours at t ∈ [0, 1]:
 * through a white of magnitude max(M1, M2, 88) when both ends are
 * saturated and their hues differ by more than 60°. */
static void diverging(const double lin1[3], const double lin2[3], double t, double out[3]) {
    double a[3], b[3];
    linear_to_msh(lin1, a);
    linear_to_msh(lin2, b);
    if (a[1] > 0.05 && b[1] > 0.05 && fabs(a[2] - b[2]) > PI_D / 3.0) {
        double mid = fmax(fmax(a[0], b[0]), 88.0);
        if (t < 0.5) {
            b[0] = mid, b[1] = 0.0, b[2] = 0.0;
            t *= 2.0;
        } else {
            a[0] = mid, a[1] = 0.0, a[2] = 0.0;
            t = 2.0 * t - 1.0;
        }
    }
    if (a[1] < 0.05 && b[1] > 0.05) a[2] = adjust_hue(b, a[0]);
    else if (b[1] < 0.05 && a[1] > 0.05) b[2] = adjust_hue(a, b[0]);
    double m[3];
    for (int c = 0; c < 3; c++) m[c] = (1.0 - t) * a[c] + t * b[c];
    msh_to_linear(m, out);
}

void volux_transfer_auto_colors(double s0, double s1, volux_tf_color_point out[VOLUX_TF_AUTO_COLORS]) {
    /* Moreland 2009, Table/Fig. of the cool-warm map: sRGB 8-bit endpoints. */
    const double cool[3] = {srgb_to_linear(59.0 / 255.0), srgb_to_linear(76.0 / 255.0), srgb_to_linear(192.0 / 255.0)};
    const double warm[3] = {srgb_to_linear(180.0 / 255.0), srgb_to_linear(4.0 / 255.0), srgb_to_linear(38.0 / 255.0)};
    for (int i = 0; i < VOLUX_TF_AUTO_COLORS; i++) {
        double t = (double)i / (VOLUX_TF_AUTO_COLORS - 1), rgb[3];
        diverging(cool, warm, t, rgb);
        out[i] = (volux_tf_color_point){(float)(s0 + t * (s1 - s0)), (float)rgb[0], (float)rgb[1], (float)rgb[2]};
    }
}

/* ---- the histogram analysis ---- */

static double smooth_at(const uint64_t *count, int bins, int b) {
    double sum = 0.0;
    int n = 0;
    for (int k = b - 2; k <= b + 2; k++)
        if (k >= 0 && k < bins) sum += (double)count[k], n++;
    return sum / n;
}

volux_status volux_transfer_auto_from_volume(volux_context *ctx, const volux_volume *v, volux_transfer_auto *out) {
    memset(out, 0, sizeof *out);
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    /* One bin per value for integer data (up to 4096 bins), else 1024. */
    /* 256 bins: one per value for 8-bit data; for wider data, noise in a
     * background (CT air) then lands in a few bins instead of hundreds. */
    int bins = 256;
    int integer = volux_volume_type(v) != VOLUX_FLOAT32 && volux_volume_type(v) != VOLUX_FLOAT64;
    double s_lo = lo, s_hi = hi;
    if (hi > lo && bins > 1) {
        uint64_t *count = volux_calloc(ctx, (size_t)bins, sizeof *count);
        if (!count) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a histogram");
        volux_volume_histogram(v, bins, count);
        uint64_t total = 0;
        int mode = 0;
        for (int b = 0; b < bins; b++) {
            total += count[b];
            if (count[b] > count[mode]) mode = b;
        }
        /* Walks run on a 5-bin box average, so single-bin noise neither
         * ends a flank early nor looks like a second material. */
#define SMOOTH(b) smooth_at(count, bins, (b))
        double peak = SMOOTH(mode), floor_level = 0.01 * peak;
        int right = mode + 1;
        double run_min = peak;
        while (right < bins && SMOOTH(right) >= floor_level && SMOOTH(right) <= 1.2 * run_min) {
            if (SMOOTH(right) < run_min) run_min = SMOOTH(right);
            right++;
        }
        int left = mode;
        while (left > 0 && SMOOTH(left - 1) >= floor_level) left--;
        /* The core: where the peak stands above 10 % of its height. */
        int core_lo = mode, core_hi = mode;
        while (core_lo > 0 && SMOOTH(core_lo - 1) >= 0.1 * peak) core_lo--;
        while (core_hi + 1 < bins && SMOOTH(core_hi + 1) >= 0.1 * peak) core_hi++;
#undef SMOOTH
        uint64_t mass = 0;
        for (int b = left; b < right; b++) mass += count[b];
        /* A background is one narrow peak holding much of the volume (air,
         * padding, embedding); a broad distribution (a simulation field)
         * has none and keeps ParaView's full-range ramp. */
        int start = 0; /* first bin of the ramp */
        if ((double)mass >= 0.2 * (double)total && core_hi - core_lo < bins / 8 && right < bins) {
            start = right;
            out->has_background = 1;
        }
        uint64_t above = 0;
        for (int b = start; b < bins; b++) above += count[b];
        /* 99.5th percentile of the values the ramp covers. */
        uint64_t seen = 0;
        int top = bins - 1;
        for (int b = start; b < bins; b++) {
            seen += count[b];
            if ((double)seen >= 0.995 * (double)above) {
                top = b;
                break;
            }
        }
        volux_free(ctx, count, (size_t)bins * sizeof *count);
        double width = (hi - lo) / bins;
        s_lo = lo + start * width;
        s_hi = lo + (top + 1) * width;
        if (integer) { /* whole file values, for a readable TF */
            s_lo = floor(s_lo);
            s_hi = ceil(s_hi);
        }
        if (s_hi > hi) s_hi = hi;
        if (!(s_hi > s_lo)) s_hi = hi > s_lo ? hi : s_lo + 1.0;
    } else {
        s_hi = lo + 1.0; /* a constant volume: the ramp ends just above it */
        s_lo = lo - 1.0;
    }
    out->ramp_start = s_lo;
    out->ramp_end = s_hi;
    out->opacity[0] = (volux_tf_scalar_point){(float)s_lo, 0.0f};
    out->opacity[1] = (volux_tf_scalar_point){(float)s_hi, AUTO_OPACITY_TOP};
    out->n_opacity = 2;
    volux_transfer_auto_colors(s_lo, s_hi, out->color);
    out->n_color = VOLUX_TF_AUTO_COLORS;
    return VOLUX_OK;
}

void volux_transfer_auto_desc(const volux_transfer_auto *a, volux_transfer_desc *d) {
    volux_transfer_desc_defaults(d);
    d->color = a->color;
    d->n_color = a->n_color;
    d->opacity = a->opacity;
    d->n_opacity = a->n_opacity;
}
