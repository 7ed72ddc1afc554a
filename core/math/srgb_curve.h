/* srgb_curve.h -- the sRGB transfer function of IEC 61966-2-1, both ways,
 * for values in [0, 1].
 *
 * One formula for every encoder and decoder: render/srgb.c's 8-bit table
 * (its edges found with srgb_decode, checked with srgb_encode), codec/png.c's
 * 16-bit PNG and shade/texture.c's 8-bit textures.  Kept in one place so
 * the 8-bit and 16-bit images cannot drift apart by a changed constant.
 */
#ifndef SRGB_CURVE_H
#define SRGB_CURVE_H

#include <math.h>

/* Linear c in [0, 1] to its sRGB-encoded value in [0, 1]. */
static inline double srgb_encode(double c) {
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

/* An sRGB-encoded e in [0, 1] to linear. */
static inline double srgb_decode(double e) {
    return e <= 0.04045 ? e / 12.92 : pow((e + 0.055) / 1.055, 2.4);
}

#endif
