/* test_primitives.c -- the exact primitives: hit, miss, tangent, inside,
 * grazing and numerically hard cases, with analytic normals. */
#include "check.h"
#include "geom/shape.h"

static ray mk(vec3 o, vec3 d) {
    ray r = {o, v3_norm(d)};
    return r;
}

static bool hit(const struct object *o, ray r, double *t, vec3 *n) {
    int part;
    if (!shape_hit(o, &r, 0, INFINITY, t, &part)) return false;
    *n = shape_ops[o->kind]->normal(o, ray_at(&r, *t), part);
    return true;
}

static void test_box(void) {
    struct object b = {.kind = SHAPE_BOX};
    b.u.box.lo = v3(-1, -2, -3);
    b.u.box.hi = v3(1, 2, 3);
    double t;
    vec3 n;
    CHECK(hit(&b, mk(v3(-5, 0, 0), v3(1, 0, 0)), &t, &n) && fabs(t - 4) < 1e-12 && n.x == -1,
          "from -x");
    CHECK(hit(&b, mk(v3(0, 0, 10), v3(0, 0, -1)), &t, &n) && fabs(t - 7) < 1e-12 && n.z == 1,
          "from +z");
    CHECK(!hit(&b, mk(v3(-5, 2.001, 0), v3(1, 0, 0)), &t, &n), "miss above");
    CHECK(hit(&b, mk(v3(0, 0, 0), v3(0, 1, 0)), &t, &n) && fabs(t - 2) < 1e-12 && n.y == 1,
          "from inside");
    CHECK(!hit(&b, mk(v3(0, 0, 5), v3(0, 0, 1)), &t, &n), "pointing away");
    CHECK(hit(&b, mk(v3(-1e7, 0.5, 0.5), v3(1, 0, 0)), &t, &n) && fabs(t - (1e7 - 1)) < 1e-6,
          "far away");
    /* grazing along a face stays consistent: hit or not, never NaN */
    bool g = hit(&b, mk(v3(-5, 2, 0), v3(1, 0, 0)), &t, &n);
    CHECK(!g || isfinite(t), "grazing finite");
    CHECK(shape_ops[SHAPE_BOX]->inside(&b, v3(0.5, 1, -2)) &&
              !shape_ops[SHAPE_BOX]->inside(&b, v3(1.5, 0, 0)),
          "inside");
}

static struct object cyl(double r0, double r1, bool capped) {
    struct object c = {.kind = SHAPE_CYLINDER};
    c.u.cyl.base = v3(0, 0, 0);
    c.u.cyl.axis = v3(0, 1, 0);
    c.u.cyl.height = 2;
    c.u.cyl.r0 = r0;
    c.u.cyl.r1 = r1;
    c.u.cyl.capped = capped;
    return c;
}

static void test_cylinder(void) {
    struct object c = cyl(1, 1, true);
    double t;
    vec3 n;
    CHECK(hit(&c, mk(v3(-5, 1, 0), v3(1, 0, 0)), &t, &n) && fabs(t - 4) < 1e-12 &&
              fabs(n.x + 1) < 1e-12,
          "side");
    CHECK(hit(&c, mk(v3(0.3, 5, 0.2), v3(0, -1, 0)), &t, &n) && fabs(t - 3) < 1e-12 && n.y == 1,
          "top cap");
    CHECK(hit(&c, mk(v3(0.3, -5, 0.2), v3(0, 1, 0)), &t, &n) && fabs(t - 5) < 1e-12 && n.y == -1,
          "base cap");
    CHECK(!hit(&c, mk(v3(-5, 2.5, 0), v3(1, 0, 0)), &t, &n), "above the top");
    CHECK(hit(&c, mk(v3(-5, 1, 1), v3(1, 0, 0)), &t, &n) && fabs(t - 5) < 1e-6,
          "tangent to the side");
    CHECK(hit(&c, mk(v3(0, 1, 0), v3(0, 0, 1)), &t, &n) && fabs(t - 1) < 1e-12 && n.z > 0.999,
          "from inside");
    struct object open = cyl(1, 1, false);
    CHECK(hit(&open, mk(v3(0, 5, 0), v3(0, -1, 0)), &t, &n) == false,
          "open: straight down the axis misses");
    CHECK(hit(&open, mk(v3(0, 1, 0), v3(1, 0, 0)), &t, &n) && fabs(t - 1) < 1e-12,
          "open: the inner wall");
    CHECK(!shape_is_solid(&open) && shape_is_solid(&c), "open is a surface, capped a solid");
    CHECK(hit(&c, mk(v3(-1e7, 1, 0.5), v3(1, 0, 0)), &t, &n) && fabs(t - (1e7 - sqrt(0.75))) < 1e-6,
          "far away");
}

