/* embree_bench -- the rays raybench casts, cast by Embree instead.
 *
 *   embree_bench SCENE.json [--width W] [--height H] [--runs N] [--cpu-time] [--robust]
 *
 * The peer of bench/raybench.c for `make bench-peers`, built only there,
 * against Debian's libembree (3.13): never a dependency of rayd itself.
 * It reads the benchmark scene JSON (camera, render size, first light, the
 * mesh object's source.file, resolved beside the scene), decodes the PLY
 * with the core's own reader (mesh_parse_ply), and measures, median of
 * RUNS runs (each cast once more before them, untimed: a process's first
 * rtcOccluded16 calls ran 6x slower than the next ones, its first
 * rtcOccluded1 calls 1.4x, so that one run measured Embree's start, not
 * its walk; raybench does the same):
 *   - the BVH build: a new scene with RTC_BUILD_QUALITY_MEDIUM, committed
 *     (Embree's default device: its own task threads on every core, as
 *     raybench builds on --threads-max threads), and the bytes Embree
 *     allocates (memory monitor) per triangle: for the BVH alone
 *     (bvh_bytes_per_triangle) and with the vertex and index buffers
 *     (bytes_per_triangle, comparable to raybench's mesh + BVH figure);
 *   - primary rays through every pixel centre of the W x H image, the
 *     camera formula of core/geom/camera.h in double precision, nearest hit:
 *     rtcIntersect1 row by row, and rtcIntersect16 on 4x4 pixel blocks;
 *   - shadow rays as raybench counts them: for every pixel the primary ray
 *     and, from each hit lifted off the surface as core/render/integrate.h does,
 *     an any-hit ray toward the first light (rtcOccluded1 / rtcOccluded16),
 *     reported as pixels per second;
 *   - the shadow rays alone, raybench's kind occlusion: the same shadow
 *     rays made once, untimed, from rtcIntersect16 on 4x4 pixel blocks,
 *     then cast with rtcOccluded1 one at a time and rtcOccluded16 a block
 *     a packet (context flag COHERENT), as rays per second of shadow rays;
 *   - diffuse-bounce rays, raybench's: from every primary hit one
 *     cosine-weighted direction about the geometric normal turned toward
 *     the viewer, from a hash of the pixel (../bounce.h, the one raybench
 *     includes), origin lifted as for the shadow rays, nearest hit.  Made
 *     once, untimed, in pixel order; cast with rtcIntersect1 one at a time
 *     and rtcIntersect16 on 16 consecutive ones (context flag INCOHERENT,
 *     Embree's hint for such rays), as rays per second of bounce rays;
 * all on the calling thread (timed in wall seconds, or with --cpu-time in
 * that thread's CPU seconds, as raybench --cpu-time times its 1-thread
 * casts), with denormals flushed to zero (FTZ/DAZ) as
 * Embree recommends.  --robust sets RTC_SCENE_FLAG_ROBUST, which "avoids
 * optimizations that reduce arithmetic accuracy ... rays shooting through
 * edges of neighboring primitives" (Embree's manual): the nearest Embree
 * comes to what rayd's walks always do (a watertight triangle test, a box
 * test that never misses a box the ray touches), and what its default
 * trades for speed.  Output: "key value" lines like raybench's, with the
 * hit counts (keys ending _hits) to show both cast the same rays.
 */
#include <cjson/cJSON.h>
#include <embree3/rtcore.h>
#include <math.h>
#include <pmmintrin.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "../bounce.h"
#include "format/mesh_io.h"

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static bool use_cpu_time;

/* The clock of the (single-threaded) ray casts. */
static double now_1t(void) {
    if (!use_cpu_time) return now();
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts); /* not Embree's idle task threads */
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n) {
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return v[n / 2];
}

static void die(const char *what) {
    fprintf(stderr, "embree_bench: %s\n", what);
    exit(1);
}

typedef struct {
    double x, y, z;
} d3;

