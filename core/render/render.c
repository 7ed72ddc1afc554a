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
 * counter to `threads` pthreads; each thread keeps its own ray count, so the
 * hot loop shares nothing.  A tile is traced in blocks of 4x4 pixels, each
 * sample's 16 camera rays as one packet (scene_packet.c); since a packet
 * gives every ray exactly its one-ray answer, the blocks change nothing
 * in the bytes.  The cancel flag is polled once per row of blocks.
 */
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "accel/bvh16.h"
#include "base/error.h"
#include "render/image.h"
#include "render/integrate.h"
#include "render/render.h"
#include "base/clock.h"
#include "math/rng.h"
#include "scene/scene.h"

#define R2_A1 0.7548776662466927 /* 1 / g, g the plastic number */
#define R2_A2 0.5698402909980532 /* 1 / g^2 */

/* The sRGB byte of a linear value, by the formula. */
static uint8_t srgb8_exact(double c) {
    if (!(c > 0)) return 0; /* also NaN */
    if (c >= 1) return 255;
    double e = c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
    return (uint8_t)(e * 255.0 + 0.5);
}

/* The sRGB byte by table.  srgb_edge[k], the least linear value whose
 * byte is k (k = 1..255), is found once by bisection over the doubles in
 * (0, 1) -- ordered like their bit patterns -- against srgb8_exact.  The
 * doubles from 2^-13 (below it every byte is 0) to 1 are cut into 128
 * slices a binade, a slice being the values that share their top 19 bits
 * (exponent and 7 bits of mantissa).  A slice is narrower than a step
 * between bytes, so it holds at most one edge: its entry packs the byte at
 * its low end (bits 48..55) and the low 45 bits of the edge inside it (or
 * 2^45: none).  A value's byte is then one load and one compare away.  One
 * more slice, for 1 and above, holds 255.  The very same bytes as the
 * formula, without three calls of pow a pixel, and without a branch. */
#define SRGB_BINADES 13
#define SRGB_LOW 45 /* the bits below a slice's */
static uint64_t srgb_slice[SRGB_BINADES * 128 + 1];
static pthread_once_t srgb_once = PTHREAD_ONCE_INIT;

static const int64_t srgb_lo = (int64_t)(1023 - SRGB_BINADES) << 52; /* 2^-13 */
static const int64_t srgb_one = (int64_t)1023 << 52;                 /* 1.0 */

static void srgb_init(void) {
    uint64_t edge[257];
    for (int k = 1; k < 256; k++) {
        double one = 1.0;
        uint64_t lo = 0, hi; /* srgb8_exact(lo) < k <= srgb8_exact(hi) */
        memcpy(&hi, &one, sizeof hi);
        while (hi - lo > 1) {
            uint64_t mid = lo + (hi - lo) / 2;
            double c;
            memcpy(&c, &mid, sizeof c);
            if (srgb8_exact(c) >= k) hi = mid;
            else lo = mid;
        }
        edge[k] = hi;
    }
    edge[256] = UINT64_MAX; /* no byte past 255 */
    const uint64_t none = (uint64_t)1 << SRGB_LOW;
    int k = 0;
    for (int i = 0; i <= SRGB_BINADES * 128; i++) {
        uint64_t start = (uint64_t)srgb_lo + ((uint64_t)i << SRGB_LOW), end = start + none;
        while (edge[k + 1] <= start) k++; /* the byte at the slice's low end */
        bool has = i < SRGB_BINADES * 128 && edge[k + 1] < end;
        uint64_t inside = has ? edge[k + 1] & (none - 1) : none;
        srgb_slice[i] = (uint64_t)k << 48 | inside;
    }
}

/* After srgb_init.  The bits of a double, as a signed integer, order the
 * doubles from -NaN to +NaN; clamped to [2^-13, 1] they find the slice. */
static inline uint8_t srgb8(double c) {
    int64_t bits;
    memcpy(&bits, &c, sizeof bits);
    bits = bits < srgb_lo ? srgb_lo : bits > srgb_one ? srgb_one : bits;
    uint64_t e = srgb_slice[(bits - srgb_lo) >> SRGB_LOW];
    uint64_t low = (uint64_t)bits & (((uint64_t)1 << SRGB_LOW) - 1);
    int k = (int)(e >> 48) + (low >= (e & (((uint64_t)1 << 48) - 1)));
    return c != c ? 0 : (uint8_t)k;
}

#ifdef BVH16
/* srgb8 of the 48 values v[0..48), 8 at a time, the same integer steps
 * (the table read by gathers) into out[0..48). */
