/* cost.c -- what a render will cost, known before it starts, and how much
 * work the queue holds in seconds.
 *
 * A render server that admits work blind can be handed hours of it by one
 * request, and then has no way to tell a balancer it is full.  So every
 * render is priced at admission, in rays: pixels x samples x the rays one
 * camera sample is expected to cast, which the core estimates from the
 * scene's description (rayd_scene_info's rays_per_sample,
 * core/scene/scene_cost.c).  Rays, not seconds, are what --max-work
 * limits: the same request gets the same answer on every node.
 *
 * Seconds come from measured rates, per scene.  Each tile reports its
 * estimated rays and the seconds it took (cost_observe), and they are added
 * to its scene's entry (keyed by the scene's id) and its client's, both
 * decayed sums of seconds and estimated rays whose ratio is the seconds
 * per estimated ray: weighted by rays, so a tile of sky and a tile of glass
 * count by their sizes, and decayed (COST_DECAY a tile) so the rate follows
 * the machine's load.  A scene's price uses its own rate once it has one:
 * the estimate's bias is a property of the scene (a tree of glass bounded
 * at 2^depth overcounts more than a matte wall), and a rate of its own
 * absorbs it.  So one client's scene cannot change another scene's price.
 *
 * A scene not yet seen is priced at the node's rate: the median of the
 * clients' rates, each client one vote however many scenes it sends, with
 * the starting rate filling the votes up to COST_VOTES.  One client's
 * heavy scene (or a thousand of them) moves the median by one vote; it
 * takes most clients at once to move it.  Before the old single moving
 * average, one 1 s render of a heavy 1-pixel scene priced everyone's next
 * render 300,000 times too high, and a few over-priced renders priced a
 * heavy job at 0.05 s.
 *
 * A tile stopped part way (a limit, a DELETE) is added only if it already
 * took longer than its price: then it says the scene costs at least that,
 * which the next request of the scene must pay; a tile cancelled early
 * says nothing.  Both tables are small and bounded (COST_SCENES,
 * COST_CLIENTS), the least recently used entry replaced.
 *
 * The seconds are used for what is reported (the job's estimated seconds,
 * X-Rayd-Estimated-Seconds), the backlog (/readyz, /metrics, Retry-After,
 * each task at its scene's rate), and one refusal: a plain render
 * estimated far past --max-render-seconds (api_cost.c, with a fourfold
 * slack), which may then differ between nodes.  An operator who wants the
 * same answer on every node sets --max-work, in estimated rays.
 *
 * Tiles are sized by cost: the largest of 64, 32, 16 and 8 pixels square
 * whose estimated rays stay under COST_TILE_RAYS, about 100 ms of one
 * worker on the slowest example scene on a 2-core machine.  A tile
 * is the unit of scheduling, so a small request waits for at most one tile
 * of anything else; a 64-pixel tile of 1024 path-traced samples would hold
 * a worker for seconds.  The size depends on the scene alone, never on the
 * measured rate, so the tiling (and the tile events a client sees) is the
 * same everywhere; the pixels are the same under any tiling anyway.
 *
 * Every function but cost_rays, cost_tile, cost_task_tile, cost_worker_count
 * and cost_price_seconds runs with work_lock held.
 */
#include "work/work_private.h"

#include <math.h>
#include <stdlib.h>

#define COST_TILE_MAX 64
#define COST_TILE_MIN 8
#define COST_TILE_RAYS (1024.0 * 1024.0) /* estimated rays a tile may hold */
#define COST_QUICK_S 0.25   /* a quick tile's seconds at its scene's rate (cost_tile_quick) */
#define COST_RATE_START 1e7 /* estimated rays a worker casts a second, before any tile */
#define COST_DECAY 0.9      /* of the sums, per tile added */
#define COST_SCENES 256     /* scenes whose rates are kept */
#define COST_CLIENTS 64     /* clients whose rates vote for the node's */
#define COST_VOTES 3        /* the starting rate fills the votes up to this */

/* A decayed sum of seconds over estimated rays: a rate. */
struct cost_entry {
    uint64_t key; /* 0: free */
    double seconds, rays;
    uint64_t used; /* cost_tick at the last use: the least is replaced */
};

static struct cost_entry cost_scenes[COST_SCENES], cost_clients[COST_CLIENTS];
static uint64_t cost_tick;
static double cost_node_spr = 1.0 / COST_RATE_START; /* worker seconds per estimated ray */
static int cost_workers = 1;

