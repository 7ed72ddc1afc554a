/* peak_rss.h -- a process's resident peak, read from /proc, for the
 * memory figures of test_build_peak and bench/raybench: a build's charge
 * to --max-memory is set beside the growth of VmHWM over VmRSS.
 *
 * Header-only (static inline), as both programs are single files.  Linux
 * only; where /proc is missing the readers say so (-1, false) and the
 * callers skip their figure.
 */
#ifndef RAYD_TESTS_PEAK_RSS_H
#define RAYD_TESTS_PEAK_RSS_H

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A kB figure of /proc/self/status (VmRSS, VmHWM), -1 where there is none. */
static inline long peak_rss_kb(const char *key) {
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long v = -1;
    size_t k = strlen(key);
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, key, k) && line[k] == ':') v = atol(line + k + 1);
    if (f) fclose(f);
    return v;
}

/* VmHWM set back to the RSS of now, so that it measures from here. */
static inline bool peak_rss_reset(void) {
    FILE *f = fopen("/proc/self/clear_refs", "w");
    if (!f) return false;
    bool ok = fputs("5", f) >= 0;
    return fclose(f) == 0 && ok;
}

#endif
