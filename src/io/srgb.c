/* io/srgb.c — the sRGB transfer function (IEC 61966-2-1:1999, §5.2 and
 * §5.3): a linear segment near black joined to a 2.4 power curve. Computed
 * in double so 8-bit encodes round the same way on every platform. */
#include <math.h>
#include <pthread.h>
#include <string.h>

#include "image_formats.h"
#include "volux/io.h"

float volux_srgb_encode(float linear) {
    double v = linear;
    if (v <= 0.0031308) return (float)(12.92 * v);
    return (float)(1.055 * pow(v, 1.0 / 2.4) - 0.055);
}

float volux_srgb_decode(float encoded) {
    double s = encoded;
    if (s <= 0.04045) return (float)(s / 12.92);
    return (float)pow((s + 0.055) / 1.055, 2.4);
}

/* The 8-bit code of one tone-mapped value, by definition. */
static unsigned char code_of(float v) {
    float s = v > 0.0f ? volux_srgb_encode(v) : 0.0f; /* NaN and negatives → black */
    if (s > 1.0f) s = 1.0f;
    return (unsigned char)(s * 255.0f + 0.5f);
}

/* code_of is monotonic in v (pow, the roundings and the truncation all
 * are), so it is a step function: threshold[k] is the smallest positive
 * float whose code is ≥ k. Looking a value up among the 255 thresholds
 * gives exactly code_of's byte for ~8 comparisons instead of a pow() —
 * tone mapping a 512² image drops from ~30 ms to ~2 ms. */
static float threshold[256];
static pthread_once_t threshold_once = PTHREAD_ONCE_INIT;

static void build_thresholds(void) {
    threshold[0] = 0.0f;
    for (int k = 1; k < 256; k++) {
        /* Positive floats order like their bit patterns: bisect on those. */
        uint32_t lo = 0, hi = 0x7f800000u; /* code(0) = 0 < k ≤ code(+inf) = 255 */
        while (hi - lo > 1) {
            uint32_t mid = lo + (hi - lo) / 2;
            float f;
            memcpy(&f, &mid, sizeof f);
            if (code_of(f) >= k) hi = mid;
            else lo = mid;
        }
        memcpy(&threshold[k], &hi, sizeof hi);
    }
}

unsigned char volux_srgb8(float v) {
    if (!(v > 0.0f)) return 0;
    /* Binary search: the number of thresholds[1..255] that are ≤ v. */
    int lo = 0; /* threshold[lo] <= v */
    for (int step = 128; step; step >>= 1)
        if (lo + step < 256 && threshold[lo + step] <= v) lo += step;
    return (unsigned char)lo;
}

void volux_srgb8_init(void) { pthread_once(&threshold_once, build_thresholds); }

unsigned char volux_srgb8_reference(float v) { return code_of(v); }

void volux_image_to_srgb8(const volux_image *img, float exposure, unsigned char *out) {
    volux_srgb8_init();
    float scale = exp2f(exposure);
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    for (size_t i = 0; i < n; i++) out[i] = volux_srgb8(img->rgb[i] * scale);
}
