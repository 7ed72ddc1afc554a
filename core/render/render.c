/* render.c -- regions, tiles and threads.
 *
 * A pixel's colour depends only on the scene and the pixel's whole-image
 * coordinates: sample positions and every random number come from the
 * counter-based RNG keyed by (seed, pixel, sample).  So any region, tiled
 * any way, on any number of threads, gives the same bytes as the same crop
 * of a full render.
 *
 * Samples inside a pixel follow the R2 low-discrepancy sequence (Roberts'
 * generalised golden ratio) shifted by a per-pixel random offset
 * (Cranley-Patterson rotation): well stratified for any sample count, not
 * only squares; lens positions for depth of field likewise.  One sample
 * goes through the pixel centre, as in the paper.
 *
 * rayd_render splits the region into tiles handed out through an atomic
 * counter to `threads` pthreads; each thread keeps its own ray count (its
 * meter), so the hot loop shares nothing.  A tile is traced in blocks of 4x4 pixels, each
 * sample's 16 camera rays as one packet (scene_packet.c); since a packet
 * gives every ray exactly its one-ray answer, the blocks change nothing
 * in the bytes.  Each thread counts its rays on a meter (base/meter.h),
 * which looks at the cancel flag and the ray budget every thousand rays or
 * so, before every pixel sample of a block, and inside the scene's costly
 * walks: a stop is seen within milliseconds whatever one pixel costs.
 *
 * Rows done (opts->rows).  The tiles are handed out row by row, and each
 * row of tiles counts the tiles it still lacks (base/rows.c, the one
 * tracker rayd's workers use too); the thread that draws a row's last tile
 * counts the rows at the top that are all drawn and tells the caller, which may then read those
 * rows while the other threads draw on (rayd-render and rayd deflate the PNG's bands so,
 * png_encode.c).
 *
 * The same blocks serve progressive passes (accum.c): instead of bytes, a
 * block then adds a range of samples k0..k1-1 to running per-pixel sums,
 * which is exactly what the plain render does before it scales and
 * converts; so a pass of n samples resolves to the plain render's bytes.
 *
 * Sums that do not depend on grouping.  A pixel's samples are summed in
 * double, but first each sample's radiance is rounded to a multiple of
 * 2^-22 and capped at RENDER_SUM_CAP (render_sum_term).  Every partial sum
 * of at most RENDER_SUM_SAMPLES such terms is then an integer times 2^-22
 * below 2^53 * 2^-22, which a double holds exactly, so no addition rounds:
 * samples 0..k-1 summed on one machine plus k..n-1 summed on another give
 * the very bits of 0..n-1 summed in order.  That is what lets one frame's
 * samples be spread over many nodes (rayd_render_sample_sums) and still
 * equal the single-node render byte for byte.  The rounding (at most
 * 1.2e-7 a sample) is below a float's step at 1.0 and far below an 8-bit
 * or 16-bit level; the cap (32768 times white) only touches fireflies.
 * A one-sample render (the centre ray) is no sum and is not rounded, in a
 * pass either.
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "accel/bvh16.h"
#include "base/error.h"
#include "base/meter.h"
#include "render/aov.h"
#include "render/image.h"
#include "render/integrate.h"
#include "render/render.h"
#include "base/clock.h"
#include "math/rng.h"
#include "scene/scene.h"

#define R2_A1 0.7548776662466927 /* 1 / g, g the plastic number */
#define R2_A2 0.5698402909980532 /* 1 / g^2 */

/* A block's colours: 16 vec3 for the integrators, read as 48 doubles for
 * the bytes (a union, so no copy between the two). */
union block_colours {
    vec3 v[16];
    LANES_ALIGN double d[48];
};
_Static_assert(sizeof(vec3) == 3 * sizeof(double), "vec3 is three doubles");

/* The bytes of the 4x4 block of colours c (inactive lanes 0) into its
 * w x h pixels of img at (x, y), row by row (a window image's rows may
 * wrap round inside a block). */
static void put_block(rayd_image *img, int x, int y, const union block_colours *c, int w, int h) {
    uint8_t b[48];
    render_srgb48(c->d, b);
    for (int row = 0; row < h; row++)
        memcpy(image_row(img, y + row) + (size_t)x * 3, b + 12 * row, (size_t)w * 3);
}

