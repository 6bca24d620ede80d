/* io/srgb.c — the sRGB transfer function (IEC 61966-2-1:1999, §5.2 and
 * §5.3): a linear segment near black joined to a 2.4 power curve. Computed
 * in double so 8-bit encodes round the same way on every platform. */
#include <math.h>

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
