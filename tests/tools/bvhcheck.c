/* bvhcheck -- renders a scene twice, through the acceleration structures
 * and by brute force (every primitive tested by every ray), and compares;
 * then checks that 16-ray packets give every ray exactly its one-ray answer.
 *
 *   bvhcheck SCENE.json [W H]
 *
 * W x H (default 96 x 64) replaces the scene's image size and samples are
 * capped at 4, so a benchmark scene renders small.  Prints "PASS
 * bvh-equals-brute NAME" or a FAIL line with the first differing pixel,
 * then "PASS packet-equals-ray NAME" or a FAIL line naming the first ray
 * whose packet answer differs.  The packets: the image's 4x4 pixel blocks
 * (primary rays, and shadow rays from their hits toward each light), the
 * same with lanes left out, and incoherent rays (random origins in the
 * scene's box, random directions).  A test tool: it links the core's
 * internals to flip the brute-force switch.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/bvh16.h"
#include "render/integrate.h"
#include "math/rng.h"
#include "scene/scene.h"

static rayd_scene *load(const char *path, const char *text, size_t len, int w, int h) {
    char dir[4096];
    const char *slash = strrchr(path, '/');
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) : 1, slash ? path : ".");
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.asset_dir = dir;
    lim.asset_confine = 0;
    rayd_scene *s = NULL;
    struct rayd_error err;
    if (rayd_scene_parse(text, len, &lim, &s, &err) != RAYD_OK) {
        printf("FAIL bvh-equals-brute %s: %s %s\n", path, err.path, err.message);
        return NULL;
    }
    /* a smaller image through the same camera (keep fov, change size), at
     * most 4 samples a pixel: the check is about geometry, not noise */
    if (s->rs.samples > 4) s->rs.samples = 4;
    double tx = s->cam.tan_x;
    s->rs.width = s->cam.n = w;
    s->rs.height = s->cam.m = h;
    if (!s->cam.ortho) s->cam.tan_y = tx * h / w;
    return s;
}

static bool same_hit(const struct hit *a, const struct hit *b) {
    return a->t == b->t && a->leaf == b->leaf && a->outer == b->outer && a->part == b->part &&
           a->orient == b->orient &&
           (a->leaf->kind != SHAPE_MESH ||
            (a->mh.t == b->mh.t && a->mh.u == b->mh.u && a->mh.v == b->mh.v &&
             a->mh.tri == b->mh.tri && a->mh.blk == b->mh.blk && a->mh.lane == b->mh.lane));
}

/* One packet against its rays one by one; false (and a FAIL line) on the
 * first difference.  light: the light the rays are shadow rays of (its
 * light buffer may answer them), or -1. */
static bool packet_ok(const rayd_scene *s, const char *name, const char *what, const ray r[16],
                      const double tmax[16], uint32_t active, int light) {
    struct hit h[16], hs[16], hw[16];
    struct hit16 simple; /* the wide shader's form of the hits on spheres and planes */
    vec3 tr[16];
    double trs[3][16];
    struct ray16 rs; /* the same rays as structure of arrays, the other entry points */
    for (int i = 0; i < 16; i++)
        if (active >> i & 1) ray16_set(&rs, i, r[i]);
    uint32_t hit = scene_intersect16(s, r, tmax, active, h);
    uint32_t hit_soa = scene_intersect16_soa(s, &rs, tmax, active, hs, NULL);
    uint32_t hit_wide = scene_intersect16_soa(s, &rs, tmax, active, hw, &simple);
    for (uint32_t m = simple.lanes; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        hw[i] = hit16_get(&simple, i);
    }
    scene_transmittance16(s, r, tmax, active, tr);
    scene_transmittance16_soa(s, light, (const double(*)[16])rs.o, (const double(*)[16])rs.d, tmax,
                              active, trs);
    for (int i = 0; i < 16; i++) {
        if (!(active >> i & 1)) continue;
        struct hit one;
        bool got = scene_intersect(s, &r[i], tmax[i], &one);
        vec3 t1 = scene_transmittance(s, &r[i], tmax[i]);
        bool hit_ok = got == (bool)(hit >> i & 1) && (!got || same_hit(&one, &h[i])) &&
                      got == (bool)(hit_soa >> i & 1) && (!got || same_hit(&one, &hs[i])) &&
                      got == (bool)(hit_wide >> i & 1) && (!got || same_hit(&one, &hw[i]));
        bool tr_ok = t1.x == tr[i].x && t1.y == tr[i].y && t1.z == tr[i].z && t1.x == trs[0][i] &&
                     t1.y == trs[1][i] && t1.z == trs[2][i];
        if (!hit_ok || !tr_ok) {
            printf(
                "FAIL packet-equals-ray %s: %s ray %d (o %.17g %.17g %.17g, d %.17g %.17g %.17g):"
                " %s differs\n",
                name, what, i, r[i].o.x, r[i].o.y, r[i].o.z, r[i].d.x, r[i].d.y, r[i].d.z,
                hit_ok ? "transmittance" : "nearest hit");
            return false;
        }
    }
    return true;
}

/* Every 4x4 block of the W x H image: primary rays (all lanes, then a
 * pattern of lanes left out), shadow rays from their hits to each light;
 * then incoherent packets.  Returns the number of rays checked, -1 on a
 * difference. */