static vec3 trace(const rayd_scene *s, const ray *r, const struct rng_key *key, struct meter *mt) {
    return s->rs.integrator == INTEGRATOR_PATH ? path_radiance(s, r, key, mt)
                                               : whitted_radiance(s, r, 0, key, mt);
}

/* The random numbers of pixel (i, j)'s first sample. */
static struct rng_key pixel_key(const rayd_scene *s, int i, int j) {
    return rng_key_at(s->rs.seed, (uint32_t)i, (uint32_t)j, 0);
}

/* What all of pixel (i, j)'s samples share: the key of its random
 * numbers and its offsets in the pixel and on the lens, made once a
 * pixel, not once a sample, where a block draws many samples. */
struct pixel_jitter {
    struct rng_key key;
    double ox, oy, lx, ly;
};

static void pixel_jitter_at(const rayd_scene *s, int i, int j, struct pixel_jitter *pj) {
    pj->key = pixel_key(s, i, j);
    pj->ox = rng_uniform(&pj->key, RNG_CAMERA, 0);
    pj->oy = rng_uniform(&pj->key, RNG_CAMERA, 1);
    pj->lx = rng_uniform(&pj->key, RNG_CAMERA, 2);
    pj->ly = rng_uniform(&pj->key, RNG_CAMERA, 3);
}

/* Pixel (i, j)'s sample k of n from its jitter pj: its ray, and *key set
 * to name it.  No lens position without a lens (cam_ray ignores it). */
static ray jitter_ray(const rayd_scene *s, const struct pixel_jitter *pj, int i, int j, int k,
                      int n, struct rng_key *key) {
    *key = pj->key;
    if (n == 1 && s->cam.aperture <= 0) return cam_ray(&s->cam, i + 0.5, j + 0.5, 0, 0);
    double sx = n == 1 ? 0.5 : pj->ox + k * R2_A1, sy = n == 1 ? 0.5 : pj->oy + k * R2_A2;
    double lu = 0, lv = 0;
    sx -= floor(sx);
    sy -= floor(sy);
    if (s->cam.aperture > 0) {
        lu = pj->lx + k * R2_A1;
        lv = pj->ly + k * R2_A2;
        lu -= floor(lu);
        lv -= floor(lv);
    }
    rng_key_sample(key, (uint32_t)k);
    return cam_ray(&s->cam, i + sx, j + sy, lu, lv);
}

/* Pixel (i, j)'s sample k of n: its ray, and *key set to name it. */
static ray sample_ray(const rayd_scene *s, int i, int j, int k, int n, struct rng_key *key) {
    struct pixel_jitter pj;
    pixel_jitter_at(s, i, j, &pj);
    return jitter_ray(s, &pj, i, j, k, n, key);
}

/* One channel of a sample as a term of an exact sum (see the top). */
static inline double render_sum_channel(double v) {
    if (!(v > 0)) return 0; /* also NaN */
    if (v > RENDER_SUM_CAP) v = RENDER_SUM_CAP;
    return nearbyint(v * RENDER_SUM_SCALE) * (1.0 / RENDER_SUM_SCALE);
}

static inline vec3 render_sum_term(vec3 c) {
    return v3(render_sum_channel(c.x), render_sum_channel(c.y), render_sum_channel(c.z));
}

/* The squared luminance of a sample's term, as a term of an exact sum:
 * the denoiser's second moment (denoise.c).  Capped like the radiance, so
 * a pixel brighter than sqrt(RENDER_SUM_CAP) (181 times white) counts as
 * that bright in the variance alone. */
static inline double render_lum2_term(vec3 t) {
    double l = 0.2126 * t.x + 0.7152 * t.y + 0.0722 * t.z;
    return render_sum_channel(l * l);
}

vec3 render_pixel(const rayd_scene *s, int i, int j, uint64_t *rays) {
    int n = s->rs.samples;
    vec3 acc = v3(0, 0, 0);
    struct meter mt = meter_make(NULL, NULL);
    for (int k = 0; k < n; k++) {
        struct rng_key key;
        ray r = sample_ray(s, i, j, k, n, &key);
        vec3 c = trace(s, &r, &key, &mt);
        acc = n > 1 ? v3_add(acc, render_sum_term(c)) : c;
    }
    *rays += mt.rays;
    return v3_scale(acc, 1.0 / n);
}

