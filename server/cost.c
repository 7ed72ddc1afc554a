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
 * Seconds come from this node's own rate: each finished tile reports its
 * estimated rays and the seconds it took, and an average weighted toward
 * the latest tiles (COST_RATE_WEIGHT) turns estimated rays into worker
 * seconds.  The rate follows the machine (a loaded or slow node answers
 * with longer estimates) and absorbs the estimate's usual bias.  It is used
 * for what is reported (the job's estimated seconds, X-Rayd-Estimated-
 * Seconds), the backlog (/readyz, /metrics, Retry-After), and one refusal:
 * a plain render estimated far past --max-render-seconds (api_cost.c, with
 * a fourfold slack), which may then differ between a fast and a slow node.
 * An operator who wants the same answer on every node sets --max-work, in
 * rays.
 *
 * Tiles are sized by cost: the largest of 64, 32, 16 and 8 pixels square
 * whose estimated rays stay under COST_TILE_RAYS, about 100 ms of one
 * worker on the slowest example scene on a 2-core machine of 2026.  A tile
 * is the unit of scheduling, so a small request waits for at most one tile
 * of anything else; a 64-pixel tile of 1024 path-traced samples would hold
 * a worker for seconds.  The size depends on the scene alone, never on the
 * measured rate, so the tiling (and the tile events a client sees) is the
 * same everywhere; the pixels are the same under any tiling anyway.
 *
 * Every function but cost_rays and cost_tile runs with work_lock held.
 */
#include "work_private.h"

#define COST_TILE_MAX 64
#define COST_TILE_MIN 8
#define COST_TILE_RAYS (1024.0 * 1024.0) /* estimated rays a tile may hold */
#define COST_RATE_START 1e7   /* estimated rays a worker casts a second, before any tile */
#define COST_RATE_WEIGHT 0.05 /* of the latest tile in the running average */

static double cost_spr = 1.0 / COST_RATE_START; /* worker seconds per estimated ray */
static int cost_workers = 1;

int cost_samples(const struct work_target *what, int scene_samples)
{
    return what->format == WORK_SUMS ? what->k1 - what->k0 : scene_samples;
}

double cost_rays(const rayd_scene *scene, const struct work_target *what)
{
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    double samples = cost_samples(what, info.samples);
    return (double)what->reg.w * what->reg.h * samples * info.rays_per_sample;
}

int cost_tile(double rays_per_pixel)
{
    int side = COST_TILE_MAX;
    while (side > COST_TILE_MIN && (double)side * side * rays_per_pixel > COST_TILE_RAYS)
        side /= 2;
    return side;
}

void cost_set_workers(int workers) { cost_workers = workers > 0 ? workers : 1; }

void cost_observe(double rays, double seconds)
{
    if (rays <= 0 || !(seconds > 0))
        return;
    cost_spr += COST_RATE_WEIGHT * (seconds / rays - cost_spr);
}

double cost_seconds(double rays) { return rays * cost_spr / cost_workers; }

double cost_rate(void) { return 1.0 / cost_spr; }