static d3 d3_sub(d3 a, d3 b) { return (d3){a.x - b.x, a.y - b.y, a.z - b.z}; }
static d3 d3_cross(d3 a, d3 b) {
    return (d3){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static d3 d3_norm(d3 a) {
    double l = sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
    return (d3){a.x / l, a.y / l, a.z / l};
}

static d3 json_vec(const cJSON *o, const char *key, d3 def) {
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != 3) return def;
    return (d3){cJSON_GetArrayItem(a, 0)->valuedouble, cJSON_GetArrayItem(a, 1)->valuedouble,
                cJSON_GetArrayItem(a, 2)->valuedouble};
}

static double json_num(const cJSON *o, const char *key, double def) {
    const cJSON *n = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsNumber(n) ? n->valuedouble : def;
}

/* Everything the casts need, shared read-only. */
struct setup {
    RTCScene scene;
    d3 pos, u, v, w;
    double tan_x, tan_y;
    int width, height;
    bool light_is_point; /* else directional (or none: straight up) */
    d3 light;            /* position, or direction toward the light */
    float *bounce;       /* bounce rays: origin and direction, 6 floats each */
    long nbounce;
    float *shadow; /* shadow rays, 16 places a 4x4 block: origin, direction, tfar */
    int *svalid;   /* -1 where the block's primary ray hit, else 0 */
    long nblocks, nshadow;
};

/* core/geom/camera.h cam_dir: d = normalize(w + alpha u + beta v). */
static d3 pixel_dir(const struct setup *s, int i, int j) {
    double hn = s->width * 0.5, hm = s->height * 0.5;
    double alpha = s->tan_x * ((i + 0.5) - hn) / hn;
    double beta = s->tan_y * (hm - (j + 0.5)) / hm;
    return d3_norm((d3){s->w.x + alpha * s->u.x + beta * s->v.x,
                        s->w.y + alpha * s->u.y + beta * s->v.y,
                        s->w.z + alpha * s->u.z + beta * s->v.z});
}

/* The shadow ray from a hit: origin lifted along the geometric normal
 * turned toward the viewer by core/render/integrate.h's float offset; direction
 * toward the light; tfar = its distance. */
/* The hit point lifted off the surface into p, and the unit geometric
 * normal turned toward the viewer into n. */
static void lift(const float org[3], const float dir[3], float t, const float ng[3], double p[3],
                 double n[3]) {
    double nl = sqrt((double)ng[0] * ng[0] + (double)ng[1] * ng[1] + (double)ng[2] * ng[2]);
    double dn = 0, maxabs = 0;
    for (int k = 0; k < 3; k++) {
        p[k] = org[k] + (double)t * dir[k];
        n[k] = ng[k] / nl;
        dn += n[k] * dir[k];
        if (fabs(p[k]) > maxabs) maxabs = fabs(p[k]);
    }
    if (dn > 0)
        for (int k = 0; k < 3; k++) n[k] = -n[k];
    double off = 1.5e-5 * maxabs + 1e-6;
    for (int k = 0; k < 3; k++) p[k] += n[k] * off;
}

static void shadow_ray(const struct setup *s, const float org[3], const float dir[3], float t,
                       const float ng[3], float o[3], float d[3], float *tfar) {
    double p[3], n[3];
    lift(org, dir, t, ng, p, n);
    double to[3], dist = INFINITY;
    if (s->light_is_point) {
        to[0] = s->light.x - p[0];
        to[1] = s->light.y - p[1];
        to[2] = s->light.z - p[2];
        dist = sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
        for (int k = 0; k < 3; k++) to[k] /= dist;
    } else {
        to[0] = s->light.x;
        to[1] = s->light.y;
        to[2] = s->light.z;
    }
    for (int k = 0; k < 3; k++) {
        o[k] = (float)p[k];
        d[k] = (float)to[k];
    }
    *tfar = (float)dist;
}

/* Single rays, row by row.  Returns seconds; *hits the primary (or shadow:
 * occluded) count. */
static double cast1(const struct setup *s, bool shadow, long *hits) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    long n = 0;
    double t0 = now_1t();
    for (int j = 0; j < s->height; j++) {
        for (int i = 0; i < s->width; i++) {
            d3 d = pixel_dir(s, i, j);
            struct RTCRayHit rh;
            rh.ray.org_x = (float)s->pos.x;
            rh.ray.org_y = (float)s->pos.y;
            rh.ray.org_z = (float)s->pos.z;
            rh.ray.dir_x = (float)d.x;
            rh.ray.dir_y = (float)d.y;
            rh.ray.dir_z = (float)d.z;
            rh.ray.tnear = 0;
            rh.ray.tfar = INFINITY;
            rh.ray.time = 0;
            rh.ray.mask = 0xffffffffu;
            rh.ray.id = 0;
            rh.ray.flags = 0;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(s->scene, &ctx, &rh);
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
            if (!shadow) {
                n++;
                continue;
            }
            const float org[3] = {rh.ray.org_x, rh.ray.org_y, rh.ray.org_z};
            const float dir[3] = {rh.ray.dir_x, rh.ray.dir_y, rh.ray.dir_z};
            const float ng[3] = {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z};
            float o[3], sd[3], tfar;
            shadow_ray(s, org, dir, rh.ray.tfar, ng, o, sd, &tfar);
            struct RTCRay r = {.org_x = o[0],
                               .org_y = o[1],
                               .org_z = o[2],
                               .tnear = 0,
                               .dir_x = sd[0],
                               .dir_y = sd[1],
                               .dir_z = sd[2],
                               .time = 0,
                               .tfar = tfar,
                               .mask = 0xffffffffu,
                               .id = 0,
                               .flags = 0};
            rtcOccluded1(s->scene, &ctx, &r);
            n += r.tfar == -INFINITY;
        }
    }
    *hits = n;
    return now_1t() - t0;
}