/* Sample k of n of the block at (x, y) whose lanes are active: the
 * radiance of each lane into c->v.  centre, when not NULL, holds the
 * block's rays through the pixel centres (the one sample of a pinhole
 * camera); else each lane's ray is sample_ray's. */
static void block_sample(const rayd_scene *s, int x, int y, uint32_t active,
                         const struct ray16 *centre, const struct pixel_jitter jit[16], int k,
                         int n, union block_colours *c, struct meter *mt) {
    struct ray16 rs; /* the sample rays, when not through the centres: set below */
    // cppcheck-suppress uninitvar
    const struct ray16 *r = centre ? centre : &rs;
    struct rng_key key[16];
    for (int q = 0; centre && q < 16; q++) key[q] = pixel_key(s, x + q % 4, y + q / 4);
    for (uint32_t m = centre ? 0 : active; m; m &= m - 1) {
        int q = __builtin_ctz(m);
        ray16_set(&rs, q, jitter_ray(s, &jit[q], x + q % 4, y + q / 4, k, n, &key[q]));
    }
    if (s->rs.integrator == INTEGRATOR_WHITTED) {
        whitted_radiance16(s, r, active, key, c->v, mt);
        return;
    } /* the path tracer: the camera rays as a packet, the paths on one by one */
    struct hit first[16];
    uint32_t hit = scene_intersect16_soa(s, r, scene_unbounded16, active, first, NULL);
    for (uint32_t m = active; m; m &= m - 1) {
        int q = __builtin_ctz(m);
        ray rq = ray16_get(r, q);
        c->v[q] = path_radiance_from(s, &rq, &first[q], hit >> q & 1, &key[q], mt);
    }
}

/* Where the blocks of a rectangle go: its bytes into img at (dx, dy), or,
 * for a pass, the radiance of samples k0..k1-1 added to sum (3 doubles a
 * pixel, rows sum_w pixels long) at (dx, dy).  n is the plain render's
 * sample count, or for a pass 1 (the centre sample) or 0 (any other). */
struct rect_out {
    rayd_image *img;
    double *sum;
    double *aov; /* NULL, or AOV_SUMS doubles a pixel beside sum (render/aov.h) */
    size_t sum_w;
    int dx, dy, k0, k1, n;
};

/* The block's running sums from the pass's buffer (lanes in the block). */
static void sums_load(const struct rect_out *o, int bx, int by, uint32_t active, vec3 acc[16]) {
    for (uint32_t m = active; m; m &= m - 1) {
        int q = __builtin_ctz(m);
        const double *p = o->sum + ((size_t)(by + q / 4) * o->sum_w + (size_t)(bx + q % 4)) * 3;
        acc[q] = v3(p[0], p[1], p[2]);
    }
}

static void sums_store(const struct rect_out *o, int bx, int by, uint32_t active,
                       const vec3 acc[16]) {
    for (uint32_t m = active; m; m &= m - 1) {
        int q = __builtin_ctz(m);
        double *p = o->sum + ((size_t)(by + q / 4) * o->sum_w + (size_t)(bx + q % 4)) * 3;
        p[0] = acc[q].x;
        p[1] = acc[q].y;
        p[2] = acc[q].z;
    }
}

/* The AOV sums of the block's lanes from o->aov (load) or back (!load). */
static void aov_move(const struct rect_out *o, int bx, int by, uint32_t active,
                     double acc[16][AOV_SUMS], bool load) {
    for (uint32_t m = active; m; m &= m - 1) {
        int q = __builtin_ctz(m);
        double *p = o->aov + ((size_t)(by + q / 4) * o->sum_w + (size_t)(bx + q % 4)) * AOV_SUMS;
        if (load)
            memcpy(acc[q], p, sizeof acc[q]);
        else
            memcpy(p, acc[q], sizeof acc[q]);
    }
}

/* Sample k of n of the block's active lanes: their AOV terms added to
 * acc, the rays made as block_sample makes them and met as a packet
 * (which gives each ray its one-ray hit). */