/* The samples a pixel of what takes: a sample range's, else the scene's. */
static int cost_samples(const struct work_target *what, int scene_samples) {
    return what->format == WORK_SUMS ? what->k1 - what->k0 : scene_samples;
}

/* The length the tiles of side `tile` over [at, at + len) cover with the
 * filter's apron on each side, clipped to [0, whole). */
static double cost_apron_span(int at, int len, int tile, int whole) {
    double sum = 0;
    for (int a = at; a < at + len; a += tile) {
        int b = a + tile < at + len ? a + tile : at + len;
        int lo = a - RAYD_DENOISE_APRON > 0 ? a - RAYD_DENOISE_APRON : 0;
        int hi = b + RAYD_DENOISE_APRON < whole ? b + RAYD_DENOISE_APRON : whole;
        sum += hi - lo;
    }
    return sum;
}

/* Sums, in rays a pixel: their 24 bytes a pixel stored tile by tile, then
 * copied into the answer.  An empty 4096x4096 scene's one-sample sums
 * (400 MB) took 3.2-4.0 s of CPU where its PNG took 0.45 s, for the same
 * 16.7M rays: 1.8 rays a pixel more at the starting rate, rounded up.
 * Before, a 74-byte request so priced passed a --max-work of its rays. */
#define COST_SUMS_RAYS 2.0

/* Writing an EXR, in rays a pixel of the region: 0.5 a channel, its RGB
 * and, asked for, its AOVs' RAYD_AOV_FLOATS.  Measured with rayd-render of
 * one sphere at 2048x2048 on one thread: the EXR took 0.25 s more than the
 * PNG, AOVs and all 1.57 s (0.37 us a pixel, 13 channels: 0.28 rays a
 * channel at the starting rate), rounded up -- an 84-byte scene at
 * 4096x4096 with ?aov=all spent 8 s of its 13 in the encode, priced at 0. */
/* A frame-range job's frame in its video, in rays a pixel: ffmpeg's H.264
 * (one thread, veryfast) took 1.6 s of CPU for 24 noisy 1024 x 1024
 * frames, 64 ns a pixel, 0.64 rays at the starting rate; rounded up.  The
 * video is made once every frame is done, whether or not it is fetched. */
#define COST_VIDEO_RAYS 1.0

static double cost_encode_rays(const struct work_target *what) {
    if (what->format == WORK_SUMS) return COST_SUMS_RAYS;
    if (what->format != WORK_EXR && !what->keep_exr) return 0;
    return 0.5 * (3 + (what->aov ? RAYD_AOV_FLOATS : 0));
}

double cost_rays(const rayd_scene *scene, const struct work_target *what) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    double per_pixel = cost_samples(what, info.samples) * info.rays_per_sample;
    double encode = (double)what->reg.w * what->reg.h * cost_encode_rays(what);
    if (what->frame) /* the frame's own parse, before it renders, and its part of the video */
        encode += info.frame_work + (double)what->reg.w * what->reg.h * COST_VIDEO_RAYS;
    if (!what->denoise) return (double)what->reg.w * what->reg.h * per_pixel + encode;
    /* A denoised render: every tile renders its apron too, and the filter
     * runs over tile and apron once a pass (resolve.c, passes.c; a PNG
     * job keeping its EXR resolves both from one run), RAYD_DENOISE_RAYS
     * a pixel: what the filter takes from the task's budget as it runs
     * (rayd_accum_watch).  It took 1.76 us a pixel on one worker
     * (rayd-render --denoise of an empty 2048x2048 scene: 7.4 s of CPU,
     * against 0.08 s without), 18 rays at the starting rate of 10^7 a
     * second, rounded up. */
    int tile = cost_task_tile(scene, what);
    double pixels = cost_apron_span(what->reg.x, what->reg.w, tile, info.width) *
                    cost_apron_span(what->reg.y, what->reg.h, tile, info.height);
    return pixels * (per_pixel + RAYD_DENOISE_RAYS * (what->passes > 1 ? what->passes : 1)) +
           encode;
}

/* The side of a square tile whose estimated rays stay under the tile
 * budget, given a pixel's estimated rays. */
static int cost_tile(double rays_per_pixel) {
    int side = COST_TILE_MAX;
    while (side > COST_TILE_MIN && (double)side * side * rays_per_pixel > COST_TILE_RAYS) side /= 2;
    return side;
}