/* Lane k of r: from org along dir, t in [0, tfar]. */
static void lane_set(struct RTCRay16 *r, int k, const float org[3], const float dir[3],
                     float tfar) {
    r->org_x[k] = org[0], r->org_y[k] = org[1], r->org_z[k] = org[2];
    r->dir_x[k] = dir[0], r->dir_y[k] = dir[1], r->dir_z[k] = dir[2];
    r->tnear[k] = 0, r->tfar[k] = tfar, r->time[k] = 0;
    r->mask[k] = 0xffffffffu, r->id[k] = (unsigned)k, r->flags[k] = 0;
}

/* Lane k of rh: lane_set's ray, unbounded, and no hit yet. */
static void lane_hit_set(struct RTCRayHit16 *rh, int k, const float org[3], const float dir[3]) {
    lane_set(&rh->ray, k, org, dir, INFINITY);
    rh->hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
    rh->hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
}

/* 16-wide packets, one per 4x4 pixel block (edge blocks masked). */
static double cast16(const struct setup *s, bool shadow, long *hits) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    long n = 0;
    struct RTCRayHit16 rh;
    struct RTCRay16 sr;
    _Alignas(64) int valid[16], svalid[16];
    /* lanes a block leaves out keep finite values: Embree's AVX2 kernels
     * (16 lanes as two 8-wide halves) assert on every lane's ray */
    memset(&sr, 0, sizeof sr);
    double t0 = now_1t();
    for (int bj = 0; bj < s->height; bj += 4) {
        for (int bi = 0; bi < s->width; bi += 4) {
            for (int k = 0; k < 16; k++) {
                int i = bi + (k & 3), j = bj + (k >> 2);
                valid[k] = i < s->width && j < s->height ? -1 : 0;
                d3 d = valid[k] ? pixel_dir(s, i, j) : s->w;
                const float org[3] = {(float)s->pos.x, (float)s->pos.y, (float)s->pos.z};
                const float dir[3] = {(float)d.x, (float)d.y, (float)d.z};
                lane_hit_set(&rh, k, org, dir);
            }
            rtcIntersect16(valid, s->scene, &ctx, &rh);
            if (!shadow) {
                for (int k = 0; k < 16; k++)
                    n += valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
                continue;
            }
            int any = 0;
            for (int k = 0; k < 16; k++) {
                svalid[k] = valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID ? -1 : 0;
                if (!svalid[k]) continue;
                any = 1;
                const float org[3] = {rh.ray.org_x[k], rh.ray.org_y[k], rh.ray.org_z[k]};
                const float dir[3] = {rh.ray.dir_x[k], rh.ray.dir_y[k], rh.ray.dir_z[k]};
                const float ng[3] = {rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]};
                float o[3], sd[3], tfar;
                shadow_ray(s, org, dir, rh.ray.tfar[k], ng, o, sd, &tfar);
                lane_set(&sr, k, o, sd, tfar);
            }
            if (!any) continue;
            rtcOccluded16(svalid, s->scene, &ctx, &sr);
            for (int k = 0; k < 16; k++) n += svalid[k] && sr.tfar[k] == -INFINITY;
        }
    }
    *hits = n;
    return now_1t() - t0;
}