static void aov_block(const rayd_scene *s, int x, int y, uint32_t active,
                      const struct ray16 *centre, const struct pixel_jitter jit[16], int k, int n,
                      double acc[16][AOV_SUMS]) {
    struct ray16 rs;
    // cppcheck-suppress uninitvar
    const struct ray16 *r = centre ? centre : &rs;
    for (uint32_t m = centre ? 0 : active; m; m &= m - 1) {
        int q = __builtin_ctz(m);
        struct rng_key key;
        ray16_set(&rs, q, jitter_ray(s, &jit[q], x + q % 4, y + q / 4, k, n, &key));
    }
    struct hit first[16];
    uint32_t hit = scene_intersect16_soa(s, r, scene_unbounded16, active, first, NULL);
    for (uint32_t m = hit & active; m; m &= m - 1) {
        int q = __builtin_ctz(m);
        ray rq = ray16_get(r, q);
        aov_sample_hit(s, &rq, &first[q], k == 0, acc[q]);
    }
}

/* The w x h (at most 4 x 4) block at (x, y), going to o at (bx, by) past
 * o's (dx, dy): each sample's 16 camera rays traced as packets, the same
 * radiance per pixel as render_pixel, summed in the same order (sample
 * index order, from 0 or from the pass's running sums).  The meter is
 * polled before every sample; stopped, the block is left unwritten. */
static void render_block(const rayd_scene *s, int x, int y, int w, int h,
                         const struct ray16 *centre, const struct rect_out *o, int bx, int by,
                         struct meter *mt) {
    int n = o->n;
    bool sum = o->sum || n > 1;
    vec3 acc[16];
    double aov[16][AOV_SUMS];
    union block_colours c; /* the lanes outside the block stay 0 */
    uint32_t active = ((1u << w) - 1) * (0x1111u & ((1u << 4 * h) - 1)); /* w lanes of h rows */
    if (active != 0xffff) memset(&c, 0, sizeof c);
    if (o->sum)
        sums_load(o, o->dx + bx, o->dy + by, active, acc);
    else if (n > 1)
        memset(acc, 0, sizeof acc);
    if (o->aov) aov_move(o, o->dx + bx, o->dy + by, active, aov, true);
    struct pixel_jitter jit[16]; /* the lanes' jitter, when not through the centres */
    for (uint32_t m = centre ? 0 : active; m; m &= m - 1) {
        int q = __builtin_ctz(m);
        pixel_jitter_at(s, x + q % 4, y + q / 4, &jit[q]);
    }
    for (int k = o->k0; k < o->k1; k++) {
        if (!meter_poll(mt)) return;
        block_sample(s, x, y, active, centre, jit, k, n, &c, mt);
        if (o->aov) aov_block(s, x, y, active, centre, jit, k, n, aov);
        for (uint32_t m = sum ? active : 0; m; m &= m - 1) {
            int q = __builtin_ctz(m);
            vec3 t = n == 1 ? c.v[q] : render_sum_term(c.v[q]); /* centre: as is */
            acc[q] = v3_add(acc[q], t);
            if (o->aov) aov[q][AOV_LUM2] += render_lum2_term(t);
        }
    }
    if (!meter_going(mt)) return; /* stopped inside the last sample */
    if (o->sum) {
        sums_store(o, o->dx + bx, o->dy + by, active, acc);
        if (o->aov) aov_move(o, o->dx + bx, o->dy + by, active, aov, false);
        return;
    }
    for (uint32_t m = n > 1 ? active : 0; m; m &= m - 1) { /* one sample: c, as (0 + c) / 1 */
        int q = __builtin_ctz(m);
        c.v[q] = v3_scale(acc[q], 1.0 / n);
    }
    put_block(o->img, o->dx + bx, o->dy + by, &c, w, h);
}

/* Renders the w x h rectangle at (x, y) of the image into dst at (dx, dy)
 * by 4 x 4 blocks of packets, counting on mt, which is bound to the thread
 * meanwhile (the scene's queries look at it).  A stopped meter ends it
 * with its status.  With a pinhole camera and one sample, the next
 * block's camera rays are made before the block is traced: nothing waits
 * for them, so their square roots and divisions run while the block's
 * work does. */
