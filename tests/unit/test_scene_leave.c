/* test_scene_leave.c -- the objects a ray leaving them cannot meet again
 * (scene/scene_leave.c): which are marked, and that for rays leaving them
 * as the path tracer casts them the full queries never report them and
 * the queries that pass over them give the same answers, bit for bit. */
#include <stdlib.h>

#include "check.h"
#include "render/integrate.h"
#include "scene/scene.h"
#include "scene_util.h"

/* Every kind the marking decides on, each alone in its spot: a plain and a
 * turned box, a sphere, a disc, a triangle, a quad (flat), a sphere too
 * big for the offset to dominate its rounding, a badly conditioned box, a
 * capped cylinder and a CSG (never marked). */
static const char *scene_json =
    "{\"camera\": {\"position\": [0,0,10], \"look_at\": [0,0,0]},"
    " \"render\": {\"width\": 8, \"height\": 8},"
    " \"objects\": ["
    "  {\"type\": \"box\", \"center\": [-3,0,0], \"size\": [1,1,1]},"
    "  {\"type\": \"box\", \"center\": [-1,3,0], \"size\": [1,2,1], \"transform\":"
    "   {\"rotate\": [10,30,0], \"translate\": [0,0,0.5]}},"
    "  {\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": 0.8},"
    "  {\"type\": \"disc\", \"center\": [3,0,0], \"normal\": [0,1,1], \"radius\": 0.7},"
    "  {\"type\": \"triangle\", \"vertices\": [[-1,-3,0],[1,-3,0.3],[0,-2,-0.2]]},"
    "  {\"type\": \"quad\", \"corner\": [2,2,0], \"edge1\": [1,0,0.2], \"edge2\": [0,1,0]},"
    "  {\"type\": \"sphere\", \"center\": [0,-2e7,0], \"radius\": 1.99999e7},"
    "  {\"type\": \"box\", \"center\": [3,-3,0], \"size\": [1,1,1], \"transform\":"
    "   {\"scale\": [3000,0.1,1]}},"
    "  {\"type\": \"cylinder\", \"base\": [-3,-3,0], \"top\": [-3,-2,0], \"radius\": 0.4},"
    "  {\"type\": \"csg\", \"op\": \"union\", \"operands\": ["
    "   {\"type\": \"sphere\", \"center\": [-3,3,0], \"radius\": 0.5},"
    "   {\"type\": \"sphere\", \"center\": [-3,3.5,0], \"radius\": 0.5}]}]}";

static uint64_t rnd_state = 88172645463325252ull;
static double rnd(void) {
    rnd_state ^= rnd_state << 13;
    rnd_state ^= rnd_state >> 7;
    rnd_state ^= rnd_state << 17;
    return (double)(rnd_state >> 11) / 9007199254740992.0;
}

static vec3 rnd_dir(void) {
    double z = 1 - 2 * rnd(), r = sqrt(fmax(0, 1 - z * z)), phi = 2 * M_PI * rnd();
    return v3(r * cos(phi), r * sin(phi), z);
}

static void test_marks(void) {
    rayd_scene *s = scene_from(scene_json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    int marked[SHAPE_KINDS] = {0}, flat = 0, big = 0;
    for (int32_t i = 0; i < s->nobjs; i++) {
        const struct object *o = &s->objs[i];
        bool m = s->leave[i].scale < INFINITY;
        marked[o->kind] += m;
        flat += m && s->leave[i].flat;
        if (o->kind == SHAPE_SPHERE && o->u.sphere.radius > 1e6)
            big += s->leave[i].scale <= 1e4 * (1 + 1e3); /* skipped even at 1e3 */
    }
    CHECK(marked[SHAPE_BOX] == 2, "boxes marked: %d (not the badly conditioned one)",
          marked[SHAPE_BOX]);
    CHECK(marked[SHAPE_SPHERE] == 2, "spheres marked: %d", marked[SHAPE_SPHERE]);
    CHECK(big == 0, "the huge sphere is skipped near the origin");
    CHECK(marked[SHAPE_DISC] == 1 && marked[SHAPE_TRIANGLE] == 1 && marked[SHAPE_QUAD] == 1,
          "flat kinds marked");
    CHECK(flat == 3, "%d flat", flat);
    CHECK(marked[SHAPE_CYLINDER] == 0 && marked[SHAPE_CSG] == 0, "cylinder, csg not marked");
    rayd_scene_free(s);
}

/* Rays from random points toward each object; from each hit, rays leaving
 * it as integrate_path.c casts them (integrate_offset off the surface, on
 * the side they go): outward only for solids, either side for flat ones. */
static void test_never_met_again(void) {
    rayd_scene *s = scene_from(scene_json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    int tried = 0, self = 0, differ = 0, shadow_differ = 0;
    for (int32_t i = 0; i < s->nobjs; i++) {
        const struct object *o = &s->objs[i];
        struct aabb b;
        if (!scene_object_bounds(s, o, &b)) continue;
        vec3 c = v3_scale(v3_add(b.lo, b.hi), 0.5);
        if (v3_maxabs(c) > 100) continue; /* the huge sphere: its point is far */
        for (int k = 0; k < 400; k++) {
            vec3 from = v3_add(c, v3_scale(rnd_dir(), 2.5));
            vec3 at = v3_add(c, v3_scale(v3(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5), 0.6));
            ray r = {from, v3_norm(v3_sub(at, from))};
            struct hit h;
            if (!scene_intersect(s, &r, INFINITY, &h) || h.leaf != o) continue;
            struct surface sf;
            scene_surface(s, &r, &h, &sf);
            bool inside = v3_dot(sf.ng, r.d) > 0;
            vec3 ng = inside ? v3_neg(sf.ng) : sf.ng;
            double off = integrate_offset(sf.p, sf.float_geom);
            bool out_flat = s->leave[i].flat;
            for (int side = 0; side < 2; side++) {
                /* side 0: back toward the viewer; 1: through (flat only) */
                if (side == 1 && !out_flat) continue;
                vec3 n = side ? v3_neg(ng) : ng;
                if (!out_flat && inside) continue; /* from inside: not outward */
                ray q = {v3_madd(sf.p, n, off), rnd_dir()};
                if (v3_dot(q.d, n) < 0) q.d = v3_neg(q.d);
                if (!(v3_dot(q.d, n) > 0)) continue;
                uint32_t leave =
                    s->leave[i].scale <= 1e4 * (1 + v3_maxabs(sf.p)) ? (uint32_t)i : SCENE_NO_LEAVE;
                struct hit all, from_h;
                bool a = scene_intersect(s, &q, INFINITY, &all);
                bool f = scene_intersect_from(s, &q, INFINITY, leave, &from_h);
                tried++;
                self += a && all.leaf == o;
                differ += a != f || (a && (all.t != from_h.t || all.leaf != from_h.leaf ||
                                           all.part != from_h.part));
                shadow_differ += scene_occluded_from(s, &q, 5, SCENE_NO_LEAVE) !=
                                     scene_occluded_from(s, &q, 5, leave) ||
                                 v3_maxabs(v3_sub(scene_transmittance(s, &q, 5),
                                                  scene_transmittance_from(s, &q, 5, leave))) != 0;
            }
        }
    }
    CHECK(tried > 1000, "only %d rays", tried);
    CHECK(self == 0, "%d rays met the object they leave", self);
    CHECK(differ == 0, "%d nearest hits differ", differ);
    CHECK(shadow_differ == 0, "%d shadow answers differ", shadow_differ);
    rayd_scene_free(s);
}

int main(void) {
    RUN(test_marks);
    RUN(test_never_met_again);
    CHECK_EXIT();
}
