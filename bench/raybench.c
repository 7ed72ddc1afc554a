/* raybench -- ray throughput of the core on one scene.
 *
 *   raybench SCENE.json [--width W] [--height H] [--runs N] [--threads-max T] [--cpu-time]
 *            [--packets-only] [--kind primary|shadow|occlusion|bounce]
 *
 * Loads the scene (timing parse + BVH build), then casts, once untimed and
 * RUNS times each, and reports the median of the timed ones:
 *   - primary rays: one through every pixel centre of a W x H image (the
 *     scene's camera), nearest hit only, no shading;
 *   - shadow rays: from every primary hit toward the first light (or
 *     straight up when the scene has none), any hit only;
 *   - both again as packets of 4x4 pixels (scene_intersect16 and
 *     scene_transmittance16; keys with _packet), their hit counts printed
 *     beside the one-ray ones, which they must equal;
 *   - the shadow rays alone (kind occlusion): the same shadow rays, made
 *     once, untimed, a 4x4 pixel block at a time, then cast one at a time
 *     (scene_transmittance) and as a packet a block (scene_transmittance16),
 *     as rays per second of shadow rays alone (occlusion_rays of them): the
 *     any-hit query itself, as bounce rays measure the nearest-hit one;
 *   - diffuse-bounce rays, the incoherent ones: from every primary hit one
 *     cosine-weighted direction about the geometric normal, drawn from a
 *     hash of the pixel (bench/bounce.h, shared with embree_bench), origin
 *     lifted off the surface as core/render/integrate.h does, nearest hit.
 *     They are made once, untimed, in pixel order; then cast one at a time
 *     (scene_intersect) and as packets of 16 consecutive ones
 *     (scene_intersect16), as rays per second of bounce rays alone
 *     (bounce_rays of them; bounce_hits must match Embree's closely);
 * on 1 thread and on T threads (default 2); and one end-to-end image
 * (rayd_render, shading and PNG-ready pixels) on T threads.
 * Output is one "key value" line each, for bench/ scripts to read.
 * --cpu-time times what runs on one thread (the 1-thread casts, and the
 * image when T is 1) in CPU seconds of the process instead of wall
 * seconds: same keys, but a machine shared with other work then slows the
 * figures far less (bench/peers.sh uses it beside the wall-clock figures).
 *
 * It links the core's internals (like the unit tests), because it measures
 * the queries under the integrator, not only whole images.
 */
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bounce.h"
#include "../tests/unit/peak_rss.h"
#include "render/integrate.h"
#include "scene/scene.h"

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* The clock of single-threaded measurements: wall, or with --cpu-time the
 * process's CPU time (the only busy thread's, then). */
static bool use_cpu_time;

