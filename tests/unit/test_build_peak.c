/* test_build_peak.c -- a mesh's build stays within what the loader
 * charged for it.
 *
 * Before a mesh's BVH is built the loader charges rayd's memory budget
 * sj_mesh_bytes: the arrays (already resident) and an estimate of what the
 * build holds at once.  Here a mesh of 82k and one of 328k triangles are
 * built on 1 to 16 threads, each in a child process whose resident peak
 * (VmHWM) is reset just before the build: the peak's growth must stay
 * within the charge less the arrays.  The builder once reserved for each
 * thread's subtree the most nodes it could need; the unused tails, between
 * the ranges the others filled, were faulted in 2 MiB pages, and the 328k
 * mesh's build on two threads or more peaked at 114 bytes a triangle.
 * Smaller meshes are not measured: the kernel counts resident pages in
 * batches, and a few hundred KB of fixed costs would be most of the figure.
 *
 * Resident memory is the figure that matters, and only the kernel knows
 * it; under AddressSanitizer (shadow memory, redzones, a quarantine that
 * keeps freed blocks) it means nothing, so the RSS check is skipped there
 * and says so.  Where /proc/self/clear_refs cannot reset the peak, the
 * same.
 */
#include "check.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "geom/mesh.h"
#include "load/scene_json_mesh.h"
#include "peak_rss.h"

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define UNDER_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define UNDER_SANITIZER 1
#endif
#endif

#ifndef UNDER_SANITIZER

/* A wavy sheet of side x side quads, two triangles each: positions and
 * indices, as a decoder leaves them (no normals: smooth false). */
static struct mesh_data sheet(uint32_t side) {
    uint32_t nv = (side + 1) * (side + 1), nt = 2 * side * side;
    struct mesh_data md = {
        malloc(sizeof(float) * 3 * nv), NULL, NULL, malloc(sizeof(uint32_t) * 3 * nt), nv, nt, 0};
    if (!md.pos || !md.index) return md;
    for (uint32_t y = 0; y <= side; y++)
        for (uint32_t x = 0; x <= side; x++) {
            float *p = md.pos + 3 * (y * (side + 1) + x);
            p[0] = (float)x, p[1] = (float)y;
            p[2] = 0.25f * (float)(((x * 7 + y * 13) % 17)) / 17.0f;
        }
    uint32_t *ix = md.index;
    for (uint32_t y = 0; y < side; y++)
        for (uint32_t x = 0; x < side; x++) {
            uint32_t a = y * (side + 1) + x, b = a + 1, c = a + side + 1, d = c + 1;
            *ix++ = a, *ix++ = b, *ix++ = c;
            *ix++ = b, *ix++ = d, *ix++ = c;
        }
    return md;
}

/* In a child: the sheet built on threads threads; writes to fd the
 * build's resident growth and its charge past the arrays, in bytes. */
static void child_build(int fd, uint32_t side, int threads) {
    struct mesh_data md = sheet(side);
    long long out[2] = {-1, 0};
    if (md.pos && md.index && peak_rss_reset()) {
        size_t arrays = sizeof(float) * 3 * md.nverts + sizeof(uint32_t) * 3 * md.ntris;
        out[1] = (long long)(sj_mesh_bytes(&md) - arrays);
        long rss0 = peak_rss_kb("VmRSS");
        struct mesh m;
        if (mesh_build(&m, md.pos, md.nverts, md.index, md.ntris, NULL, NULL, false, threads,
                       NULL) == RAYD_OK &&
            rss0 >= 0)
            out[0] = (peak_rss_kb("VmHWM") - rss0) * 1024LL;
        mesh_free(&m);
    }
    ssize_t w = write(fd, out, sizeof out);
    _exit(w == (ssize_t)sizeof out ? 0 : 1);
}

/* The growth and charge of one build (in a fresh process, so that no
 * earlier build's freed pages are reused); false where it cannot say. */
static bool measure(uint32_t side, int threads, long long *growth, long long *charge) {
    int fds[2];
    if (pipe(fds) != 0) return false;
    fflush(stdout);
    pid_t pid = fork();
    if (pid == 0) {
        close(fds[0]);
        child_build(fds[1], side, threads);
    }
    close(fds[1]);
    long long out[2] = {-1, 0};
    bool ok = pid > 0 && read(fds[0], out, sizeof out) == (ssize_t)sizeof out;
    close(fds[0]);
    int status = 0;
    if (pid > 0) waitpid(pid, &status, 0);
    *growth = out[0], *charge = out[1];
    return ok && WIFEXITED(status) && WEXITSTATUS(status) == 0 && out[0] >= 0;
}

#endif

static void test_build_within_charge(void) {
#ifdef UNDER_SANITIZER
    printf("  skipped: resident memory means nothing under a sanitizer\n");
#else
    static const uint32_t sides[] = {203, 405}; /* 82k and 328k triangles */
    static const int threads[] = {1, 2, 4, 8, 16};
    for (size_t s = 0; s < sizeof sides / sizeof *sides; s++)
        for (size_t t = 0; t < sizeof threads / sizeof *threads; t++) {
            long long growth, charge;
            if (!measure(sides[s], threads[t], &growth, &charge)) {
                printf("  skipped: no resident peak to read (/proc/self/clear_refs)\n");
                return;
            }
            double tris = 2.0 * sides[s] * sides[s];
            printf("  %u triangles, %2d threads: build peak %.1f, charged %.1f bytes a triangle\n",
                   (unsigned)(2 * sides[s] * sides[s]), threads[t], (double)growth / tris,
                   (double)charge / tris);
            CHECK(growth <= charge,
                  "%u triangles on %d threads: peak %lld bytes over the %lld charged",
                  (unsigned)(2 * sides[s] * sides[s]), threads[t], growth, charge);
        }
#endif
}

int main(void) {
    RUN(test_build_within_charge);
    return check_failures_ ? 1 : 0;
}