/* The primary ray of pixel (i, j), ready for rtcIntersect1. */
static void primary_ray(const struct setup *s, int i, int j, struct RTCRayHit *rh) {
    d3 d = pixel_dir(s, i, j);
    *rh = (struct RTCRayHit){
        .ray = {.org_x = (float)s->pos.x,
                .org_y = (float)s->pos.y,
                .org_z = (float)s->pos.z,
                .dir_x = (float)d.x,
                .dir_y = (float)d.y,
                .dir_z = (float)d.z,
                .tfar = INFINITY,
                .mask = 0xffffffffu},
        .hit = {.geomID = RTC_INVALID_GEOMETRY_ID, .instID = {RTC_INVALID_GEOMETRY_ID}}};
}

/* Every block's shadow rays (untimed), as cast16 makes them. */
static void shadow_make(struct setup *s) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    int bw = (s->width + 3) / 4, bh = (s->height + 3) / 4;
    s->nblocks = (long)bw * bh;
    s->shadow = calloc((size_t)s->nblocks * 16 * 7, sizeof(float));
    s->svalid = calloc((size_t)s->nblocks * 16, sizeof(int));
    if (!s->shadow || !s->svalid) die("out of memory");
    s->nshadow = 0;
    struct RTCRayHit16 rh;
    _Alignas(64) int valid[16];
    for (long q = 0; q < s->nblocks; q++) {
        int bi = 4 * (int)(q % bw), bj = 4 * (int)(q / bw);
        for (int k = 0; k < 16; k++) {
            int i = bi + (k & 3), j = bj + (k >> 2);
            valid[k] = i < s->width && j < s->height ? -1 : 0;
            struct RTCRayHit one;
            primary_ray(s, valid[k] ? i : bi, valid[k] ? j : bj, &one);
            const float org[3] = {one.ray.org_x, one.ray.org_y, one.ray.org_z};
            const float dir[3] = {one.ray.dir_x, one.ray.dir_y, one.ray.dir_z};
            lane_hit_set(&rh, k, org, dir);
        }
        rtcIntersect16(valid, s->scene, &ctx, &rh);
        for (int k = 0; k < 16; k++) {
            if (!valid[k] || rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) continue;
            const float org[3] = {rh.ray.org_x[k], rh.ray.org_y[k], rh.ray.org_z[k]};
            const float dir[3] = {rh.ray.dir_x[k], rh.ray.dir_y[k], rh.ray.dir_z[k]};
            const float ng[3] = {rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]};
            float *r = &s->shadow[7 * (16 * q + k)];
            shadow_ray(s, org, dir, rh.ray.tfar[k], ng, r, r + 3, r + 6);
            s->svalid[16 * q + k] = -1;
            s->nshadow++;
        }
    }
}

/* The shadow rays alone, one at a time (rtcOccluded1).  Returns seconds;
 * *hits the rays occluded. */
static double occluded1(const struct setup *s, bool unused, long *hits) {
    (void)unused;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    long n = 0;
    double t0 = now_1t();
    for (long q = 0; q < 16 * s->nblocks; q++) {
        if (!s->svalid[q]) continue;
        const float *b = &s->shadow[7 * q];
        struct RTCRay r = {.org_x = b[0],
                           .org_y = b[1],
                           .org_z = b[2],
                           .dir_x = b[3],
                           .dir_y = b[4],
                           .dir_z = b[5],
                           .tfar = b[6],
                           .mask = 0xffffffffu};
        rtcOccluded1(s->scene, &ctx, &r);
        n += r.tfar == -INFINITY;
    }
    *hits = n;
    return now_1t() - t0;
}

/* The shadow rays alone, a block a packet (rtcOccluded16). */
static double occluded16(const struct setup *s, bool unused, long *hits) {
    (void)unused;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    long n = 0;
    struct RTCRay16 sr;
    _Alignas(64) int valid[16];
    double t0 = now_1t();
    for (long q = 0; q < s->nblocks; q++) {
        int any = 0;
        for (int k = 0; k < 16; k++) {
            const float *b = &s->shadow[7 * (16 * q + k)];
            valid[k] = s->svalid[16 * q + k];
            any |= valid[k];
            lane_set(&sr, k, b, b + 3, b[6]);
        }
        if (!any) continue;
        rtcOccluded16(valid, s->scene, &ctx, &sr);
        for (int k = 0; k < 16; k++) n += valid[k] && sr.tfar[k] == -INFINITY;
    }
    *hits = n;
    return now_1t() - t0;
}