static enum rayd_status render_rect(const rayd_scene *s, int x, int y, int w, int h,
                                    const struct rect_out *o, int bx, int by, struct meter *mt) {
    bool centres = o->n == 1 && s->cam.aperture <= 0 && !s->cam.ortho;
    struct ray16 ahead[2];
    int now = 0;
    if (centres) cam_block_rays(&s->cam, x, y, &ahead[0]);
    meter_bind(mt);
    for (int row = 0; row < h && meter_going(mt); row += 4) {
        for (int col = 0; col < w && meter_going(mt); col += 4) {
            int bw = w - col < 4 ? w - col : 4, bh = h - row < 4 ? h - row : 4;
            int ncol = col + 4 < w ? col + 4 : 0, nrow = col + 4 < w ? row : row + 4;
            if (centres && nrow < h) cam_block_rays(&s->cam, x + ncol, y + nrow, &ahead[!now]);
            render_block(s, x + col, y + row, bw, bh, centres ? &ahead[now] : NULL, o, bx + col,
                         by + row, mt);
            now = !now;
        }
    }
    meter_bind(NULL);
    return mt->stop;
}

/* The error of a render its meter stopped (st: RAYD_E_CANCELED or
 * RAYD_E_LIMIT). */
static enum rayd_status render_stopped(enum rayd_status st, struct rayd_error *err) {
    if (st == RAYD_E_LIMIT)
        return err_set(err, st, NULL, "the render cast more rays than its budget and was stopped");
    return err_set(err, st, NULL, "render canceled");
}

static void region_resolve(const rayd_scene *s, const struct rayd_region *in,
                           struct rayd_region *out) {
    if (!in || (in->w == 0 && in->h == 0)) {
        struct rayd_region all = {0, 0, s->rs.width, s->rs.height};
        *out = all;
    } else {
        *out = *in;
    }
}

enum rayd_status rayd_region_check(const rayd_scene *s, const struct rayd_region *region,
                                   struct rayd_error *err) {
    struct rayd_region r;
    region_resolve(s, region, &r);
    int W = s->rs.width, H = s->rs.height;
    if (r.x < 0 || r.x >= W)
        return err_set(err, RAYD_E_ARG, "x", "must be in 0..%d (the image is %d wide)", W - 1, W);
    if (r.y < 0 || r.y >= H)
        return err_set(err, RAYD_E_ARG, "y", "must be in 0..%d (the image is %d high)", H - 1, H);
    if (r.w <= 0 || r.w > W - r.x)
        return err_set(err, RAYD_E_ARG, "w", "must be in 1..%d (x + w may not pass the width %d)",
                       W - r.x, W);
    if (r.h <= 0 || r.h > H - r.y)
        return err_set(err, RAYD_E_ARG, "h", "must be in 1..%d (y + h may not pass the height %d)",
                       H - r.y, H);
    return RAYD_OK;
}

enum rayd_status rayd_render_tile(const rayd_scene *s, const struct rayd_render_opts *opts,
                                  rayd_image *dst, int dst_x, int dst_y, struct rayd_error *err) {
    static const struct rayd_render_opts none;
    if (!opts) opts = &none;
    enum rayd_status st = rayd_region_check(s, &opts->region, err);
    if (st != RAYD_OK) return st;
    struct rayd_region r;
    region_resolve(s, &opts->region, &r);
    if (!dst) return err_set(err, RAYD_E_ARG, NULL, "no image to render into");
    if (dst->win) return err_set(err, RAYD_E_ARG, NULL, "a window image is for rayd_render_image");
    if (dst_x < 0 || dst_y < 0 || dst_x > dst->w - r.w || dst_y > dst->h - r.h)
        return err_set(err, RAYD_E_ARG, NULL, "the region does not fit the destination image");
    double t0 = clock_now();
    struct meter mt = meter_make(opts->cancel, opts->rays_left);
    int n = s->rs.samples;
    struct rect_out o = {.img = dst, .dx = dst_x, .dy = dst_y, .k0 = 0, .k1 = n, .n = n};
    st = render_rect(s, r.x, r.y, r.w, r.h, &o, 0, 0, &mt);
    if (st == RAYD_OK && !meter_close(&mt)) st = mt.stop;
    if (opts->stats) {
        opts->stats->rays = mt.rays;
        opts->stats->seconds = clock_now() - t0;
    }
    return st == RAYD_OK ? st : render_stopped(st, err);
}

