/* procstat.c -- what the kernel knows about this process, for the
 * process_* metrics every Prometheus client library exports.
 *
 * The names and units are the Prometheus client conventions
 * (process_cpu_seconds_total, process_resident_memory_bytes,
 * process_virtual_memory_bytes, process_open_fds, process_max_fds,
 * process_start_time_seconds), so the dashboards and alerts written for any
 * exporter work on rayd unchanged.  They come from where those libraries
 * read them on Linux: /proc/self/stat (CPU ticks, sizes, start tick),
 * /proc/stat (boot time), /proc/self/fd (one entry per descriptor) and
 * getrlimit(RLIMIT_NOFILE).  Read at each scrape: a few system calls, no
 * state, no lock.  On a system without /proc the fields read 0 and ok is
 * false.
 *
 * Layer: base; called by metrics.c only.
 */
#include "base/base.h"

#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

/* Boot time in seconds since the epoch: the "btime" line of /proc/stat. */
static double procstat_boot_time(void) {
    FILE *f = fopen("/proc/stat", "r");
    if (!f) return 0;
    char line[256];
    double t = 0;
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, "btime ", 6)) {
            t = strtod(line + 6, NULL);
            break;
        }
    fclose(f);
    return t;
}

/* Fields 14, 15 (utime, stime), 22 (starttime), 23 (vsize), 24 (rss) of
 * /proc/self/stat.  The command name (field 2) may hold spaces and
 * parentheses, so fields are counted from the last ')'. */
static bool procstat_stat(struct procstat *p) {
    FILE *f = fopen("/proc/self/stat", "r");
    if (!f) return false;
    char buf[1024];
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = 0;
    char *s = strrchr(buf, ')');
    if (!s) return false;
    /* field k (from 3 on) as a number; the state letter (3) reads 0 */
    unsigned long long v[25] = {0};
    int k = 3;
    for (char *q = s + 1; k < 25; k++) {
        while (*q == ' ') q++;
        if (!*q) return false;
        v[k] = strtoull(q, &q, 10);
        while (*q && *q != ' ') q++;
    }
    unsigned long long utime = v[14], stime = v[15], start = v[22], vsize = v[23], rss = v[24];
    double tick = (double)sysconf(_SC_CLK_TCK);
    long page = sysconf(_SC_PAGESIZE);
    if (tick <= 0 || page <= 0) return false;
    p->cpu_seconds = (double)(utime + stime) / tick;
    p->start_time = procstat_boot_time() + (double)start / tick;
    p->virtual_bytes = (double)vsize;
    p->resident_bytes = (double)rss * (double)page;
    return true;
}

/* Open descriptors: the entries of /proc/self/fd, less the one reading it. */
static long procstat_fds(void) {
    DIR *d = opendir("/proc/self/fd");
    if (!d) return -1;
    long n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (e->d_name[0] != '.') n++;
    closedir(d);
    return n > 0 ? n - 1 : 0;
}

bool procstat_read(struct procstat *p) {
    memset(p, 0, sizeof *p);
    bool ok = procstat_stat(p);
    long fds = procstat_fds();
    p->open_fds = fds > 0 ? (double)fds : 0;
    struct rlimit rl;
    if (!getrlimit(RLIMIT_NOFILE, &rl))
        p->max_fds = rl.rlim_cur == RLIM_INFINITY ? 1e18 : (double)rl.rlim_cur;
    return ok && fds >= 0;
}