BVH16_FN void srgb8_48(const double v[48], uint8_t out[48]) {
    const __m512i lo = _mm512_set1_epi64(srgb_lo), one = _mm512_set1_epi64(srgb_one);
    const __m512i low = _mm512_set1_epi64(((int64_t)1 << SRGB_LOW) - 1);
    const __m512i entry = _mm512_set1_epi64(((int64_t)1 << 48) - 1);
    for (int k = 0; k < 48; k += 8) {
        __m512d c = _mm512_loadu_pd(v + k);
        __m512i bits = _mm512_min_epi64(_mm512_max_epi64(_mm512_castpd_si512(c), lo), one);
        __m512i idx = _mm512_srli_epi64(_mm512_sub_epi64(bits, lo), SRGB_LOW);
        __m512i e = _mm512_i64gather_epi64(idx, (const void *)srgb_slice, 8);
        __mmask8 past = _mm512_cmpge_epu64_mask(_mm512_and_si512(bits, low),
                                                _mm512_and_si512(e, entry));
        __m512i byte = _mm512_mask_add_epi64(_mm512_srli_epi64(e, 48), past,
                                             _mm512_srli_epi64(e, 48), _mm512_set1_epi64(1));
        byte = _mm512_maskz_mov_epi64(_mm512_cmp_pd_mask(c, c, _CMP_ORD_Q), byte); /* NaN: 0 */
        _mm_storel_epi64((__m128i *)(out + k), _mm512_cvtepi64_epi8(byte));
    }
}
#endif

void render_srgb48(const double v[48], uint8_t out[48]) {
    pthread_once(&srgb_once, srgb_init);
#ifdef BVH16
    if (bvh16_available()) {
        srgb8_48(v, out);
        return;
    }
#endif
    for (int k = 0; k < 48; k++) out[k] = srgb8(v[k]);
}

/* A block's colours: 16 vec3 for the integrators, read as 48 doubles for
 * the bytes (a union, so no copy between the two). */
union block_colours {
    vec3 v[16];
    LANES_ALIGN double d[48];
};
_Static_assert(sizeof(vec3) == 3 * sizeof(double), "vec3 is three doubles");

/* The bytes of the 4x4 block of colours c (inactive lanes 0) into its
 * w x h pixels at dst, rows stride bytes apart. */
static void put_block(uint8_t *dst, size_t stride, const union block_colours *c, int w, int h) {
    uint8_t b[48];
#ifdef BVH16
    if (bvh16_available())
        srgb8_48(c->d, b);
    else
#endif
        for (int k = 0; k < 48; k++) /* every lane set: by the integrator or to 0 */
            b[k] = srgb8(c->d[k]);   // NOLINT(clang-analyzer-core.CallAndMessage)
    for (int row = 0; row < h; row++)
        memcpy(dst + (size_t)row * stride, b + 12 * row, (size_t)w * 3);
}

uint8_t render_srgb8(double c) {
    pthread_once(&srgb_once, srgb_init);
    return srgb8(c);
}

static vec3 trace(const rayd_scene *s, const ray *r, const struct rng_key *key, uint64_t *rays) {
    return s->rs.integrator == INTEGRATOR_PATH ? path_radiance(s, r, key, rays)
                                               : whitted_radiance(s, r, 0, key, rays);
}

/* The random numbers of pixel (i, j)'s first sample. */
static struct rng_key pixel_key(const rayd_scene *s, int i, int j) {
    return (struct rng_key){s->rs.seed, (uint32_t)i, (uint32_t)j, 0};
}

/* Pixel (i, j)'s sample k of n: its ray, and *key set to name it. */
static ray sample_ray(const rayd_scene *s, int i, int j, int k, int n, struct rng_key *key) {
    *key = pixel_key(s, i, j);
    if (n == 1 && s->cam.aperture <= 0) return cam_ray(&s->cam, i + 0.5, j + 0.5, 0, 0);
    double ox = rng_uniform(key, RNG_CAMERA, 0), oy = rng_uniform(key, RNG_CAMERA, 1);
    double lx = rng_uniform(key, RNG_CAMERA, 2), ly = rng_uniform(key, RNG_CAMERA, 3);
    double sx = n == 1 ? 0.5 : ox + k * R2_A1, sy = n == 1 ? 0.5 : oy + k * R2_A2;
    double lu = lx + k * R2_A1, lv = ly + k * R2_A2;
    sx -= floor(sx);
    sy -= floor(sy);
    lu -= floor(lu);
    lv -= floor(lv);
    key->sample = (uint32_t)k;
    return cam_ray(&s->cam, i + sx, j + sy, lu, lv);
}