/* Every pixel's bounce ray (untimed), as raybench makes them. */
static void bounce_make(struct setup *s) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    s->bounce = malloc(sizeof(float) * 6 * (size_t)s->width * s->height);
    if (!s->bounce) die("out of memory");
    s->nbounce = 0;
    for (int j = 0; j < s->height; j++) {
        for (int i = 0; i < s->width; i++) {
            struct RTCRayHit rh;
            primary_ray(s, i, j, &rh);
            rtcIntersect1(s->scene, &ctx, &rh);
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
            const float org[3] = {rh.ray.org_x, rh.ray.org_y, rh.ray.org_z};
            const float dir[3] = {rh.ray.dir_x, rh.ray.dir_y, rh.ray.dir_z};
            const float ng[3] = {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z};
            double p[3], n[3], d[3];
            lift(org, dir, rh.ray.tfar, ng, p, n);
            bounce_dir((uint32_t)j * (uint32_t)s->width + (uint32_t)i, n, d);
            float *b = &s->bounce[6 * s->nbounce++];
            for (int k = 0; k < 3; k++) {
                b[k] = (float)p[k];
                b[3 + k] = (float)d[k];
            }
        }
    }
}

/* Bounce rays one at a time (rtcIntersect1).  Returns seconds; *hits the
 * rays that hit. */
static double bounce1(const struct setup *s, bool unused, long *hits) {
    (void)unused;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    long n = 0;
    double t0 = now_1t();
    for (long q = 0; q < s->nbounce; q++) {
        const float *b = &s->bounce[6 * q];
        struct RTCRayHit rh = {
            .ray = {.org_x = b[0],
                    .org_y = b[1],
                    .org_z = b[2],
                    .dir_x = b[3],
                    .dir_y = b[4],
                    .dir_z = b[5],
                    .tfar = INFINITY,
                    .mask = 0xffffffffu},
            .hit = {.geomID = RTC_INVALID_GEOMETRY_ID, .instID = {RTC_INVALID_GEOMETRY_ID}}};
        rtcIntersect1(s->scene, &ctx, &rh);
        n += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
    *hits = n;
    return now_1t() - t0;
}

/* Bounce rays 16 consecutive ones a packet (rtcIntersect16, the last one
 * masked). */
static double bounce16(const struct setup *s, bool unused, long *hits) {
    (void)unused;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    long n = 0;
    struct RTCRayHit16 rh;
    _Alignas(64) int valid[16];
    double t0 = now_1t();
    for (long q0 = 0; q0 < s->nbounce; q0 += 16) {
        for (int k = 0; k < 16; k++) {
            long q = q0 + k < s->nbounce ? q0 + k : q0;
            const float *b = &s->bounce[6 * q];
            valid[k] = q0 + k < s->nbounce ? -1 : 0;
            lane_hit_set(&rh, k, b, b + 3);
        }
        rtcIntersect16(valid, s->scene, &ctx, &rh);
        for (int k = 0; k < 16; k++) n += valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
    }
    *hits = n;
    return now_1t() - t0;
}

static atomic_llong mem_now, mem_peak;

static bool mem_monitor(void *user, ssize_t bytes, bool post) {
    (void)user;
    (void)post;
    long long v = atomic_fetch_add(&mem_now, (long long)bytes) + (long long)bytes;
    long long p = atomic_load(&mem_peak);
    while (v > p && !atomic_compare_exchange_weak(&mem_peak, &p, v)) {
    }
    return true;
}

static RTCScene build_scene(RTCDevice dev, const struct mesh_data *m, bool robust) {
    RTCScene sc = rtcNewScene(dev);
    rtcSetSceneBuildQuality(sc, RTC_BUILD_QUALITY_MEDIUM);
    if (robust) rtcSetSceneFlags(sc, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_MEDIUM);
    float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                        3 * sizeof(float), m->nverts);
    unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                           3 * sizeof(unsigned), m->ntris);
    if (!vb || !ib) die("rtcSetNewGeometryBuffer failed");
    memcpy(vb, m->pos, sizeof(float) * 3 * m->nverts);
    memcpy(ib, m->index, sizeof(unsigned) * 3 * m->ntris);
    rtcCommitGeometry(g);
    rtcAttachGeometry(sc, g);
    rtcReleaseGeometry(g);
    return sc;
}