static void test_cone(void) {
    struct object c = cyl(1, 0, true); /* apex at y = 2 */
    double t;
    vec3 n;
    /* the side at height 1 has radius 0.5; the normal leans up by atan(1/2) */
    CHECK(hit(&c, mk(v3(-5, 1, 0), v3(1, 0, 0)), &t, &n) && fabs(t - 4.5) < 1e-12,
          "side at mid height");
    vec3 want = v3_norm(v3(-1, 0.5, 0));
    CHECK(fabs(v3_dot(n, want) - 1) < 1e-12, "cone normal (%g %g %g)", n.x, n.y, n.z);
    CHECK(!hit(&c, mk(v3(-5, 1.9, 0.2), v3(1, 0, 0)), &t, &n), "misses beside the apex");
    CHECK(hit(&c, mk(v3(0, 5, 0), v3(0, -1, 0)), &t, &n) && fabs(t - 3) < 1e-9, "the apex");
    /* the apex's normal points out of the tip, not back into the cone (a
     * ray meeting it there would be taken as leaving a glass cone) */
    CHECK(n.y == 1, "apex normal (%g %g %g) points up, out of the tip", n.x, n.y, n.z);
    struct object d = cyl(0, 1, true); /* apex at the base, y = 0 */
    CHECK(hit(&d, mk(v3(0, -5, 0), v3(0, 1, 0)), &t, &n) && fabs(t - 5) < 1e-9 && n.y == -1,
          "apex at the base: normal (%g %g %g) points down", n.x, n.y, n.z);
    CHECK(hit(&c, mk(v3(0.2, -3, 0), v3(0, 1, 0)), &t, &n) && fabs(t - 3) < 1e-12 && n.y == -1,
          "base cap");
    CHECK(shape_ops[SHAPE_CYLINDER]->inside(&c, v3(0, 1, 0.4)) &&
              !shape_ops[SHAPE_CYLINDER]->inside(&c, v3(0, 1, 0.6)),
          "inside");
}

static void test_disc(void) {
    struct object d = {.kind = SHAPE_DISC};
    d.u.disc.center = v3(0, 1, 0);
    d.u.disc.normal = v3(0, 1, 0);
    d.u.disc.radius = 2;
    d.u.disc.inner = 0.5;
    double t;
    vec3 n;
    CHECK(hit(&d, mk(v3(1, 5, 0), v3(0, -1, 0)), &t, &n) && fabs(t - 4) < 1e-12 && n.y == 1,
          "ring");
    CHECK(!hit(&d, mk(v3(0.2, 5, 0), v3(0, -1, 0)), &t, &n), "hole");
    CHECK(!hit(&d, mk(v3(2.1, 5, 0), v3(0, -1, 0)), &t, &n), "outside");
    CHECK(!hit(&d, mk(v3(-5, 1, 1), v3(1, 0, 0)), &t, &n), "edge-on");
    CHECK(hit(&d, mk(v3(1, -5, 0), v3(0, 1, 0)), &t, &n), "from below");
}

static struct object torus(double R, double r) {
    struct object o = {.kind = SHAPE_TORUS};
    o.u.torus.center = v3(0, 0, 0);
    o.u.torus.w = v3(0, 1, 0);
    v3_frame(o.u.torus.w, &o.u.torus.u, &o.u.torus.v);
    o.u.torus.major = R;
    o.u.torus.minor = r;
    return o;
}

