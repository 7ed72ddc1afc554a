/* mesh_io.c -- what the mesh decoders share: freeing, quoting, numbers.
 *
 * mesh_obj.c and mesh_ply.c each turn a file's bytes into a struct
 * mesh_data in one pass over a buffer that is not NUL-terminated (growing
 * their arrays by doubling, array.c, so a million-triangle file costs
 * O(log n) reallocations).  The things they both need live here:
 *   - mesh_data_free, so a half-built mesh and a finished one are released
 *     the same way on every path;
 *   - mesh_charge and mesh_grow, so each big array is charged to the
 *     caller's memory budget (mesh_limits.charge) before it is allocated,
 *     and a refusal comes before the memory is used;
 *   - mesh_quote, so a token quoted in a message is printable ASCII;
 *   - mesh_parse_number, a decimal parser over a bounded token.  strtod
 *     needs a NUL after the number and is slow; the common case (at most 19
 *     significant digits, |exponent| <= 22, mantissa exact in a double) is
 *     computed directly, which is exact because both operands of the one
 *     multiplication or division are exact doubles (Clinger's fast path).
 *     Anything else -- long mantissas, big exponents, "nan", "inf", hex --
 *     is copied to a stack buffer and handed to strtod.  Tokens longer than
 *     that buffer are refused rather than truncated; no number needs 512
 *     characters.
 */
#include "format/mesh_io.h"

#include "base/meter.h"

#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void mesh_data_free(struct mesh_data *m) {
    if (!m) return;
    free(m->pos);
    free(m->normal);
    free(m->uv);
    free(m->index);
    memset(m, 0, sizeof *m);
}

/* UINT32_MAX - 1 at most, so a count + 1 still fits a uint32_t. */
uint32_t mesh_max_vertices(const struct mesh_limits *lim) {
    return lim && lim->max_vertices < UINT32_MAX ? lim->max_vertices : UINT32_MAX - 1;
}

uint32_t mesh_max_triangles(const struct mesh_limits *lim) {
    return lim && lim->max_triangles < UINT32_MAX ? lim->max_triangles : UINT32_MAX - 1;
}

enum rayd_status mesh_charge(const struct mesh_limits *lim, size_t *charged, size_t bytes,
                             char *why, size_t why_len) {
    if (!meter_live()) { /* the parse's cancel flag (rayd_limits.cancel) */
        if (why_len) snprintf(why, why_len, "the parse was canceled");
        return RAYD_E_CANCELED;
    }
    if (!lim || !lim->charge || bytes == 0) return RAYD_OK;
    if (why_len) why[0] = '\0';
    long long n = bytes > (size_t)LLONG_MAX ? LLONG_MAX : (long long)bytes;
    enum rayd_status st = lim->charge(lim->charge_arg, n, why, why_len);
    if (st != RAYD_OK) {
        if (why_len && !why[0]) snprintf(why, why_len, "no memory for %zu bytes", bytes);
        return st;
    }
    *charged += bytes;
    return RAYD_OK;
}

void mesh_give_back(const struct mesh_limits *lim, size_t *charged, size_t bytes) {
    if (bytes > *charged) bytes = *charged;
    if (!lim || !lim->charge || bytes == 0) return;
    char why[8];
    long long n = bytes > (size_t)LLONG_MAX ? LLONG_MAX : (long long)bytes; /* as charged */
    (void)lim->charge(lim->charge_arg, -n, why, sizeof why);
    *charged -= bytes;
}

/* The capacity array_grow picks: doubling from *cap (16 at first). */
static size_t mesh_grown_cap(size_t cap, size_t need) {
    size_t n = cap ? cap : 16;
    while (n < need) {
        if (n > SIZE_MAX / 2) return need;
        n *= 2;
    }
    return n;
}