static long check_packets(const rayd_scene *s, const char *name, int w, int h) {
    long n = 0;
    for (int y = 0; y < h; y += 4)
        for (int x = 0; x < w; x += 4) {
            ray r[16];
            double tmax[16];
            uint32_t active = 0;
            for (int k = 0; k < 16; k++) {
                int i = x + k % 4, j = y + k / 4;
                tmax[k] = INFINITY;
                if (i >= w || j >= h) continue;
                r[k] = cam_ray(&s->cam, i + 0.5, j + 0.5, 0.5, 0.5);
                active |= 1u << k;
            }
            uint32_t some = active & (0x5a5au ^ (uint32_t)(x * 7 + y));
            if (!packet_ok(s, name, "primary", r, tmax, active, -1) ||
                !packet_ok(s, name, "primary (some lanes)", r, tmax, some, -1))
                return -1;
            n += __builtin_popcount(active);
            struct hit hit[16];
            uint32_t got = scene_intersect16(s, r, tmax, active, hit);
            for (int l = 0; l < s->nlights; l++) {
                ray sr[16];
                double dist[16];
                uint32_t lit = 0;
                for (uint32_t m = got; m; m &= m - 1) {
                    int k = __builtin_ctz(m);
                    struct surface sf;
                    scene_surface(s, &r[k], &hit[k], &sf);
                    vec3 nf = v3_dot(sf.ng, r[k].d) > 0 ? v3_neg(sf.ng) : sf.ng, rad;
                    sr[k].o = v3_madd(sf.p, nf, integrate_offset(sf.p, sf.float_geom));
                    if (light_at(&s->lights[l], sr[k].o, &sr[k].d, &dist[k], &rad)) lit |= 1u << k;
                }
                if (!packet_ok(s, name, "shadow", sr, dist, lit, l)) return -1;
                n += __builtin_popcount(lit);
            }
        }
    struct rng_key key = rng_key_at(7, 1, 2, 3);
    vec3 lo = v3(-10, -10, -10), hi = v3(10, 10, 10);
    if (s->nobjs > 0) {
        const struct bbox *b = &s->tlas.bounds;
        lo = v3(b->lo[0], b->lo[1], b->lo[2]);
        hi = v3(b->hi[0], b->hi[1], b->hi[2]);
    }
    for (uint32_t p = 0; p < 64; p++) {
        ray r[16];
        double tmax[16];
        for (int k = 0; k < 16; k++) {
            double u[5];
            for (int d = 0; d < 5; d++) u[d] = rng_uniform(&key, p, (uint32_t)(5 * k + d));
            r[k].o = v3(lo.x + u[0] * (hi.x - lo.x), lo.y + u[1] * (hi.y - lo.y),
                        lo.z + u[2] * (hi.z - lo.z));
            double z = 2 * u[3] - 1, a = 6.283185307179586 * u[4], q = sqrt(1 - z * z);
            r[k].d = v3(q * cos(a), q * sin(a), z);
            tmax[k] = k % 3 ? INFINITY : 0.5 + k;
        }
        if (!packet_ok(s, name, "incoherent", r, tmax, 0xffffu, -1)) return -1;
        n += 16;
    }
    return n;
}

int main(int argc, char **argv) {
    if (argc != 2 && argc != 4) {
        fprintf(stderr, "usage: bvhcheck SCENE.json [W H]\n");
        return 2;
    }
    int w = argc == 4 ? atoi(argv[2]) : 96, h = argc == 4 ? atoi(argv[3]) : 64;
    size_t len;
    char *text = NULL;
    if (rayd_read_file(argv[1], (size_t)1 << 30, &text, &len, NULL) != RAYD_OK) text = NULL;
    if (!text) {
        printf("FAIL bvh-equals-brute %s: cannot read\n", argv[1]);
        return 1;
    }
    rayd_scene *fast = load(argv[1], text, len, w, h), *slow = load(argv[1], text, len, w, h);
    free(text);
    if (!fast || !slow) return 1;
    slow->brute = true;
    struct rayd_render_opts o = {.threads = 2};
    rayd_image *a = NULL, *b = NULL;
    rayd_render(fast, &o, &a, NULL);
    rayd_render(slow, &o, &b, NULL);
    int rc = 0;
    if (!a || !b) {
        printf("FAIL bvh-equals-brute %s: render failed\n", argv[1]);
        rc = 1;
    } else {
        const uint8_t *pa = rayd_image_pixels_const(a), *pb = rayd_image_pixels_const(b);
        size_t n = (size_t)w * h * 3, i = 0;
        while (i < n && pa[i] == pb[i]) i++;
        if (i < n) {
            printf("FAIL bvh-equals-brute %s: pixel (%zu, %zu) differs\n", argv[1], i / 3 % w,
                   i / 3 / w);
            rc = 1;
        } else {
            printf("PASS bvh-equals-brute %s (%u meshes, %ld objects)\n", argv[1], fast->nmeshes,
                   (long)fast->nobjs + fast->nplanes);
        }
    }
    rayd_image_free(a);
    rayd_image_free(b);
    long rays = check_packets(fast, argv[1], w, h);
    if (rays < 0)
        rc = 1;
    else
        printf("PASS packet-equals-ray %s (%ld rays, %s)\n", argv[1], rays,
               cpu_avx512() ? "AVX-512" : "one ray at a time");
    rayd_scene_free(fast);
    rayd_scene_free(slow);
    return rc;
}
