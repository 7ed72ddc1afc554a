/* srgb.c -- linear radiance to 8-bit sRGB, fast and exactly by the formula.
 *
 * Every image rayd writes in 8 bits goes through here: the plain render's
 * blocks, and the accumulator of progressive passes (accum.c) when it
 * resolves its sums.  Both must give the same byte for the same double, so
 * there is one table and one rounding, and the AVX-512 path reads the same
 * table as the scalar one.
 */
#include <math.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "base/cpu.h"
#include "math/srgb_curve.h"
#include "render/srgb.h"

/* The sRGB byte of a linear value, by the formula. */
static uint8_t srgb8_exact(double c) {
    if (!(c > 0)) return 0; /* also NaN */
    if (c >= 1) return 255;
    return (uint8_t)(srgb_encode(c) * 255.0 + 0.5);
}

/* The sRGB byte by table.  The edge of byte k, the least linear value whose
 * byte is k (k = 1..255), is found once by bisection over the doubles
 * near it -- ordered like their bit patterns -- against srgb8_exact.  The
 * doubles from 2^-13 (below it every byte is 0) to 1 are cut into 128
 * slices a binade, a slice being the values that share their top 19 bits
 * (exponent and 7 bits of mantissa).  A slice is narrower than a step
 * between bytes, so it holds at most one edge: its entry packs the byte at
 * its low end (bits 48..55) and the low 45 bits of the edge inside it (or
 * 2^45: none).  A value's byte is then one load and one compare away.  One
 * more slice, for 1 and above, holds 255.  The very same bytes as the
 * formula, without three calls of pow a pixel, and without a branch. */
#define SRGB_BINADES 13
#define SRGB_LOW 45 /* the bits below a slice's */
static uint64_t srgb_slice[SRGB_BINADES * 128 + 1];
static pthread_once_t srgb_once = PTHREAD_ONCE_INIT;

static const int64_t srgb_lo = (int64_t)(1023 - SRGB_BINADES) << 52; /* 2^-13 */
static const int64_t srgb_one = (int64_t)1023 << 52;                 /* 1.0 */

static int srgb8_bits(uint64_t bits) {
    double c;
    memcpy(&c, &bits, sizeof c);
    return srgb8_exact(c);
}

/* The bits of the least double in (0, 1] whose byte is k.  The formula's
 * inverse at the step gives a start a few ulps off it (6 at most); a
 * bracket grown from there until it holds the step is then bisected.  About
 * 5 calls of pow a byte, not the 62 of a bisection over all of (0, 1): the
 * table is made in every process, and that one took 2 ms of rayd-render's
 * start. */
static uint64_t srgb_edge(int k) {
    double e = (k - 0.5) / 255.0, one = 1.0;
    double g = srgb_decode(e);
    uint64_t top, lo, hi, step = 1;
    memcpy(&top, &one, sizeof top);
    memcpy(&lo, &g, sizeof lo);
    lo = lo > top ? top : lo;
    hi = lo;
    while (lo > 0 && srgb8_bits(lo) >= k) { /* srgb8_bits(lo) < k */
        lo = lo > step ? lo - step : 0;
        step *= 2;
    }
    for (step = 1; srgb8_bits(hi) < k; step *= 2) /* srgb8_bits(hi) >= k */
        hi = top - hi > step ? hi + step : top;
    while (hi - lo > 1) {
        uint64_t mid = lo + (hi - lo) / 2;
        if (srgb8_bits(mid) >= k)
            hi = mid;
        else
            lo = mid;
    }
    return hi;
}

static void srgb_init(void) {
    uint64_t edge[257];
    for (int k = 1; k < 256; k++) edge[k] = srgb_edge(k);
    edge[256] = UINT64_MAX; /* no byte past 255 */
    const uint64_t none = (uint64_t)1 << SRGB_LOW;
    int k = 0;
    for (int i = 0; i <= SRGB_BINADES * 128; i++) {
        uint64_t start = (uint64_t)srgb_lo + ((uint64_t)i << SRGB_LOW), end = start + none;
        while (edge[k + 1] <= start) k++; /* the byte at the slice's low end */
        bool has = i < SRGB_BINADES * 128 && edge[k + 1] < end;
        uint64_t inside = has ? edge[k + 1] & (none - 1) : none;
        srgb_slice[i] = (uint64_t)k << 48 | inside;
    }
}

/* After srgb_init.  The bits of a double, as a signed integer, order the
 * doubles from -NaN to +NaN; clamped to [2^-13, 1] they find the slice. */
static inline uint8_t srgb8(double c) {
    int64_t bits;
    memcpy(&bits, &c, sizeof bits);
    bits = bits < srgb_lo ? srgb_lo : bits > srgb_one ? srgb_one : bits;
    uint64_t e = srgb_slice[(bits - srgb_lo) >> SRGB_LOW];
    uint64_t low = (uint64_t)bits & (((uint64_t)1 << SRGB_LOW) - 1);
    int k = (int)(e >> 48) + (low >= (e & (((uint64_t)1 << 48) - 1)));
    return c != c ? 0 : (uint8_t)k;
}

#ifdef CPU_AVX512
/* srgb8 of the 48 values v[0..48), 8 at a time, the same integer steps
 * (the table read by gathers) into out[0..48). */
CPU_AVX512_FN void srgb8_48(const double v[48], uint8_t out[48]) {
    const __m512i lo = _mm512_set1_epi64(srgb_lo), one = _mm512_set1_epi64(srgb_one);
    const __m512i low = _mm512_set1_epi64(((int64_t)1 << SRGB_LOW) - 1);
    const __m512i entry = _mm512_set1_epi64(((int64_t)1 << 48) - 1);
    for (int k = 0; k < 48; k += 8) {
        __m512d c = _mm512_loadu_pd(v + k);
        __m512i bits = _mm512_min_epi64(_mm512_max_epi64(_mm512_castpd_si512(c), lo), one);
        __m512i idx = _mm512_srli_epi64(_mm512_sub_epi64(bits, lo), SRGB_LOW);
        __m512i e = _mm512_i64gather_epi64(idx, (const void *)srgb_slice, 8);
        __mmask8 past =
            _mm512_cmpge_epu64_mask(_mm512_and_si512(bits, low), _mm512_and_si512(e, entry));
        __m512i byte = _mm512_mask_add_epi64(_mm512_srli_epi64(e, 48), past,
                                             _mm512_srli_epi64(e, 48), _mm512_set1_epi64(1));
        byte = _mm512_maskz_mov_epi64(_mm512_cmp_pd_mask(c, c, _CMP_ORD_Q), byte); /* NaN: 0 */
        _mm_storel_epi64((__m128i *)(out + k), _mm512_cvtepi64_epi8(byte));
    }
}
#endif

void render_srgb48(const double v[48], uint8_t out[48]) {
    pthread_once(&srgb_once, srgb_init);
#ifdef CPU_AVX512
    if (cpu_avx512()) {
        srgb8_48(v, out);
        return;
    }
#endif
    for (int k = 0; k < 48; k++) out[k] = srgb8(v[k]);
}

uint8_t render_srgb8(double c) {
    pthread_once(&srgb_once, srgb_init);
    return srgb8(c);
}