vec3 render_pixel(const rayd_scene *s, int i, int j, uint64_t *rays) {
    int n = s->rs.samples;
    vec3 acc = v3(0, 0, 0);
    for (int k = 0; k < n; k++) {
        struct rng_key key;
        ray r = sample_ray(s, i, j, k, n, &key);
        acc = v3_add(acc, trace(s, &r, &key, rays));
    }
    return v3_scale(acc, 1.0 / n);
}

/* The w x h (at most 4 x 4) block at (x, y): each sample's 16 camera rays
 * traced as packets (whitted_radiance16; for the path tracer the camera
 * rays' hits, scene_intersect16), the same radiance per pixel as
 * render_pixel, summed in the same order.  centre, when not NULL, holds
 * the block's rays through the pixel centres (the one sample of a pinhole
 * camera). */
static void render_block(const rayd_scene *s, int x, int y, int w, int h,
                         const struct ray16 *centre, rayd_image *dst, int dx, int dy,
                         uint64_t *rays) {
    int n = s->rs.samples;
    vec3 acc[16];
    union block_colours c; /* the lanes outside the block stay 0 */
    struct ray16 rs;       /* the sample rays, when not through the centres: set below */
    // cppcheck-suppress uninitvar
    const struct ray16 *r = centre ? centre : &rs;
    struct rng_key key[16];
    uint32_t active = ((1u << w) - 1) * (0x1111u & ((1u << 4 * h) - 1)); /* w lanes of h rows */
    if (active != 0xffff) memset(&c, 0, sizeof c);
    if (n > 1) memset(acc, 0, sizeof acc);
    for (int k = 0; k < n; k++) {
        for (int q = 0; centre && q < 16; q++) key[q] = pixel_key(s, x + q % 4, y + q / 4);
        for (uint32_t m = centre ? 0 : active; m; m &= m - 1) {
            int q = __builtin_ctz(m);
            ray16_set(&rs, q, sample_ray(s, x + q % 4, y + q / 4, k, n, &key[q]));
        }
        if (s->rs.integrator == INTEGRATOR_WHITTED) {
            whitted_radiance16(s, r, active, key, c.v, rays);
        } else { /* the camera rays as a packet, the paths on one by one */
            struct hit first[16];
            uint32_t hit = scene_intersect16_soa(s, r, scene_unbounded16, active, first, NULL);
            for (uint32_t m = active; m; m &= m - 1) {
                int q = __builtin_ctz(m);
                ray rq = ray16_get(r, q);
                c.v[q] = path_radiance_from(s, &rq, &first[q], hit >> q & 1, &key[q], rays);
            }
        }
        for (uint32_t m = active; n > 1 && m; m &= m - 1) {
            int q = __builtin_ctz(m);
            acc[q] = v3_add(acc[q], c.v[q]);
        }
    }
    for (uint32_t m = n > 1 ? active : 0; m; m &= m - 1) { /* one sample: c, as (0 + c) / 1 */
        int q = __builtin_ctz(m);
        c.v[q] = v3_scale(acc[q], 1.0 / n);
    }
    size_t stride = (size_t)dst->w * 3;
    put_block(dst->px + (size_t)dy * stride + (size_t)dx * 3, stride, &c, w, h);
}

/* Renders the w x h rectangle at (x, y) of the image into dst at (dx, dy)
 * by 4 x 4 blocks of packets.  The cancel flag is polled once per row of
 * blocks.  With a pinhole camera and one sample, the next block's camera
 * rays are made before the block is traced: nothing waits for them, so
 * their square roots and divisions run while the block's work does. */
static enum rayd_status render_rect(const rayd_scene *s, int x, int y, int w, int h,
                                    rayd_image *dst, int dx, int dy, const atomic_int *cancel,
                                    uint64_t *rays) {
    pthread_once(&srgb_once, srgb_init);
    bool centres = s->rs.samples == 1 && s->cam.aperture <= 0 && !s->cam.ortho;
    struct ray16 ahead[2];
    int now = 0;
    if (centres) cam_block_rays(&s->cam, x, y, &ahead[0]);
    for (int row = 0; row < h; row += 4) {
        if (cancel && atomic_load_explicit(cancel, memory_order_relaxed)) return RAYD_E_CANCELED;
        for (int col = 0; col < w; col += 4) {
            int bw = w - col < 4 ? w - col : 4, bh = h - row < 4 ? h - row : 4;
            int ncol = col + 4 < w ? col + 4 : 0, nrow = col + 4 < w ? row : row + 4;
            if (centres && nrow < h) cam_block_rays(&s->cam, x + ncol, y + nrow, &ahead[!now]);
            render_block(s, x + col, y + row, bw, bh, centres ? &ahead[now] : NULL, dst, dx + col,
                         dy + row, rays);
            now = !now;
        }
    }
    return RAYD_OK;
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
        return err_set(err, RAYD_E_ARG, "h",
                       "must be in 1..%d (y + h may not pass the height %d)", H - r.y, H);
    return RAYD_OK;
}