int main(int argc, char **argv) {
    const char *path = NULL;
    int w = 0, h = 0, runs = 3;
    bool robust = false;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--width") && i + 1 < argc)
            w = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--height") && i + 1 < argc)
            h = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--cpu-time"))
            use_cpu_time = true;
        else if (!strcmp(argv[i], "--robust"))
            robust = true;
        else
            path = argv[i];
    }
    if (!path || w < 0 || h < 0 || runs <= 0 || runs > 99) {
        fprintf(stderr,
                "usage: embree_bench SCENE.json [--width W] [--height H] [--runs N] [--cpu-time]"
                " [--robust]\n");
        return 2;
    }
    size_t len;
    char *text = NULL;
    if (rayd_read_file(path, (size_t)1 << 31, &text, &len, NULL) != RAYD_OK) text = NULL;
    if (!text) die("cannot read the scene");
    cJSON *root = cJSON_Parse(text);
    free(text);
    if (!root) die("scene is not JSON");
    const cJSON *cam = cJSON_GetObjectItemCaseSensitive(root, "camera");
    const cJSON *rs = cJSON_GetObjectItemCaseSensitive(root, "render");
    const cJSON *lights = cJSON_GetObjectItemCaseSensitive(root, "lights");
    const cJSON *objs = cJSON_GetObjectItemCaseSensitive(root, "objects");
    const cJSON *mesh = NULL, *o;
    cJSON_ArrayForEach(o, objs) {
        const cJSON *t = cJSON_GetObjectItemCaseSensitive(o, "type");
        if (cJSON_IsString(t) && !strcmp(t->valuestring, "mesh")) {
            if (mesh) die("more than one mesh in the scene");
            mesh = o;
        }
    }
    const cJSON *file =
        cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(mesh, "source"), "file");
    if (!cJSON_IsString(file)) die("no mesh object with source.file in the scene");
    if (cJSON_GetObjectItemCaseSensitive(mesh, "transform")) die("mesh transforms not supported");

    /* Camera, as the loader and raybench set it up. */
    struct setup s = {0};
    int sw = (int)json_num(rs, "width", 640), sh = (int)json_num(rs, "height", 480);
    s.width = w ? w : sw;
    s.height = h ? h : sh;
    s.pos = json_vec(cam, "position", (d3){0, 0, 0});
    d3 look = json_vec(cam, "look_at", (d3){0, 0, -1}), up = json_vec(cam, "up", (d3){0, 1, 0});
    s.w = d3_norm(d3_sub(look, s.pos));
    s.u = d3_norm(d3_cross(s.w, up));
    s.v = d3_cross(s.u, s.w);
    const double deg = 3.14159265358979323846 / 180;
    double fx = json_num(cam, "fov_x", 0), fy = json_num(cam, "fov_y", 0);
    if (fx > 0)
        s.tan_x = tan(fx * deg / 2);
    else if (fy > 0)
        s.tan_x = tan(fy * deg / 2) * sw / sh;
    else
        s.tan_x = tan(60 * deg / 2);
    s.tan_y = s.tan_x * s.height / s.width; /* as raybench does */
    const cJSON *l0 = cJSON_GetArrayItem(lights, 0);
    const cJSON *lt = cJSON_GetObjectItemCaseSensitive(l0, "type");
    if (!l0) {
        s.light = (d3){0, 1, 0};
    } else if (cJSON_IsString(lt) && !strcmp(lt->valuestring, "directional")) {
        d3 d = d3_norm(json_vec(l0, "direction", (d3){0, -1, 0}));
        s.light = (d3){-d.x, -d.y, -d.z};
    } else {
        s.light_is_point = true;
        s.light = json_vec(l0, "position", (d3){0, 0, 0});
    }

    /* The mesh, beside the scene file. */
    char ply[4096];
    const char *slash = strrchr(path, '/');
    snprintf(ply, sizeof ply, "%.*s%s", slash ? (int)(slash - path + 1) : 0, path,
             file->valuestring);
    /* Read and decoded by the core's reader, as rayd does it: timed, so
     * the end-to-end comparison of bench-peers has a load figure for the
     * Embree side (Embree itself reads no files). */
    char *data = NULL;
    double tp = now();
    if (rayd_read_file(ply, (size_t)1 << 31, &data, &len, NULL) != RAYD_OK) data = NULL;
    if (!data) die("cannot read the mesh file");
    struct mesh_data m;
    struct rayd_error err = {0};
    enum rayd_status pst = mesh_parse_ply(data, len, NULL, &m, &err);
    double parse_s = now() - tp;
    if (pst != RAYD_OK) {
        char msg[600];
        fprintf(stderr, "embree_bench: %s: %s\n", ply, rayd_error_format(&err, msg, sizeof msg));
        return 1;
    }
    free(data);
    cJSON_Delete(root);

    /* Denormals flushed to zero, as Embree's own tutorials set it up. */
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    RTCDevice dev = rtcNewDevice(NULL);
    if (!dev) die("rtcNewDevice failed");
    rtcSetDeviceMemoryMonitorFunction(dev, mem_monitor, NULL);

    /* Build: RUNS fresh scenes, median time; bytes of the last one. */
    double bt[99];
    long long bytes = 0, total = 0;
    for (int r = 0; r < runs; r++) {
        if (s.scene) rtcReleaseScene(s.scene);
        long long start = atomic_load(&mem_now);
        RTCScene sc = build_scene(dev, &m, robust); /* geometry upload: not timed */
        long long before = atomic_load(&mem_now);
        double t0 = now();
        rtcCommitScene(sc);
        bt[r] = now() - t0;
        bytes = atomic_load(&mem_now) - before;
        total = atomic_load(&mem_now) - start;
        if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) die("rtcCommitScene failed");
        s.scene = sc;
    }
    printf("scene %s\n", path);
    printf("peer embree %s\n", RTC_VERSION_STRING);
    printf("triangles %u\n", m.ntris);
    printf("parse_s %.4f\n", parse_s);
    printf("bvh_build_s %.4f\n", median(bt, runs));
    printf("bvh_bytes_per_triangle %.1f\n", (double)bytes / m.ntris);
    printf("bytes_per_triangle %.1f\n", (double)total / m.ntris);

    bounce_make(&s);
    printf("bounce_rays %ld\n", s.nbounce);
    shadow_make(&s);
    printf("occlusion_rays %ld\n", s.nshadow);
    long pixels = (long)s.width * s.height;
    struct {
        const char *name;
        double (*fn)(const struct setup *, bool, long *);
        bool shadow;
    } casts[] = {{"primary_mrays_1t_single", cast1, false},
                 {"primary_mrays_1t_packet16", cast16, false},
                 {"shadow_mrays_1t_single", cast1, true},
                 {"shadow_mrays_1t_packet16", cast16, true},
                 {"occlusion_mrays_1t_single", occluded1, false},
                 {"occlusion_mrays_1t_packet16", occluded16, false},
                 {"bounce_mrays_1t_single", bounce1, false},
                 {"bounce_mrays_1t_packet16", bounce16, false}};
    for (size_t c = 0; c < sizeof casts / sizeof casts[0]; c++) {
        double rate[99];
        bool bounce = casts[c].fn == bounce1 || casts[c].fn == bounce16;
        bool occl = casts[c].fn == occluded1 || casts[c].fn == occluded16;
        long hits = 0, count = bounce ? s.nbounce : occl ? s.nshadow : pixels; /* else pixels */
        casts[c].fn(&s, casts[c].shadow, &hits); /* untimed: see the comment at the top */
        for (int r = 0; r < runs; r++)
            rate[r] = count / casts[c].fn(&s, casts[c].shadow, &hits) / 1e6;
        printf("%s %.2f\n", casts[c].name, median(rate, runs));
        printf("%s_hits %ld\n", casts[c].name, hits);
    }
    free(s.bounce);
    free(s.shadow), free(s.svalid);
    rtcReleaseScene(s.scene);
    rtcReleaseDevice(dev);
    mesh_data_free(&m);
    return 0;
}