enum rayd_status rayd_render_into(const rayd_scene *s, const struct rayd_region *region,
                                  rayd_image *dst, int dst_x, int dst_y, const atomic_int *cancel,
                                  uint64_t *rays, struct rayd_error *err) {
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts o = {.cancel = cancel, .stats = &stats};
    if (region) o.region = *region;
    enum rayd_status st = rayd_render_tile(s, &o, dst, dst_x, dst_y, err);
    if (rays) *rays += stats.rays;
    return st;
}

struct tile_job {
    const rayd_scene *s;
    struct rayd_region r;
    const struct rayd_render_opts *opts;
    const struct rect_out *out;
    int tile, tiles_x, ntiles;
    atomic_int next;
    atomic_long done;
    atomic_int stop; /* the first status that stopped a thread, RAYD_OK while none */
    atomic_uint_least64_t rays;
    rayd_rows *rows; /* for opts->rows: which rows at the top are all drawn */
};

/* A tile of tile row ty is drawn: when that completes rows at the top,
 * opts->rows is told how many pixel rows are all drawn. */
static void rows_note(struct tile_job *jb, int ty) {
    int rows = rayd_rows_tile_done(jb->rows, ty);
    if (rows > 0) jb->opts->rows(jb->opts->rows_user, rows);
}

/* Tells the other threads to take no more tiles: the first status stands. */
static void tile_job_stop(struct tile_job *jb, enum rayd_status st) {
    int none = RAYD_OK;
    atomic_compare_exchange_strong(&jb->stop, &none, (int)st);
    if (jb->out->img) image_rows_give_up(jb->out->img); /* no rows will come */
}

static void *render_worker(void *arg) {
    struct tile_job *jb = arg;
    struct meter mt = meter_make(jb->opts->cancel, jb->opts->rays_left);
    for (;;) {
        int t = atomic_fetch_add(&jb->next, 1);
        if (t >= jb->ntiles || atomic_load(&jb->stop) != RAYD_OK) break;
        int tx = (t % jb->tiles_x) * jb->tile, ty = (t / jb->tiles_x) * jb->tile;
        int w = jb->r.w - tx < jb->tile ? jb->r.w - tx : jb->tile;
        int h = jb->r.h - ty < jb->tile ? jb->r.h - ty : jb->tile;
        if (jb->out->img && !image_rows_wait(jb->out->img, ty + h)) break; /* given up */
        enum rayd_status st =
            render_rect(jb->s, jb->r.x + tx, jb->r.y + ty, w, h, jb->out, tx, ty, &mt);
        if (st != RAYD_OK) {
            tile_job_stop(jb, st);
            break;
        }
        if (jb->rows) rows_note(jb, t / jb->tiles_x);
        long done = atomic_fetch_add(&jb->done, (long)w * h) + (long)w * h;
        if (jb->opts->progress)
            jb->opts->progress(jb->opts->progress_user, done, (long)jb->r.w * jb->r.h);
    }
    if (!meter_close(&mt) && atomic_load(&jb->stop) == RAYD_OK) tile_job_stop(jb, mt.stop);
    atomic_fetch_add(&jb->rays, mt.rays);
    return NULL;
}

/* Renders region r (checked) to out in tiles on opts->threads threads;
 * fills opts->stats. */
