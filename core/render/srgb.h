/* srgb.h -- linear values to 8-bit sRGB bytes (srgb.c). */
#ifndef SRGB_H
#define SRGB_H

#include <stdint.h>

/* The sRGB byte of a linear value (0 for NaN and below 0, 255 from 1). */
uint8_t render_srgb8(double c);
/* The same for 48 values at once (a 4x4 block's channels), 8 at a time
 * with AVX-512 where it runs: out[k] = render_srgb8(v[k]). */
void render_srgb48(const double v[48], uint8_t out[48]);

#endif
