/* frame_name.c -- a frame range and each frame's file name.
 *
 * rayd-render --frames A-B and rayd-client job --frames A-B read the same
 * range, and both name frame k's file from -o's pattern the same way: one
 * %d or %0Nd (N < 10) becomes k, "%%" a "%".  One copy here, so the
 * two programs write the same names for the same command line (shot-%04d.png
 * is shot-0007.png from either), and a pattern one refuses the other
 * refuses too.
 */
#include "common/common.h"

#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int frame_name_path(const char *pattern, long k, char *out, size_t size) {
    size_t o = 0;
    int numbers = 0;
    for (const char *p = pattern; *p; p++) {
        char piece[32] = {*p, 0};
        if (*p == '%' && p[1] == '%') {
            p++;
        } else if (*p == '%') {
            /* %0Nd, not %Nd: padded with spaces, names a shell splits
             * (and ffmpeg reads %Nd as %0Nd: other names than ours) */
            const char *q = p + 1;
            int width = 0;
            if (*q == '0' && q[1] >= '1' && q[1] <= '9') width = q[1] - '0', q += 2;
            if (*q != 'd' || numbers++) return -1;
            snprintf(piece, sizeof piece, "%0*ld", width, k);
            p = q;
        }
        size_t n = strlen(piece);
        if (o + n >= size) return -1;
        memcpy(out + o, piece, n + 1);
        o += n;
    }
    if (!numbers) snprintf(out, size, "%s", pattern);
    return numbers;
}

int frame_name_range(const char *s, long *a, long *b) {
    char *end;
    errno = 0;
    *a = strtol(s, &end, 10);
    if (errno || end == s || !(*end == '-' || !*end) || *a < 0 || *a > 1000000) return -1;
    if (!*end) {
        *b = *a;
        return 0;
    }
    const char *s2 = end + 1;
    *b = strtol(s2, &end, 10);
    if (errno || end == s2 || *end || *b < *a || *b > 1000000) return -1;
    return 0;
}
