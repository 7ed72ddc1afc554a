/* json_numbers.c -- the numbers of a large inline mesh array, read from the
 * scene text without cJSON.
 *
 * The result must be the mesh cJSON's path gives, bit for bit, so each
 * number becomes the double strtod gives (cJSON calls strtod on a copy of at
 * most 63 characters with '.' made the locale's decimal point), and the
 * caller casts or checks that double as the cJSON path does.  strtod is a
 * quarter of the time, so most numbers take the exact fast path instead
 * (Clinger, 1990): when the significant digits fit in 53 bits and the power
 * of ten is at most 22, both are exact doubles and one IEEE multiply or
 * divide rounds their product correctly, which is what strtod returns.  The
 * rest (long mantissas, large exponents) go to strtod as cJSON calls it.
 *
 * The array is cut into blocks of bytes, a fixed size whatever the thread
 * count; a first pass counts the separators ('[' and ',') of each block so
 * each knows the index of its first element, a second parses each block's
 * elements into place.  Blocks run on threads (base/parallel.c); each
 * stops at its own first bad number and the lowest such index wins, so the
 * error is the one a reading in order meets first.
 */
#include "format/json_numbers.h"

#include <locale.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "base/parallel.h"

#define JN_BLOCK (64u << 10) /* bytes a block */

static const double pow10_exact[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                       1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                       1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

static bool is_digit(char ch) { return ch >= '0' && ch <= '9'; }

/* As cJSON 1.7.15 parse_number: at most 63 characters of the number's
 * alphabet, '.' as the locale's decimal point, then strtod. */
static double number_strtod(const char *s, const char **end, char point) {
    char buf[64];
    size_t n = 0;
    for (; n < 63 && s[n] && strchr("0123456789+-eE.", s[n]); n++)
        buf[n] = s[n] == '.' ? point : s[n];
    buf[n] = 0;
    *end = s + n;
    return strtod(buf, NULL);
}

double json_number(const char **s, char point) {
    const char *p = *s;
    bool neg = *p == '-';
    uint64_t m = 0;
    int digits = 0, exp10 = 0;
    p += neg;
    for (; is_digit(*p); p++) {
        if (m == 0 && *p == '0') continue;
        m = m * 10 + (uint64_t)(*p - '0');
        if (++digits > 19) return number_strtod(*s, s, point);
    }
    if (*p == '.')
        for (p++; is_digit(*p); p++, exp10--) {
            if (m == 0 && *p == '0') continue;
            m = m * 10 + (uint64_t)(*p - '0');
            if (++digits > 19) return number_strtod(*s, s, point);
        }
    if (*p == 'e' || *p == 'E') {
        p++;
        bool eneg = *p == '-';
        int e = 0;
        if (*p == '+' || *p == '-') p++;
        for (; is_digit(*p); p++)
            if (e < 100000) e = e * 10 + (*p - '0');
        exp10 += eneg ? -e : e;
    }
    if (m > (1ull << 53) || exp10 < -22 || exp10 > 22) return number_strtod(*s, s, point);
    *s = p;
    double d = exp10 < 0 ? (double)m / pow10_exact[-exp10] : (double)m * pow10_exact[exp10];
    return neg ? -d : d;
}

/* ---- blocks ------------------------------------------------------------------ */

struct numbers_job {
    const char *text;
    const struct json_span *sp;
    size_t nblocks;
    long *first;  /* per block: its first element's index (the counts first) */
    long *bad;    /* per block: the index of its first bad number, or -1 */
    double *badv; /* and that number */
    float *f;     /* floats out, or NULL */
    uint32_t *ix; /* indices out, or NULL */
    double limit; /* floats: the largest magnitude */
    long nverts;  /* indices: the bound */
    char point;   /* the locale's decimal point */
};

static size_t block_lo(const struct numbers_job *j, size_t b) { return j->sp->open + b * JN_BLOCK; }

static size_t block_hi(const struct numbers_job *j, size_t b) {
    size_t hi = j->sp->open + (b + 1) * JN_BLOCK;
    return hi < j->sp->close ? hi : j->sp->close;
}

/* Separators ('[' and ',') in each block: the elements that start there. */
static void count_blocks(void *ctx, size_t lo, size_t hi) {
    struct numbers_job *j = ctx;
    for (size_t b = lo; b < hi; b++) {
        const char *p = j->text + block_lo(j, b), *end = j->text + block_hi(j, b);
        long n = b == 0; /* the '[' */
        while ((p = memchr(p, ',', (size_t)(end - p))) != NULL) {
            n++;
            p++;
        }
        j->first[b] = n;
    }
}

static bool keep(struct numbers_job *j, long i, double v) {
    if (j->f) {
        if (!isfinite(v) || fabs(v) > j->limit) return false;
        j->f[i] = (float)v;
    } else {
        if (!(v >= 0 && v < (double)j->nverts && floor(v) == v)) return false;
        j->ix[i] = (uint32_t)v;
    }
    return true;
}

static void skip_ws(const char **p) {
    while (**p == ' ' || **p == '\t' || **p == '\r' || **p == '\n') (*p)++;
}

/* Parses the elements whose separator lies in block b. */
static void parse_block(struct numbers_job *j, size_t b) {
    const char *p = j->text + block_lo(j, b), *end = j->text + block_hi(j, b);
    long i = j->first[b];
    j->bad[b] = -1;
    if (b > 0) p = memchr(p, ',', (size_t)(end - p));
    while (p && p < end && *p != ']') {
        p++;
        skip_ws(&p);
        double v = json_number(&p, j->point);
        if (!keep(j, i, v)) {
            j->bad[b] = i;
            j->badv[b] = v;
            return;
        }
        i++;
        skip_ws(&p);
    }
}

static void parse_blocks(void *ctx, size_t lo, size_t hi) {
    for (size_t b = lo; b < hi; b++) parse_block(ctx, b);
}

static long run(struct numbers_job *j, int threads, double *bad) {
    size_t nb = (j->sp->close - j->sp->open + JN_BLOCK - 1) / JN_BLOCK;
    long *first = malloc(nb * 2 * sizeof(long));
    double *badv = malloc(nb * sizeof(double));
    if (!first || !badv) {
        free(first);
        free(badv);
        return JSON_NUMBERS_NOMEM;
    }
    j->nblocks = nb;
    j->first = first;
    j->bad = first + nb;
    j->badv = badv;
    if (threads != 1 && nb < 16) threads = 1; /* under 1 MB: not worth a thread */
    parallel_for(nb, threads, 1, count_blocks, j);
    for (size_t b = 0, sum = 0; b < nb; b++) {
        size_t n = (size_t)first[b];
        first[b] = (long)sum;
        sum += n;
    }
    parallel_for(nb, threads, 1, parse_blocks, j);
    long result = -1;
    for (size_t b = 0; b < nb && result < 0; b++)
        if (j->bad[b] >= 0) {
            result = j->bad[b];
            if (bad) *bad = j->badv[b];
        }
    free(first);
    free(badv);
    return result;
}

long json_floats(const char *text, const struct json_span *sp, double limit, int threads,
                 float *out, double *bad) {
    struct numbers_job j = {
        .text = text, .sp = sp, .f = out, .limit = limit, .point = localeconv()->decimal_point[0]};
    return run(&j, threads, bad);
}

long json_indices(const char *text, const struct json_span *sp, long nverts, int threads,
                  uint32_t *out) {
    struct numbers_job j = {.text = text,
                            .sp = sp,
                            .ix = out,
                            .nverts = nverts,
                            .point = localeconv()->decimal_point[0]};
    return run(&j, threads, NULL);
}