enum rayd_status rayd_render_into(const rayd_scene *s, const struct rayd_region *region,
                                  rayd_image *dst, int dst_x, int dst_y, const atomic_int *cancel,
                                  uint64_t *rays, struct rayd_error *err) {
    enum rayd_status st = rayd_region_check(s, region, err);
    if (st != RAYD_OK) return st;
    struct rayd_region r;
    region_resolve(s, region, &r);
    if (dst_x < 0 || dst_y < 0 || dst_x > dst->w - r.w || dst_y > dst->h - r.h)
        return err_set(err, RAYD_E_ARG, NULL, "the region does not fit the destination image");
    uint64_t count = 0;
    st = render_rect(s, r.x, r.y, r.w, r.h, dst, dst_x, dst_y, cancel, &count);
    if (rays) *rays += count;
    if (st == RAYD_E_CANCELED) return err_set(err, st, NULL, "render canceled");
    return st;
}

struct job {
    const rayd_scene *s;
    struct rayd_region r;
    const struct rayd_render_opts *opts;
    rayd_image *img;
    int tile, tiles_x, ntiles;
    atomic_int next;
    atomic_long done;
    atomic_int canceled;
    atomic_uint_least64_t rays;
};

static void *render_worker(void *arg) {
    struct job *jb = arg;
    uint64_t rays = 0;
    for (;;) {
        int t = atomic_fetch_add(&jb->next, 1);
        if (t >= jb->ntiles || atomic_load(&jb->canceled)) break;
        int tx = (t % jb->tiles_x) * jb->tile, ty = (t / jb->tiles_x) * jb->tile;
        int w = jb->r.w - tx < jb->tile ? jb->r.w - tx : jb->tile;
        int h = jb->r.h - ty < jb->tile ? jb->r.h - ty : jb->tile;
        if (render_rect(jb->s, jb->r.x + tx, jb->r.y + ty, w, h, jb->img, tx, ty, jb->opts->cancel,
                        &rays) != RAYD_OK) {
            atomic_store(&jb->canceled, 1);
            break;
        }
        long done = atomic_fetch_add(&jb->done, (long)w * h) + (long)w * h;
        if (jb->opts->progress)
            jb->opts->progress(jb->opts->progress_user, done, (long)jb->r.w * jb->r.h);
    }
    atomic_fetch_add(&jb->rays, rays);
    return NULL;
}

enum rayd_status rayd_render(const rayd_scene *s, const struct rayd_render_opts *opts,
                             rayd_image **out, struct rayd_error *err) {
    static const struct rayd_render_opts none;
    if (!opts) opts = &none;
    double t0 = clock_now();
    enum rayd_status st = rayd_region_check(s, &opts->region, err);
    if (st != RAYD_OK) return st;
    struct job jb = {.s = s, .opts = opts, .tile = opts->tile > 0 ? opts->tile : 32};
    region_resolve(s, &opts->region, &jb.r);
    st = rayd_image_new(jb.r.w, jb.r.h, &jb.img, err);
    if (st != RAYD_OK) return st;
    jb.tiles_x = (jb.r.w + jb.tile - 1) / jb.tile;
    jb.ntiles = jb.tiles_x * ((jb.r.h + jb.tile - 1) / jb.tile);
    atomic_init(&jb.next, 0);
    atomic_init(&jb.done, 0);
    atomic_init(&jb.canceled, 0);
    atomic_init(&jb.rays, 0);

    int nthreads = opts->threads > 1 ? opts->threads : 1;
    if (nthreads > jb.ntiles) nthreads = jb.ntiles;
    pthread_t *th = nthreads > 1 ? calloc((size_t)nthreads - 1, sizeof *th) : NULL;
    int started = 0;
    for (int i = 0; th && i < nthreads - 1; i++, started++)
        if (pthread_create(&th[i], NULL, render_worker, &jb) != 0) break;
    render_worker(&jb); /* the calling thread works too */
    for (int i = 0; i < started; i++) pthread_join(th[i], NULL);
    free(th);

    if (opts->stats) {
        opts->stats->rays = atomic_load(&jb.rays);
        opts->stats->seconds = clock_now() - t0;
    }
    if (atomic_load(&jb.canceled)) {
        rayd_image_free(jb.img);
        return err_set(err, RAYD_E_CANCELED, NULL, "render canceled");
    }
    *out = jb.img;
    return RAYD_OK;
}