static double now_1t(void) {
    if (!use_cpu_time) return now();
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* What a cast measures. */
enum kind { PRIMARY, SHADOW, OCCLUSION, BOUNCE, NKINDS };

static const char *const kind_names[NKINDS] = {"primary", "shadow", "occlusion", "bounce"};

/* The kind named s, or NKINDS for a name of none (a usage error). */
static int kind_named(const char *s) {
    int k = 0;
    while (k < NKINDS && strcmp(s, kind_names[k])) k++;
    return k;
}

/* The bounce rays, in pixel order of their primary hits. */
struct bounces {
    ray *r;
    long n;
};

/* The shadow rays alone, a 4x4 pixel block each 16 places: block q's rays
 * at r[16 q + k] for the lanes k in mask[q], whose primary rays hit. */
struct shadows {
    ray *r;
    double *tmax;
    uint16_t *mask;
    int bw, bh; /* blocks across and down */
    long n;     /* rays */
};

/* Bounce rays are handed out this many a work item. */
#define BOUNCE_CHUNK 4096

struct work {
    const rayd_scene *s;
    struct camera cam;
    int w, h;
    enum kind kind;
    bool packets; /* 4x4 pixels a packet (scene_intersect16) */
    const struct bounces *b;
    const struct shadows *sh;
    atomic_int next_row; /* a row (of pixels or packets), or a chunk of bounce rays */
    atomic_long hits;
};

static vec3 light_dir(const rayd_scene *s, vec3 p, double *dist) {
    if (s->nlights == 0) {
        *dist = INFINITY;
        return v3(0, 1, 0);
    }
    vec3 to, rad;
    if (!light_at(&s->lights[0], p, &to, dist, &rad)) {
        to = v3_norm(v3_sub(s->lights[0].position, p));
        *dist = v3_len(v3_sub(s->lights[0].position, p));
    }
    return to;
}

/* The point and unit geometric normal of hit h of ray r, and whether the
 * geometry is in float: on an untransformed mesh those two alone, the
 * same values as scene_surface's, which also looks up the material and
 * the shading normal (embree_bench has the normal from its hit and takes
 * the point along its ray); any other hit through scene_surface. */
static void hit_geometry(const rayd_scene *s, const ray *r, const struct hit *h, vec3 *p, vec3 *ng,
                         bool *float_geom) {
    const struct object *o = h->leaf;
    if (o->kind == SHAPE_MESH && o->xform < 0 && !h->outer && !h->orient) {
        const struct mesh *m = &s->meshes[o->u.mesh.id];
        *p = mesh_point(m, &h->mh);
        *ng = mesh_geometric_normal(m, &h->mh);
        *float_geom = true;
        return;
    }
    struct surface sf;
    scene_surface(s, r, h, &sf);
    *p = sf.p, *ng = sf.ng, *float_geom = sf.float_geom;
}

/* The origin of a secondary ray from hit h of ray r, lifted off the
 * surface as core/render/integrate.h does, and in *n the geometric normal
 * on the side r came from. */
static vec3 hit_lifted(const rayd_scene *s, const ray *r, const struct hit *h, vec3 *n) {
    vec3 p, ng;
    bool float_geom;
    hit_geometry(s, r, h, &p, &ng, &float_geom);
    *n = v3_dot(ng, r->d) > 0 ? v3_neg(ng) : ng;
    return v3_madd(p, *n, integrate_offset(p, float_geom));
}

/* The shadow ray from primary hit h of ray r: origin, direction, length. */
static void shadow_ray(const rayd_scene *s, const ray *r, const struct hit *h, ray *sr,
                       double *dist) {
    vec3 n;
    sr->o = hit_lifted(s, r, h, &n);
    sr->d = light_dir(s, sr->o, dist);
}

/* One ray at a time, a row of pixels per work item. */
static long cast_rows(struct work *wk) {
    long hits = 0;
    for (;;) {
        int j = atomic_fetch_add(&wk->next_row, 1);
        if (j >= wk->h) break;
        for (int i = 0; i < wk->w; i++) {
            ray r = {wk->cam.pos, cam_dir(&wk->cam, i + 0.5, j + 0.5)};
            struct hit hit;
            if (!scene_intersect(wk->s, &r, INFINITY, &hit)) continue;
            if (wk->kind == PRIMARY) {
                hits++;
                continue;
            }
            ray sr;
            double dist;
            shadow_ray(wk->s, &r, &hit, &sr, &dist);
            vec3 t = scene_transmittance(wk->s, &sr, dist);
            hits += t.x == 0 && t.y == 0 && t.z == 0;
        }
    }
    return hits;
}

/* The primary rays of the 4x4 pixels from (i0, j0) of a w x h image, ray
 * k for pixel (i0 + k % 4, j0 + k / 4), unbounded; returns the lanes inside
 * the image. */
static uint32_t block_rays(const struct camera *cam, int w, int h, int i0, int j0, ray r[16],
                           double tmax[16]) {
    uint32_t active = 0;
    for (int k = 0; k < 16; k++) {
        int i = i0 + k % 4, j = j0 + k / 4;
        tmax[k] = INFINITY;
        if (i >= w || j >= h) continue;
        r[k] = (ray){cam->pos, cam_dir(cam, i + 0.5, j + 0.5)};
        active |= 1u << k;
    }
    return active;
}

/* Packets of 4x4 pixels, a row of packets per work item. */
static long cast_packets(struct work *wk) {
    long hits = 0;
    for (;;) {
        int j0 = 4 * atomic_fetch_add(&wk->next_row, 1);
        if (j0 >= wk->h) break;
        for (int i0 = 0; i0 < wk->w; i0 += 4) {
            ray r[16];
            double tmax[16];
            uint32_t active = block_rays(&wk->cam, wk->w, wk->h, i0, j0, r, tmax);
            struct hit h[16];
            uint32_t hit = scene_intersect16(wk->s, r, tmax, active, h);
            if (wk->kind == PRIMARY) {
                hits += __builtin_popcount(hit);
                continue;
            }
            ray sr[16];
            vec3 t[16];
            for (uint32_t m = hit; m; m &= m - 1) {
                int k = __builtin_ctz(m);
                shadow_ray(wk->s, &r[k], &h[k], &sr[k], &tmax[k]);
            }
            scene_transmittance16(wk->s, sr, tmax, hit, t);
            for (uint32_t m = hit; m; m &= m - 1) {
                int k = __builtin_ctz(m);
                hits += t[k].x == 0 && t[k].y == 0 && t[k].z == 0;
            }
        }
    }
    return hits;
}

/* Every block's shadow rays (untimed): primary rays as packets, as
 * cast_packets makes them. */
static void shadow_make(const rayd_scene *s, const struct camera *cam, int w, int h,
                        struct shadows *sh) {
    sh->bw = (w + 3) / 4, sh->bh = (h + 3) / 4;
    size_t nb = (size_t)sh->bw * sh->bh;
    sh->r = malloc(sizeof *sh->r * 16 * nb);
    sh->tmax = malloc(sizeof *sh->tmax * 16 * nb);
    sh->mask = malloc(sizeof *sh->mask * nb);
    sh->n = 0;
    for (size_t q = 0; q < nb; q++) {
        int i0 = 4 * (int)(q % (size_t)sh->bw), j0 = 4 * (int)(q / (size_t)sh->bw);
        ray r[16];
        double tmax[16];
        uint32_t active = block_rays(cam, w, h, i0, j0, r, tmax);
        struct hit hits[16];
        uint32_t hit = scene_intersect16(s, r, tmax, active, hits);
        for (uint32_t m = hit; m; m &= m - 1) {
            int k = __builtin_ctz(m);
            shadow_ray(s, &r[k], &hits[k], &sh->r[16 * q + k], &sh->tmax[16 * q + k]);
        }
        for (int k = 0; k < 16; k++)
            if (!(hit >> k & 1)) sh->r[16 * q + k] = sh->r[16 * q], sh->tmax[16 * q + k] = 0;
        sh->mask[q] = (uint16_t)hit;
        sh->n += __builtin_popcount(hit);
    }
}

/* The shadow rays alone, a row of blocks per work item: one at a time, or
 * a block a packet. */
static long cast_shadows(struct work *wk) {
    const struct shadows *sh = wk->sh;
    long hits = 0;
    for (;;) {
        int row = atomic_fetch_add(&wk->next_row, 1);
        if (row >= sh->bh) break;
        for (long q = (long)row * sh->bw; q < (long)(row + 1) * sh->bw; q++) {
            const ray *r = &sh->r[16 * q];
            const double *tmax = &sh->tmax[16 * q];
            if (!wk->packets) {
                for (uint32_t m = sh->mask[q]; m; m &= m - 1) {
                    int k = __builtin_ctz(m);
                    vec3 t = scene_transmittance(wk->s, &r[k], tmax[k]);
                    hits += t.x == 0 && t.y == 0 && t.z == 0;
                }
                continue;
            }
            vec3 t[16];
            scene_transmittance16(wk->s, r, tmax, sh->mask[q], t);
            for (uint32_t m = sh->mask[q]; m; m &= m - 1) {
                int k = __builtin_ctz(m);
                hits += t[k].x == 0 && t[k].y == 0 && t[k].z == 0;
            }
        }
    }
    return hits;
}

/* The bounce ray of pixel `pixel` from primary hit h of ray r. */
static void bounce_ray(const rayd_scene *s, const ray *r, const struct hit *h, uint32_t pixel,
                       ray *br) {
    vec3 n;
    br->o = hit_lifted(s, r, h, &n);
    double nd[3] = {n.x, n.y, n.z}, d[3];
    bounce_dir(pixel, nd, d);
    br->d = v3(d[0], d[1], d[2]);
}

/* Every pixel's bounce ray (untimed): primary rays one at a time. */
static void bounce_make(const rayd_scene *s, const struct camera *cam, int w, int h,
                        struct bounces *b) {
    b->r = malloc(sizeof *b->r * (size_t)w * h);
    b->n = 0;
    for (int j = 0; j < h; j++) {
        for (int i = 0; i < w; i++) {
            ray r = {cam->pos, cam_dir(cam, i + 0.5, j + 0.5)};
            struct hit hit;
            if (scene_intersect(s, &r, INFINITY, &hit))
                bounce_ray(s, &r, &hit, (uint32_t)j * (uint32_t)w + (uint32_t)i, &b->r[b->n++]);
        }
    }
}

/* Bounce rays, a chunk a work item: one at a time, or 16 consecutive ones
 * a packet. */
static long cast_bounces(struct work *wk) {
    long hits = 0, n = wk->b->n;
    for (;;) {
        long c0 = (long)BOUNCE_CHUNK * atomic_fetch_add(&wk->next_row, 1);
        if (c0 >= n) break;
        long c1 = c0 + BOUNCE_CHUNK < n ? c0 + BOUNCE_CHUNK : n;
        const ray *r = wk->b->r;
        if (!wk->packets) {
            for (long k = c0; k < c1; k++) {
                struct hit hit;
                hits += scene_intersect(wk->s, &r[k], INFINITY, &hit);
            }
            continue;
        }
        for (long k = c0; k < c1; k += 16) {
            double tmax[16];
            struct hit h[16];
            int m = c1 - k < 16 ? (int)(c1 - k) : 16;
            for (int q = 0; q < 16; q++) tmax[q] = INFINITY;
            uint32_t active = m == 16 ? 0xffffu : (1u << m) - 1;
            hits += __builtin_popcount(scene_intersect16(wk->s, &r[k], tmax, active, h));
        }
    }
    return hits;
}

static void *worker(void *arg) {
    struct work *wk = arg;
    long hits = wk->kind == BOUNCE      ? cast_bounces(wk)
                : wk->kind == OCCLUSION ? cast_shadows(wk)
                : wk->packets           ? cast_packets(wk)
                                        : cast_rows(wk);
    atomic_fetch_add(&wk->hits, hits);
    return NULL;
}

/* Seconds to cast the rays on `threads` threads; *count gets the rays cast
 * (pixels for primary and shadow rays, else the rays alone). */
static double cast(const rayd_scene *s, const struct camera *cam, int w, int h, enum kind kind,
                   const struct bounces *b, const struct shadows *sh, bool packets, int threads,
                   long *count, long *hits) {
    struct work wk = {
        .s = s, .cam = *cam, .w = w, .h = h, .kind = kind, .packets = packets, .b = b, .sh = sh};
    atomic_init(&wk.next_row, 0);
    atomic_init(&wk.hits, 0);
    pthread_t th[64];
    double (*tick)(void) = threads == 1 ? now_1t : now;
    double t0 = tick();
    for (int i = 1; i < threads; i++) pthread_create(&th[i], NULL, worker, &wk);
    worker(&wk);
    for (int i = 1; i < threads; i++) pthread_join(th[i], NULL);
    double dt = tick() - t0;
    *count = kind == BOUNCE ? b->n : kind == OCCLUSION ? sh->n : (long)w * h;
    *hits = atomic_load(&wk.hits);
    return dt;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n) {
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return v[n / 2];
}

/* The loader's charges (rayd_limits.charge): what it holds now and at
 * most, to set beside the load's resident peak (VmHWM). */
struct load_count {
    long long net, peak;
};

static enum rayd_status load_charge(void *arg, long long bytes, char *why, size_t why_len) {
    struct load_count *c = arg;
    (void)why, (void)why_len;
    c->net += bytes;
    if (c->net > c->peak) c->peak = c->net;
    return RAYD_OK;
}

int main(int argc, char **argv) {
    const char *path = NULL;
    int w = 1920, h = 1080, runs = 3, tmax = 2, packets_only = 0, only = -1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--width") && i + 1 < argc)
            w = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--height") && i + 1 < argc)
            h = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads-max") && i + 1 < argc)
            tmax = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--cpu-time"))
            use_cpu_time = true;
        else if (!strcmp(argv[i], "--packets-only"))
            packets_only = 1;
        else if (!strcmp(argv[i], "--kind") && i + 1 < argc)
            only = kind_named(argv[++i]);
        else
            path = argv[i];
    }
    if (!path || w <= 0 || h <= 0 || runs <= 0 || runs > 99 || tmax < 1 || tmax > 64 ||
        only == NKINDS) {
        fprintf(stderr,
                "usage: raybench SCENE.json [--width W] [--height H] [--runs N] [--threads-max T]"
                " [--cpu-time] [--packets-only] [--kind primary|shadow|occlusion|bounce]\n");
        return 2;
    }
    size_t len;
    char *text = NULL;
    if (rayd_read_file(path, (size_t)1 << 31, &text, &len, NULL) != RAYD_OK) text = NULL;
    if (!text) {
        fprintf(stderr, "raybench: cannot read %s\n", path);
        return 1;
    }
    char dir[4096];
    const char *slash = strrchr(path, '/');
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) : 1, slash ? path : ".");
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.asset_dir = dir;
    lim.asset_confine = 0;
    lim.max_bytes = (size_t)1 << 31;
    struct load_count charged = {0, 0};
    lim.charge = load_charge;
    lim.charge_arg = &charged;
    struct rayd_error err = {0};
    rayd_scene *s = NULL;
    bool hwm_reset = peak_rss_reset(); /* VmHWM from here */
    long rss0 = peak_rss_kb("VmRSS");
    double t0 = now();
    if (rayd_scene_parse(text, len, &lim, &s, &err) != RAYD_OK) {
        char msg[600];
        fprintf(stderr, "raybench: %s\n", rayd_error_format(&err, msg, sizeof msg));
        return 1;
    }
    double load = now() - t0;
    free(text);

    long tris = 0;
    size_t mesh_bytes_total = 0;
    for (uint32_t i = 0; i < s->nmeshes; i++) {
        tris += s->meshes[i].ntris;
        mesh_bytes_total += mesh_bytes(&s->meshes[i]);
    }
    if (tris && hwm_reset && rss0 >= 0) { /* the load's resident peak against its charge */
        printf("load_peak_bytes_per_triangle %.1f\n",
               (double)(peak_rss_kb("VmHWM") - rss0) * 1024.0 / (double)tris);
        printf("load_charged_bytes_per_triangle %.1f\n", (double)charged.peak / (double)tris);
    }
    /* BVH build alone: rebuild the largest mesh's (8-wide) hierarchy. */
    double build = 0;
    uint32_t big = 0;
    for (uint32_t i = 1; i < s->nmeshes; i++)
        if (s->meshes[i].ntris > s->meshes[big].ntris) big = i;
    if (s->nmeshes) {
        const struct mesh *m = &s->meshes[big];
        struct bbox *boxes = malloc(sizeof *boxes * m->ntris);
        uint32_t *order = malloc(sizeof *order * m->ntris);
        uint32_t t = 0; /* the triangles' boxes, from the leaf blocks */
        for (uint32_t bi = 0; bi < m->nblocks; bi++) {
            const struct tri4 *blk = &m->blocks[bi];
            for (int lane = 0; lane < 4 && blk->id[lane] != UINT32_MAX; lane++, t++) {
                for (int k = 0; k < 3; k++) {
                    float a = blk->v[0][k][lane], b = blk->v[1][k][lane], c = blk->v[2][k][lane];
                    boxes[t].lo[k] = fminf(a, fminf(b, c));
                    boxes[t].hi[k] = fmaxf(a, fmaxf(b, c));
                }
            }
        }
        double bt[99];
        for (int r = 0; r < runs; r++) {
            struct bvh8 bvh;
            double b0 = now();
            bvh8_build_from(&bvh, bvh_boxes_copy, boxes, m->ntris, BVH_MAX_LEAF, order, tmax, NULL);
            bt[r] = now() - b0;
            bvh8_free(&bvh);
        }
        build = median(bt, runs);
        free(boxes);
        free(order);
    }
    struct camera cam;
    cam_init(&cam, s->cam.pos, v3_add(s->cam.pos, s->cam.w), s->cam.v, 0, 0, w, h, NULL);
    cam.tan_x = s->cam.tan_x;
    cam.tan_y = s->cam.tan_x * h / w;

    printf("scene %s\n", path);
    printf("triangles %ld\n", tris);
    printf("objects %ld\n", (long)s->nobjs + s->nplanes);
    printf("load_s %.4f\n", load);
    printf("bvh_build_s %.4f\n", build);
    if (tris) printf("bytes_per_triangle %.1f\n", (double)mesh_bytes_total / (double)tris);
    struct bounces b;
    bounce_make(s, &cam, w, h, &b);
    printf("bounce_rays %ld\n", b.n);
    struct shadows sh;
    shadow_make(s, &cam, w, h, &sh);
    printf("occlusion_rays %ld\n", sh.n);
    int thread_counts[2] = {1, tmax};
    for (int ti = 0; ti < (tmax > 1 ? 2 : 1); ti++) {
        for (int packets = packets_only; packets <= 1; packets++) {
            for (int k = PRIMARY; k < NKINDS; k++) {
                if (only >= 0 && k != only) continue;
                double rate[99];
                long count = 0, hits = 0;
                /* untimed, as embree_bench's: the first cast of a kind is no other's */
                cast(s, &cam, w, h, (enum kind)k, &b, &sh, packets, thread_counts[ti], &count,
                     &hits);
                for (int r = 0; r < runs; r++) {
                    double dt = cast(s, &cam, w, h, (enum kind)k, &b, &sh, packets,
                                     thread_counts[ti], &count, &hits);
                    rate[r] = count / dt / 1e6;
                }
                const char *kind = kind_names[k];
                printf("%s%s_mrays_%dt %.2f\n", kind, packets ? "_packet" : "", thread_counts[ti],
                       median(rate, runs));
                if (ti == 0) printf("%s%s_hits %ld\n", kind, packets ? "_packet" : "", hits);
            }
        }
    }
    free(b.r);
    free(sh.r), free(sh.tmax), free(sh.mask);
    /* End to end: the whole image, shaded, on tmax threads. */
    double it[99];
    struct rayd_render_stats st = {0};
    for (int r = 0; r < runs; r++) {
        struct rayd_render_opts o = {.threads = tmax, .stats = &st};
        rayd_image *img = NULL;
        double (*tick)(void) = tmax == 1 ? now_1t : now;
        double i0 = tick();
        rayd_render(s, &o, &img, NULL);
        it[r] = tick() - i0;
        rayd_image_free(img);
    }
    printf("image_s_%dt %.4f\n", tmax, median(it, runs));
    rayd_scene_free(s);
    return 0;
}
