/* test_shapes.c -- plane (paper (7)-(8)) and sphere intersection. */
#include "check.h"
#include "geom/shape.h"

static struct object plane(vec3 q, vec3 n) {
    struct object o = {.kind = SHAPE_PLANE};
    o.u.plane.point = q;
    o.u.plane.normal = v3_norm(n);
    return o;
}

static struct object sphere(vec3 c, double r) {
    struct object o = {.kind = SHAPE_SPHERE};
    o.u.sphere.center = c;
    o.u.sphere.radius = r;
    return o;
}

static ray mkray(vec3 o, vec3 d) {
    ray r = {o, v3_norm(d)};
    return r;
}

static void test_plane_hit_formula(void) {
    struct object p = plane(v3(0, -2, 0), v3(0, 1, 0));
    ray r = mkray(v3(1, 3, 2), v3(0.3, -1, 0.2));
    double t = 0;
    CHECK(plane_hit(&p, &r, 0, INFINITY, &t), "hit");
    /* t = n.(Q - O) / (n.d) */
    double expect =
        v3_dot(p.u.plane.normal, v3_sub(p.u.plane.point, r.o)) / v3_dot(p.u.plane.normal, r.d);
    CHECK_NEAR(t, expect, 1e-12);
    CHECK_NEAR(ray_at(&r, t).y, -2, 1e-12);
}

static void test_plane_parallel_ray_misses(void) {
    struct object p = plane(v3(0, 0, 0), v3(0, 1, 0));
    ray r = mkray(v3(0, 1, 0), v3(1, 0, 0.5));
    double t;
    CHECK(!plane_hit(&p, &r, 0, INFINITY, &t), "parallel above");
    ray in = mkray(v3(0, 0, 0), v3(1, 0, 0));
    CHECK(!plane_hit(&p, &in, 0, INFINITY, &t), "parallel in the plane");
}

static void test_plane_behind_camera_misses(void) {
    struct object p = plane(v3(0, 0, 5), v3(0, 0, 1));
    ray r = mkray(v3(0, 0, 0), v3(0, 0.1, -1));
    double t;
    CHECK(!plane_hit(&p, &r, 0, INFINITY, &t), "t < 0");
}

static void test_plane_from_either_side(void) {
    struct object p = plane(v3(0, 0, 0), v3(0, 1, 0));
    double t1 = 0, t2 = 0;
    ray above = mkray(v3(0, 2, 0), v3(0, -1, 0));
    ray below = mkray(v3(0, -3, 0), v3(0, 1, 0));
    CHECK(plane_hit(&p, &above, 0, INFINITY, &t1), "from above");
    CHECK(plane_hit(&p, &below, 0, INFINITY, &t2), "from below");
    CHECK_NEAR(t1, 2, 1e-12);
    CHECK_NEAR(t2, 3, 1e-12);
}

static void test_sphere_hit_and_miss(void) {
    struct object s = sphere(v3(0, 0, -5), 1);
    double t = 0;
    ray r = mkray(v3(0, 0, 0), v3(0, 0, -1));
    CHECK(sphere_hit(&s, &r, 0, INFINITY, &t), "hit");
    CHECK_NEAR(t, 4, 1e-12);
    vec3 n = sphere_normal(&s, ray_at(&r, t));
    CHECK_NEAR(n.z, 1, 1e-12);
    ray miss = mkray(v3(0, 1.001, 0), v3(0, 0, -1));
    CHECK(!sphere_hit(&s, &miss, 0, INFINITY, &t), "miss just above");
    ray away = mkray(v3(0, 0, 0), v3(0, 0, 1));
    CHECK(!sphere_hit(&s, &away, 0, INFINITY, &t), "looking away");
}

static void test_sphere_tangent(void) {
    struct object s = sphere(v3(0, 1, -5), 1);
    double t = 0;
    ray r = mkray(v3(-3, 0, -5), v3(1, 0, 0)); /* grazes the bottom at (0, 0, -5) */
    CHECK(sphere_hit(&s, &r, 0, INFINITY, &t), "tangent counts as a hit");
    CHECK_NEAR(t, 3, 1e-6);
}

static void test_sphere_ray_from_inside(void) {
    struct object s = sphere(v3(1, 1, 1), 2);
    double t = 0;
    ray r = mkray(v3(1, 1, 1), v3(0, 0, 1));
    CHECK(sphere_hit(&s, &r, 0, INFINITY, &t), "exit hit");
    CHECK_NEAR(t, 2, 1e-12);
    ray off = mkray(v3(1.5, 1, 1), v3(-1, 0, 0));
    CHECK(sphere_hit(&s, &off, 0, INFINITY, &t), "off-centre exit");
    CHECK_NEAR(t, 2.5, 1e-12);
}

static void test_sphere_both_roots_behind(void) {
    struct object s = sphere(v3(0, 0, 5), 1);
    double t;
    ray r = mkray(v3(0, 0, 0), v3(0, 0, -1));
    CHECK(!sphere_hit(&s, &r, 0, INFINITY, &t), "sphere behind the origin");
}

static void test_sphere_far_and_small(void) {
    /* A small sphere very far away: the naive b^2 - c discriminant loses it. */
    struct object s = sphere(v3(0, 0, -1e7), 0.5);
    double t = 0;
    ray r = mkray(v3(0.3, 0, 0), v3(0, 0, -1));
    CHECK(sphere_hit(&s, &r, 0, INFINITY, &t), "hit far away");
    CHECK_NEAR(t, 1e7 - sqrt(0.25 - 0.09), 1e-6);
    /* A huge sphere seen from near its surface. */
    struct object big = sphere(v3(0, -1e6, 0), 1e6 - 1);
    ray down = mkray(v3(0, 0, 0), v3(0, -1, 0));
    CHECK(sphere_hit(&big, &down, 0, INFINITY, &t), "huge sphere");
    CHECK_NEAR(t, 1, 1e-6);
}

static void test_tmax_bounds_hits(void) {
    struct object s = sphere(v3(0, 0, -5), 1);
    double t;
    ray r = mkray(v3(0, 0, 0), v3(0, 0, -1));
    CHECK(!sphere_hit(&s, &r, 0, 3.9, &t), "hit beyond tmax ignored");
    CHECK(sphere_hit(&s, &r, 4.5, INFINITY, &t) && fabs(t - 6) < 1e-12, "far root past tmin");
}

int main(void) {
    RUN(test_plane_hit_formula);
    RUN(test_plane_parallel_ray_misses);
    RUN(test_plane_behind_camera_misses);
    RUN(test_plane_from_either_side);
    RUN(test_sphere_hit_and_miss);
    RUN(test_sphere_tangent);
    RUN(test_sphere_ray_from_inside);
    RUN(test_sphere_both_roots_behind);
    RUN(test_sphere_far_and_small);
    RUN(test_tmax_bounds_hits);
    CHECK_EXIT();
}
