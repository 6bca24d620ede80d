/*
 * tools/viewer/exposure.c — the viewer's automatic exposure: the EV that
 * brings the mean *displayed* luminance of a frame's volume pixels to a
 * fixed target, from the frame alone (no reference image).
 *
 * Why the displayed mean and not a log-average: what the user compares
 * when switching technique is the picture on screen, after the PNG tone
 * mapping (×2^EV, sRGB curve, clamp). A log-average matched to middle grey
 * (Reinhard et al. 2002, eq. 1) lets a technique with bright highlights
 * and one without end at different displayed means once the clamp bites;
 * solving for the displayed mean itself makes the switch keep it by
 * construction (the mean is monotonic in EV, so bisection finds it).
 *
 * Volume pixels are the ones that differ from the scene's background
 * colour (rays that met no material return it exactly); when almost none
 * do (a visible environment map, a volume that fills the frame) every
 * pixel counts.
 */
#include <math.h>
#include <stdlib.h>

#include "viewer.h"

/* Rec. 709 luminance weights (of the displayed, sRGB-encoded values). */
#define LUMA_R 0.2126f
#define LUMA_G 0.7152f
#define LUMA_B 0.0722f

/* A pixel belongs to the volume when a channel differs from the
 * background by more than this (absolute + relative to the background). */
#define BACKGROUND_TOLERANCE 1e-3f

/* Below this share of volume pixels every pixel is used. */
#define MIN_VOLUME_SHARE 0.01

static float displayed(float linear, float scale) {
    float v = linear * scale;
    if (!(v > 0.0f)) return 0.0f; /* NaN and negatives are black, as in PNG output */
    return v >= 1.0f ? 1.0f : volux_srgb_encode(v);
}

/* At most this many pixels are looked at (an even subsample of larger
 * frames): 40 bisection steps over them take a few ms. */
#define MAX_SAMPLES 65536

typedef struct samples {
    const volux_image *img;
    size_t stride;         /* every stride-th pixel */
    unsigned char *mask;   /* per sample: a volume pixel; NULL = all */
} samples;

static double mean_displayed(const samples *s, float ev) {
    const float scale = exp2f(ev);
    const size_t n = (size_t)s->img->width * (size_t)s->img->height;
    double sum = 0;
    size_t count = 0;
    for (size_t i = 0, j = 0; i < n; i += s->stride, j++) {
        if (s->mask && !s->mask[j]) continue;
        const float *p = s->img->rgb + 3 * i;
        sum += LUMA_R * displayed(p[0], scale) + LUMA_G * displayed(p[1], scale) + LUMA_B * displayed(p[2], scale);
        count++;
    }
    return count ? sum / (double)count : 0;
}

/* The samples and which of them are volume pixels; 0 on NOMEM. */
static int sample(const volux_image *img, volux_vec3 background, samples *s) {
    const size_t n = (size_t)img->width * (size_t)img->height;
    s->img = img;
    s->stride = n > MAX_SAMPLES ? (n + MAX_SAMPLES - 1) / MAX_SAMPLES : 1;
    const size_t m = n ? (n + s->stride - 1) / s->stride : 0;
    s->mask = malloc(m ? m : 1);
    if (!s->mask) return 0;
    const float bg[3] = {background.x, background.y, background.z};
    size_t fg = 0;
    for (size_t i = 0, j = 0; i < n; i += s->stride, j++) {
        const float *p = img->rgb + 3 * i;
        int differs = 0;
        for (int k = 0; k < 3; k++) differs |= fabsf(p[k] - bg[k]) > BACKGROUND_TOLERANCE * (1.0f + fabsf(bg[k]));
        s->mask[j] = (unsigned char)differs;
        fg += (size_t)differs;
    }
    if ((double)fg < MIN_VOLUME_SHARE * (double)m) {
        free(s->mask);
        s->mask = NULL;
    }
    return 1;
}

double viewer_displayed_mean(const volux_image *img, volux_vec3 background, float ev) {
    samples s;
    if (!sample(img, background, &s)) return -1;
    double m = mean_displayed(&s, ev);
    free(s.mask);
    return m;
}

int viewer_auto_exposure(const volux_image *img, volux_vec3 background, float *ev_out) {
    samples s;
    if (!sample(img, background, &s)) return 0;
    /* the bracket: render.exposure's own range is [-64, 64]; ±24 EV
     * covers 1e-7 … 1e7 in radiance, far beyond any lit technique's spread */
    float lo = -24.0f, hi = 24.0f;
    int ok = mean_displayed(&s, hi) >= 1e-4; /* black: nothing to expose */
    for (int it = 0; ok && it < 40 && hi - lo > 0.01f; it++) {
        float mid = 0.5f * (lo + hi);
        if (mean_displayed(&s, mid) < VIEWER_EXPOSURE_TARGET) lo = mid;
        else hi = mid;
    }
    free(s.mask);
    /* rounded to the page slider's step, so the value reads cleanly */
    if (ok) *ev_out = roundf(0.5f * (lo + hi) * 20.0f) / 20.0f;
    return ok;
}