enum rayd_status mesh_grow(const struct mesh_limits *lim, size_t *charged, void **arr, size_t *cap,
                           size_t need, size_t elem, char *why, size_t why_len) {
    if (need <= *cap) return RAYD_OK;
    size_t n = mesh_grown_cap(*cap, need);
    if (elem == 0 || n > SIZE_MAX / elem) {
        snprintf(why, why_len, "out of memory");
        return RAYD_E_NOMEM;
    }
    size_t more = (n - *cap) * elem;
    enum rayd_status st = mesh_charge(lim, charged, more, why, why_len);
    if (st != RAYD_OK) return st;
    if (!array_grow(arr, cap, n, elem)) {
        mesh_give_back(lim, charged, more);
        snprintf(why, why_len, "out of memory");
        return RAYD_E_NOMEM;
    }
    return RAYD_OK;
}

const char *mesh_quote(char *buf, const char *s, size_t n) {
    size_t max = MESH_QUOTE_SIZE - 8, k = 0; /* room for "..." and the NUL */
    for (; k < n && k < max; k++) buf[k] = s[k] >= 0x20 && s[k] <= 0x7e ? s[k] : '?';
    if (k < n) {
        memcpy(buf + k, "...", 3);
        k += 3;
    }
    buf[k] = '\0';
    return buf;
}

#define MESH_NUM_MAX 512 /* longest token handed to strtod */

static const double mesh_pow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                    1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                    1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

static bool mesh_is_digit(char c) { return c >= '0' && c <= '9'; }

/* strtod on a copy of s[0..n), accepting only if it consumes all of it. */
static bool mesh_number_slow(const char *s, size_t n, double *out) {
    char buf[MESH_NUM_MAX + 1];
    if (n == 0 || n > MESH_NUM_MAX) return false;
    if (s[0] == ' ' || (s[0] >= '\t' && s[0] <= '\r')) return false;
    memcpy(buf, s, n);
    buf[n] = '\0';
    if (memchr(buf, '\0', n)) return false;
    char *end = NULL;
    double v = strtod(buf, &end);
    if (end != buf + n) return false;
    *out = v;
    return true;
}

size_t mesh_scan_number(const char *s, const char *end, double *out) {
    size_t n = (size_t)(end - s), i = 0;
    bool neg = false;
    if (i < n && (s[i] == '+' || s[i] == '-')) neg = s[i++] == '-';
    uint64_t m = 0;
    int sig = 0, exp10 = 0, digits = 0;
    for (; i < n && mesh_is_digit(s[i]); i++, digits++) {
        if (m == 0 && s[i] == '0') continue;
        m = m * 10 + (uint64_t)(s[i] - '0');
        if (++sig > 19) return 0;
    }
    if (i < n && s[i] == '.') {
        for (i++; i < n && mesh_is_digit(s[i]); i++, digits++) {
            exp10--;
            if (m == 0 && s[i] == '0') continue;
            m = m * 10 + (uint64_t)(s[i] - '0');
            if (++sig > 19) return 0;
        }
    }
    if (digits == 0) return 0; /* "nan", "inf", ".", "" */
    if (i < n && (s[i] == 'e' || s[i] == 'E')) {
        i++;
        bool eneg = false;
        if (i < n && (s[i] == '+' || s[i] == '-')) eneg = s[i++] == '-';
        if (i >= n || !mesh_is_digit(s[i])) return 0;
        int e = 0;
        for (; i < n && mesh_is_digit(s[i]); i++)
            if (e < 100000) e = e * 10 + (s[i] - '0');
        exp10 += eneg ? -e : e;
    }
    double v;
    if (m == 0) {
        v = 0.0;
    } else if (m <= (UINT64_C(1) << 53) && exp10 >= -22 && exp10 <= 22) {
        v = exp10 < 0 ? (double)m / mesh_pow10[-exp10] : (double)m * mesh_pow10[exp10];
    } else {
        return 0;
    }
    *out = neg ? -v : v;
    return i;
}

bool mesh_parse_number(const char *s, size_t n, double *out) {
    /* the whole token by the fast path, or strtod: hex and other strtod
     * forms, long mantissas, big exponents, and every malformed token,
     * which strtod refuses */
    if (n > 0 && mesh_scan_number(s, s + n, out) == n) return true;
    return mesh_number_slow(s, n, out);
}
