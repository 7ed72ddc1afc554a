/* progress.c -- what the user sees while tiles come back.
 *
 * On a terminal (stderr is a tty) one line is redrawn in place at most five
 * times a second: a bar, tiles done of total, the share of every server,
 * the rays per second the servers report and an estimate of the time left
 * from the rate so far.  When stderr is a file or a pipe (CI logs, tests)
 * the same facts go out as plain lines, one per 10% of the frame or every
 * five seconds, whichever comes first, so a log stays short and greppable.
 * A progressive job's passes (watch.c) are shown by progress_pass: the bar
 * in samples, or one line a pass written.
 * Nothing here touches stdout.
 */
#include "client.h"

#include <stdio.h>
#include <string.h>
#include <unistd.h>

void progress_init(struct progress *p, int total, int quiet) {
    memset(p, 0, sizeof *p);
    p->total = total;
    p->quiet = quiet;
    p->tty = isatty(2);
    p->t0 = net_now();
    p->last_pct = -1;
    p->unit = "tiles";
}

void progress_eta(double secs, char *buf, size_t size) {
    if (secs < 0)
        snprintf(buf, size, "--");
    else if (secs < 60)
        snprintf(buf, size, "%.0fs", secs);
    else if (secs < 3600)
        snprintf(buf, size, "%dm%02ds", (int)secs / 60, (int)secs % 60);
    else
        snprintf(buf, size, "%dh%02dm", (int)secs / 3600, (int)secs % 3600 / 60);
}

static void progress_rays(double rps, char *buf, size_t size) {
    if (rps < 0)
        buf[0] = '\0';
    else if (rps >= 1e9)
        snprintf(buf, size, "  %.2f Grays/s", rps / 1e9);
    else if (rps >= 1e6)
        snprintf(buf, size, "  %.2f Mrays/s", rps / 1e6);
    else
        snprintf(buf, size, "  %.0f rays/s", rps);
}

void progress_update(struct progress *p, int done, int failed, int nservers, const long *per_server,
                     char labels[][40], double rays_per_s, int force) {
    if (p->quiet || p->total <= 0 || done < 0 || done > p->total)
        return; /* figures that make no sense are never drawn (job.c warns) */
    double now = net_now(), el = now - p->t0;
    int pct = (int)(100.0 * done / p->total);
    if (p->tty) {
        if (!force && now - p->last_draw < 0.2) return;
    } else if (force ? done == p->last_done && p->last_pct >= 0
                     : pct / 10 == p->last_pct / 10 && now - p->last_line < 5) {
        return; /* plain lines: nothing new to say */
    }
    p->last_done = done;
    p->last_draw = p->last_line = now;
    p->last_pct = pct;
    char eta[32], rays[48], servers[600] = "";
    progress_eta(done > 0 && done < p->total ? el / done * (p->total - done)
                 : done                      ? 0
                                             : -1,
                 eta, sizeof eta);
    progress_rays(rays_per_s, rays, sizeof rays);
    size_t n = 0;
    for (int i = 0; i < nservers && n + 60 < sizeof servers; i++)
        n += (size_t)snprintf(servers + n, sizeof servers - n, "%s%s=%ld", i ? " " : "", labels[i],
                              per_server[i]);
    char fail[32] = "";
    if (failed) snprintf(fail, sizeof fail, ", %d failed", failed);
    if (p->tty) {
        char bar[31];
        int fill = p->total ? 30 * done / p->total : 0;
        for (int i = 0; i < 30; i++) bar[i] = i < fill ? '#' : '.';
        bar[30] = '\0';
        int w = fprintf(stderr, "\r[%s] %d/%d %s%s  %s%s  ETA %s", bar, done, p->total, p->unit,
                        fail, servers, rays, eta);
        for (int i = w; i < p->width; i++) fputc(' ', stderr);
        if (w > p->width) p->width = w;
    } else {
        fprintf(stderr, "rayd-client: %d/%d %s (%d%%)%s, %.1fs, servers: %s%s, ETA %s\n", done,
                p->total, p->unit, pct, fail, el, servers, rays, eta);
    }
    fflush(stderr);
}

void progress_end(struct progress *p) {
    if (!p->quiet && p->tty && p->width) {
        fputc('\n', stderr);
        p->width = 0;
    }
}

void progress_pass(struct progress *p, long k, long n, long samples, long target, double secs,
                   double eta_s, const char *path) {
    if (p->quiet || target <= 0) return;
    char eta[32];
    progress_eta(eta_s, eta, sizeof eta);
    if (!p->tty) {
        fprintf(stderr, "rayd-client: pass %ld/%ld: %ld/%ld samples, %.1fs, ETA %s%s%s\n", k, n,
                samples, target, secs, eta, path ? " -> " : "", path ? path : "");
        return;
    }
    char bar[31];
    int fill = (int)(30 * samples / target);
    for (int i = 0; i < 30; i++) bar[i] = i < fill ? '#' : '.';
    bar[30] = '\0';
    int w = fprintf(stderr, "\r[%s] pass %ld/%ld  %ld/%ld samples  %.1fs  ETA %s", bar, k, n,
                    samples, target, secs, eta);
    for (int i = w; i < p->width; i++) fputc(' ', stderr);
    if (w > p->width) p->width = w;
    fflush(stderr);
}
