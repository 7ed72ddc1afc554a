/* scene_cost.c -- how many rays a camera sample of a scene will cast, told
 * before any is cast.
 *
 * A render server must know what a request costs before it gives it a
 * worker: to refuse what is over a budget, to size tiles so no tile holds a
 * worker for long, and to tell a balancer how much work is waiting.  The
 * estimate reads only what the frozen scene says -- the integrator, the
 * depth limit, the lights and their samples, the materials -- so it is the
 * same number on every node and every run, and a test can count on it.
 *
 * The model, per camera sample:
 *   Whitted: each shading point casts one shadow ray per point-like light
 *     and `samples` per area light (integrate.c); the camera ray shades one
 *     point, a mirror material one more and glass two (a reflected and a
 *     refracted ray).  Deeper bounces are not counted: on the example
 *     scenes only a small part of the image sees them, and counting
 *     max_depth of them overestimated the rays sevenfold.
 *   Path: each bounce casts a continuation ray, one shadow ray per light,
 *     one toward an emitter and one toward a sampled environment map
 *     (next-event estimation, integrate_path.c);
 *     Russian roulette ends most paths by the fourth or fifth bounce, so at
 *     most PATH_EXPECTED_BOUNCES count.
 * It counts rays, not seconds: the server turns rays into seconds with the
 * rate it measures on its own tiles (server/cost.c).  rayd-render --stats
 * prints it beside the rays really cast; on the example scenes the
 * estimate is 1.2 to 4 times the rays cast (it counts a shadow ray for
 * every light at every pixel, even where the camera sees only the
 * background): an estimate errs high, so a budget never lets through more
 * than it says.
 */
#include "scene/scene.h"

#define PATH_EXPECTED_BOUNCES 5 /* Russian roulette from bounce 3 ends most paths by here */

/* Shadow rays a shading point casts, over all lights. */
static double shadow_rays(const struct rayd_scene *s)
{
    double n = 0;
    for (int i = 0; i < s->nlights; i++)
        n += s->lights[i].kind == LIGHT_AREA ? s->lights[i].samples : 1;
    return n;
}

/* Whitted: shading points per camera sample. */
static double whitted_points(const struct rayd_scene *s)
{
    bool mirror = false, glass = false;
    for (int i = 0; i < s->nmats; i++) {
        mirror |= s->mats[i].reflectivity > 0;
        glass |= s->mats[i].transparency > 0;
    }
    if (s->rs.max_depth <= 0)
        return 1.0;
    return 1.0 + (mirror ? 1.0 : 0.0) + (glass ? 2.0 : 0.0);
}

double scene_rays_per_sample(const struct rayd_scene *s)
{
    if (s->rs.integrator == INTEGRATOR_WHITTED)
        return whitted_points(s) * (1.0 + shadow_rays(s));
    int bounces = s->rs.max_depth < PATH_EXPECTED_BOUNCES ? s->rs.max_depth : PATH_EXPECTED_BOUNCES;
    double nee = s->nlights + (s->nemitters > 0 ? 1 : 0) + (env_can_sample(&s->rs.env) ? 1 : 0);
    return (1.0 + bounces) * (1.0 + nee);
}