static enum rayd_status render_tiles(const rayd_scene *s, const struct rayd_render_opts *opts,
                                     const struct rayd_region *r, const struct rect_out *out,
                                     struct rayd_error *err) {
    double t0 = clock_now();
    struct tile_job jb = {.s = s, .r = *r, .opts = opts, .out = out};
    jb.tile = opts->tile > 0 ? opts->tile : 32;
    int side = jb.r.w > jb.r.h ? jb.r.w : jb.r.h;
    if (jb.tile > side) jb.tile = side; /* the same one tile, and no overflow below */
    jb.tiles_x = (jb.r.w + jb.tile - 1) / jb.tile;
    jb.ntiles = jb.tiles_x * ((jb.r.h + jb.tile - 1) / jb.tile);
    atomic_init(&jb.next, 0);
    atomic_init(&jb.done, 0);
    atomic_init(&jb.stop, RAYD_OK);
    atomic_init(&jb.rays, 0);
    if (opts->rows && !out->sum) {
        int tiles_y = (jb.r.h + jb.tile - 1) / jb.tile;
        jb.rows = rayd_rows_new(jb.tiles_x, tiles_y, jb.tile, jb.r.h);
        if (!jb.rows) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for a render");
    }
    int nthreads = opts->threads > 1 ? opts->threads : 1;
    if (nthreads > jb.ntiles) nthreads = jb.ntiles;
    /* a window image's rows in flight: the threads' tiles, over as many
     * rows of tiles as they may span, and the row a thread waits to draw;
     * with no rows callback nothing is released, so the whole frame */
    size_t ahead = opts->rows ? (size_t)jb.tile * (size_t)(2 + nthreads / jb.tiles_x) : SIZE_MAX;
    enum rayd_status st = out->img ? image_window_open(out->img, ahead, err) : RAYD_OK;
    if (st != RAYD_OK) {
        rayd_rows_free(jb.rows);
        return st;
    }

    pthread_t *th = nthreads > 1 ? calloc((size_t)nthreads - 1, sizeof *th) : NULL;
    int started = 0;
    for (int i = 0; th && i < nthreads - 1; i++, started++)
        if (pthread_create(&th[i], NULL, render_worker, &jb) != 0) break;
    render_worker(&jb); /* the calling thread works too */
    for (int i = 0; i < started; i++) pthread_join(th[i], NULL);
    free(th);
    rayd_rows_free(jb.rows);

    if (opts->stats) {
        opts->stats->rays = atomic_load(&jb.rays);
        opts->stats->seconds = clock_now() - t0;
    }
    enum rayd_status stop = (enum rayd_status)atomic_load(&jb.stop);
    return stop == RAYD_OK ? RAYD_OK : render_stopped(stop, err);
}

/* *opts, or no options when NULL, and its region checked and resolved. */
static enum rayd_status opts_region(const rayd_scene *s, const struct rayd_render_opts **opts,
                                    struct rayd_region *r, struct rayd_error *err) {
    static const struct rayd_render_opts none;
    if (!*opts) *opts = &none;
    enum rayd_status st = rayd_region_check(s, &(*opts)->region, err);
    if (st == RAYD_OK) region_resolve(s, &(*opts)->region, r);
    return st;
}

enum rayd_status rayd_render_image(const rayd_scene *s, const struct rayd_render_opts *opts,
                                   rayd_image *dst, struct rayd_error *err) {
    struct rayd_region r;
    enum rayd_status st = opts_region(s, &opts, &r, err);
    if (st != RAYD_OK) return st;
    if (!dst) return err_set(err, RAYD_E_ARG, NULL, "no image to render into");
    if (dst->w != r.w || dst->h != r.h)
        return err_set(err, RAYD_E_ARG, NULL, "the image is %dx%d, the region %dx%d", dst->w,
                       dst->h, r.w, r.h);
    int n = s->rs.samples;
    struct rect_out o = {.img = dst, .k0 = 0, .k1 = n, .n = n};
    return render_tiles(s, opts, &r, &o, err);
}

enum rayd_status rayd_render(const rayd_scene *s, const struct rayd_render_opts *opts,
                             rayd_image **out, struct rayd_error *err) {
    struct rayd_region r;
    enum rayd_status st = opts_region(s, &opts, &r, err);
    if (st != RAYD_OK) return st;
    rayd_image *img = NULL;
    st = rayd_image_new(r.w, r.h, &img, err);
    if (st == RAYD_OK) st = rayd_render_image(s, opts, img, err);
    if (st != RAYD_OK) {
        rayd_image_free(img);
        return st;
    }
    *out = img;
    return RAYD_OK;
}

enum rayd_status render_sums(const rayd_scene *s, const struct rayd_render_opts *opts,
                             const struct rayd_region *r, double *sum, double *aov, int k0, int k1,
                             int n, struct rayd_error *err) {
    struct rect_out o = {.sum = sum, .aov = aov, .sum_w = (size_t)r->w, .k0 = k0, .k1 = k1, .n = n};
    return render_tiles(s, opts, r, &o, err);
}