static void test_torus(void) {
    struct object o = torus(2, 0.5);
    struct xing x[4];
    ray r = mk(v3(-10, 0, 0), v3(1, 0, 0));
    int n = shape_ops[SHAPE_TORUS]->crossings(&o, &r, x);
    CHECK(n == 4, "four crossings through the middle: %d", n);
    double want[4] = {10 - 2.5, 10 - 1.5, 10 + 1.5, 10 + 2.5};
    for (int i = 0; i < n && i < 4; i++) CHECK_NEAR(x[i].t, want[i], 1e-9);
    double t;
    vec3 nn;
    CHECK(!hit(&o, mk(v3(0, 10, 0), v3(0, -1, 0)), &t, &nn), "down the hole");
    CHECK(hit(&o, mk(v3(2, 10, 0), v3(0, -1, 0)), &t, &nn) && fabs(t - 9.5) < 1e-9 && nn.y > 0.999,
          "top of the tube");
    CHECK(hit(&o, mk(v3(2, 0, 0), v3(0, 0, 1)), &t, &nn) && fabs(t - sqrt(4.25) + 0) < 2 &&
              isfinite(t),
          "from inside the tube");
    /* grazing: a ray just above the tube top misses, just below hits twice */
    CHECK(!hit(&o, mk(v3(-10, 0.5001, 0), v3(1, 0, 0)), &t, &nn), "just above the top");
    r = mk(v3(-10, 0.4999, 0), v3(1, 0, 0));
    n = shape_ops[SHAPE_TORUS]->crossings(&o, &r, x);
    CHECK(n == 4, "just below the top: %d crossings", n);
    /* far away: a ray from 1e6 units still finds the tube to 1e-6 */
    r = mk(v3(-1e6, 0, 0), v3(1, 0, 0));
    n = shape_ops[SHAPE_TORUS]->crossings(&o, &r, x);
    CHECK(n == 4 && fabs(x[0].t - (1e6 - 2.5)) < 1e-6, "far: %d, %.9g", n, n ? x[0].t : 0);
    /* a huge torus */
    struct object big = torus(1e5, 10);
    r = mk(v3(1e5, 100, 0), v3(0, -1, 0));
    n = shape_ops[SHAPE_TORUS]->crossings(&big, &r, x);
    CHECK(n == 2 && fabs(x[0].t - 90) < 1e-6 && fabs(x[1].t - 110) < 1e-6, "huge: %d", n);
    CHECK(shape_ops[SHAPE_TORUS]->inside(&o, v3(2, 0.2, 0)) &&
              !shape_ops[SHAPE_TORUS]->inside(&o, v3(0, 0, 0)),
          "inside");
    /* every crossing lies on the surface */
    for (int k = 0; k < 200; k++) {
        r = mk(v3(-6, 0.3 * sin(k), 0.4 * cos(k * 1.7)), v3(1, 0.2 * sin(k * 0.3), 0.1 * cos(k)));
        n = shape_ops[SHAPE_TORUS]->crossings(&o, &r, x);
        for (int i = 0; i < n; i++) {
            vec3 p = ray_at(&r, x[i].t);
            double q = sqrt(p.x * p.x + p.z * p.z) - 2;
            CHECK(fabs(sqrt(q * q + p.y * p.y) - 0.5) < 1e-9, "crossing off the surface");
        }
    }
}

static void test_triangle_and_quad(void) {
    struct object t3 = {.kind = SHAPE_TRIANGLE};
    t3.u.tri.a = v3(0, 0, 0);
    t3.u.tri.b = v3(1, 0, 0);
    t3.u.tri.c = v3(0, 1, 0);
    double t;
    vec3 n;
    CHECK(hit(&t3, mk(v3(0.2, 0.2, 5), v3(0, 0, -1)), &t, &n) && fabs(t - 5) < 1e-12 && n.z == 1,
          "triangle");
    CHECK(!hit(&t3, mk(v3(0.6, 0.6, 5), v3(0, 0, -1)), &t, &n), "outside the hypotenuse");
    CHECK(hit(&t3, mk(v3(0.2, 0.2, -5), v3(0, 0, 1)), &t, &n), "from behind");
    struct object q = {.kind = SHAPE_QUAD};
    q.u.quad.corner = v3(0, 0, 0);
    q.u.quad.e1 = v3(2, 0, 0);
    q.u.quad.e2 = v3(0, 0, 1);
    quad_derive(&q);
    CHECK(hit(&q, mk(v3(1.9, 3, 0.9), v3(0, -1, 0)), &t, &n) && fabs(t - 3) < 1e-12,
          "quad corner region");
    CHECK(!hit(&q, mk(v3(2.1, 3, 0.5), v3(0, -1, 0)), &t, &n), "past the quad");
    CHECK(fabs(fabs(n.y) - 1) < 1e-12, "quad normal");
}

static void test_quadric(void) {
    /* x^2 + y^2 + z^2 - 4 = 0: the sphere of radius 2 */
    struct object q = {.kind = SHAPE_QUADRIC};
    double k[10] = {1, 1, 1, 0, 0, 0, 0, 0, 0, -4};
    for (int i = 0; i < 10; i++) q.u.quadric.k[i] = k[i];
    double t;
    vec3 n;
    CHECK(hit(&q, mk(v3(0, 0, 10), v3(0, 0, -1)), &t, &n) && fabs(t - 8) < 1e-12 &&
              fabs(n.z - 1) < 1e-12,
          "sphere quadric");
    /* a paraboloid y = x^2 + z^2: x^2 + z^2 - y = 0 */
    double p[10] = {1, 0, 1, 0, 0, 0, 0, -1, 0, 0};
    for (int i = 0; i < 10; i++) q.u.quadric.k[i] = p[i];
    CHECK(hit(&q, mk(v3(1, 10, 0), v3(0, -1, 0)), &t, &n) && fabs(t - 9) < 1e-12, "paraboloid");
    vec3 want = v3_norm(v3(2, -1, 0));
    CHECK(fabs(v3_dot(n, want) - 1) < 1e-12, "paraboloid normal");
    CHECK(shape_ops[SHAPE_QUADRIC]->inside(&q, v3(0, 1, 0)), "inside the bowl");
}

int main(void) {
    RUN(test_box);
    RUN(test_cylinder);
    RUN(test_cone);
    RUN(test_disc);
    RUN(test_torus);
    RUN(test_triangle_and_quad);
    RUN(test_quadric);
    CHECK_EXIT();
}