/* A denoised task's least tile edge: a tile renders the filter's apron
 * (RAYD_DENOISE_APRON, 68 pixels) around it, which costs 2.3x the tile's own
 * pixels at 256, against 28x at 32. */
#define COST_DENOISE_TILE 256

int cost_task_tile(const rayd_scene *scene, const struct work_target *what) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    int side = cost_tile(cost_samples(what, info.samples) * info.rays_per_sample);
    return what->denoise && side < COST_DENOISE_TILE ? COST_DENOISE_TILE : side;
}

void cost_set_workers(int workers) { cost_workers = workers > 0 ? workers : 1; }

int cost_worker_count(void) { return cost_workers; }

static uint64_t cost_key(const char *id) {
    uint64_t h = 0xcbf29ce484222325ull;
    for (; *id; id++) h = (h ^ (unsigned char)*id) * 0x100000001b3ull;
    return h ? h : 1;
}

static struct cost_entry *cost_find(struct cost_entry *tab, int n, uint64_t key) {
    for (int i = 0; i < n; i++)
        if (tab[i].key == key) {
            tab[i].used = ++cost_tick;
            return &tab[i];
        }
    return NULL;
}

/* key's entry, made in the least recently used slot if new. */
static struct cost_entry *cost_slot(struct cost_entry *tab, int n, uint64_t key) {
    struct cost_entry *e = cost_find(tab, n, key), *old = &tab[0];
    if (e) return e;
    for (int i = 1; i < n; i++)
        if (tab[i].used < old->used) old = &tab[i];
    *old = (struct cost_entry){key, 0, 0, ++cost_tick};
    return old;
}

static double cost_spr(const struct cost_entry *e) {
    return e && e->rays > 0 && e->seconds > 0 ? e->seconds / e->rays : 0;
}

static void cost_add(struct cost_entry *e, double rays, double seconds) {
    e->seconds = e->seconds * COST_DECAY + seconds;
    e->rays = e->rays * COST_DECAY + rays;
}

static int cost_cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The node's rate: the median of the clients' (see the top). */
static void cost_node_update(void) {
    double v[COST_CLIENTS + COST_VOTES];
    int n = 0;
    for (int i = 0; i < COST_CLIENTS; i++)
        if (cost_spr(&cost_clients[i]) > 0) v[n++] = cost_spr(&cost_clients[i]);
    while (n < COST_VOTES) v[n++] = 1.0 / COST_RATE_START;
    qsort(v, (size_t)n, sizeof *v, cost_cmp);
    cost_node_spr = n % 2 ? v[n / 2] : sqrt(v[n / 2 - 1] * v[n / 2]);
}

void cost_observe(const char *scene_id, uint64_t client, double rays, double seconds,
                  bool complete) {
    work_assert_locked();
    if (!(rays > 0) || !(seconds > 0)) return;
    struct cost_entry *s = cost_find(cost_scenes, COST_SCENES, cost_key(scene_id));
    double priced = rays * (cost_spr(s) > 0 ? cost_spr(s) : cost_node_spr);
    if (!complete && seconds <= priced)
        return; /* cancelled within its price: says nothing of the rate */
    cost_add(s ? s : cost_slot(cost_scenes, COST_SCENES, cost_key(scene_id)), rays, seconds);
    cost_add(cost_slot(cost_clients, COST_CLIENTS, client ? client : 1), rays, seconds);
    cost_node_update();
}

/* Worker seconds per estimated ray for scene_id: its own, or the node's. */
static double cost_scene_spr(const char *scene_id) {
    double spr = cost_spr(cost_find(cost_scenes, COST_SCENES, cost_key(scene_id)));
    return spr > 0 ? spr : cost_node_spr;
}

double cost_seconds(double rays) { return rays * cost_node_spr / cost_workers; }

bool cost_tile_quick(const char *scene_id, double rays) {
    work_assert_locked();
    return rays <= COST_TILE_RAYS && rays * cost_scene_spr(scene_id) <= COST_QUICK_S;
}

double cost_scene_weight(const char *scene_id) { return cost_scene_spr(scene_id) / cost_node_spr; }

double cost_price_seconds(const char *scene_id, double rays) {
    work_lock_take();
    double s = rays * cost_scene_spr(scene_id) / cost_workers;
    work_lock_give();
    return s;
}
