/* shape.h -- the primitives the scene is made of.
 *
 * One struct for every kind, tagged by `kind`, so objects sit in one flat
 * array that the BVH reorders.  Each analytic kind lives in its own
 * shape_<kind>.c and fills one row of shape_ops: all its crossings with a
 * ray's line (sorted, each with the part of the surface it is on, so caps
 * and sides get their own normals), the outward normal, the bounds, a
 * point-in-solid test for CSG, and texture coordinates.  The nearest hit is
 * the first crossing inside (tmin, tmax); CSG combines the crossing lists.
 *
 * Meshes, CSG nodes and instances refer to data held by the scene and are
 * dispatched in scene_query.c.  Unbounded kinds (planes, quadrics) are kept out of
 * the BVH and tested one by one.
 */
#ifndef SHAPE_H
#define SHAPE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "math/vec.h"

enum shape_kind {
    SHAPE_SPHERE,
    SHAPE_PLANE,
    SHAPE_BOX,
    SHAPE_CYLINDER, /* also cones: a cylinder whose two radii differ */
    SHAPE_DISC,
    SHAPE_TORUS,
    SHAPE_TRIANGLE,
    SHAPE_QUAD,
    SHAPE_QUADRIC,
    SHAPE_MESH,
    SHAPE_CSG,
    SHAPE_INSTANCE,
    SHAPE_KINDS
};

enum csg_op { CSG_UNION, CSG_INTERSECTION, CSG_DIFFERENCE };

struct object {
    enum shape_kind kind : 8;
    /* Its index in /objects (a CSG operand's: its CSG object's; a group
     * member's: in its group), the AOVs' object id (render/aov.c); 24
     * bits beside kind keep the struct at two cache lines. */
    int32_t id : 24;
    int material;  /* index into the scene's materials */
    int32_t xform; /* index into the scene's transforms, -1 for none */
    /* A CSG leaf that takes its material from a csg node above it: 1 + the
     * index of that node's transform, the space its object-space texture is
     * in (one pattern across the whole node, as in POV-Ray); 0: the
     * object's own space. */
    int32_t tex_xform;
    union {
        struct {
            vec3 center;
            double radius;
        } sphere;
        struct {
            vec3 point;  /* Q */
            vec3 normal; /* unit n */
            bool baked;  /* its transform is baked in (scene.c): a top-level plane */
        } plane;
        struct {
            vec3 lo, hi;
        } box;
        struct {
            vec3 base;     /* centre of the base disc */
            vec3 axis;     /* unit, base to top */
            double height; /* along axis */
            double r0, r1; /* radius at base and at top */
            bool capped;
        } cyl;
        struct {
            vec3 center, normal; /* normal unit */
            double radius, inner;
        } disc;
        struct {
            vec3 center;
            vec3 u, v, w; /* frame: w is the axis */
            double major, minor;
        } torus;
        struct {
            vec3 a, b, c;
        } tri;
        struct {
            vec3 corner, e1, e2; /* points corner + s e1 + t e2, s, t in [0, 1] */
            /* from the edges by quad_derive: the unit normal e1 x e2 and
             * the area, made once rather than at every hit and light
             * sample */
            vec3 n;
            double area;
        } quad;
        struct {
            /* a x^2 + b y^2 + c z^2 + d xy + e xz + f yz + g x + h y + i z + j = 0 */
            double k[10];
        } quadric;
        struct {
            uint32_t id; /* index into the scene's meshes */
        } mesh;
        struct {
            enum csg_op op;
            int32_t left, right; /* indices into the scene's parts */
        } csg;
        struct {
            int32_t group; /* index into the scene's groups */
        } inst;
    } u;
};

/* A crossing of a ray's line with a surface: its t and which part. */
struct xing {
    double t;
    int part;
};

#define SHAPE_MAX_XINGS 4

struct shape_ops {
    const char *name;
    /* All crossings with the whole line o + t d (t of any sign), sorted. */
    int (*crossings)(const struct object *o, const ray *r, struct xing out[SHAPE_MAX_XINGS]);
    /* Outward unit normal at surface point p on part. */
    vec3 (*normal)(const struct object *o, vec3 p, int part);
    /* Bounds; NULL for unbounded kinds. */
    struct aabb (*bounds)(const struct object *o);
    /* Point-in-solid; NULL for surfaces that enclose nothing. */
    bool (*inside)(const struct object *o, vec3 p);
    /* Texture coordinates of surface point p. */
    void (*uv)(const struct object *o, vec3 p, int part, double *u, double *v);
};

/* One row per analytic kind (NULL for meshes, CSG and instances). */
extern const struct shape_ops *const shape_ops[SHAPE_KINDS];
extern const struct shape_ops sphere_ops, plane_ops, box_ops, cylinder_ops, disc_ops, torus_ops,
    triangle_ops, quad_ops, quadric_ops;

/* The nearest crossing with t in (tmin, tmax). */
bool shape_hit(const struct object *o, const ray *r, double tmin, double tmax, double *t,
               int *part);

static inline bool shape_bounded(const struct object *o) {
    return o->kind >= SHAPE_MESH || shape_ops[o->kind]->bounds != NULL;
}

/* A solid (usable as a CSG operand): encloses a volume.  Inline: asked at
 * every hit. */
static inline bool shape_is_solid(const struct object *o) {
    if (o->kind >= SHAPE_MESH) return o->kind == SHAPE_CSG;
    if (o->kind == SHAPE_CYLINDER) return o->u.cyl.capped;
    return shape_ops[o->kind]->inside != NULL;
}

/* Fills quad o's normal and area from its edges (set them first). */
void quad_derive(struct object *o);

/* The sphere's two crossings with the ray's line, sorted (shape_sphere.c
 * explains the formula); false when the line misses.  Inline: the hot
 * path of sphere scenes. */
static inline bool sphere_roots(const struct object *o, const ray *r, double *t0, double *t1) {
    vec3 oc = v3_sub(r->o, o->u.sphere.center);
    double rad = o->u.sphere.radius;
    double b = v3_dot(oc, r->d);
    double c = v3_dot(oc, oc) - rad * rad;
    vec3 h = v3_madd(oc, r->d, -b);
    double disc = rad * rad - v3_dot(h, h);
    if (disc < 0) return false;
    double q = -b - copysign(sqrt(disc), b);
    double a0 = q, a1 = (q != 0) ? c / q : q;
    *t0 = v3_fmin(a0, a1);
    *t1 = v3_fmax(a0, a1);
    return true;
}

/* shape_hit for a sphere and for a plane with tmin = 0, without the
 * crossing list. */
static inline bool sphere_nearest(const struct object *o, const ray *r, double tmax, double *t) {
    double t0, t1;
    if (!sphere_roots(o, r, &t0, &t1)) return false;
    *t = t0 > 0 && t0 < tmax ? t0 : t1;
    return *t > 0 && *t < tmax;
}

/* The plane's crossing with the ray's line (the paper's formula, see
 * shape_plane.c); false when the ray runs parallel to it. */
static inline bool plane_cross(const struct object *o, const ray *r, double *t) {
    double denom = v3_dot(o->u.plane.normal, r->d);
    if (denom == 0) return false;
    *t = v3_dot(o->u.plane.normal, v3_sub(o->u.plane.point, r->o)) / denom;
    return true;
}

static inline bool plane_nearest(const struct object *o, const ray *r, double tmax, double *t) {
    return plane_cross(o, r, t) && *t > 0 && *t < tmax;
}

/* The Moller-Trumbore solve of O + tD = corner + s e1 + u e2 for a quad
 * (s, u in [0, 1]) or a triangle (s, u >= 0, s + u <= 1): the crossing's
 * t, false when the line misses (shape_triangle.c).  Inline: the crossing
 * list and the nearest-hit fast path share these very roundings. */
static inline bool para_solve(vec3 corner, vec3 e1, vec3 e2, bool tri, const ray *r, double *t) {
    vec3 pv = v3_cross(r->d, e2);
    double det = v3_dot(e1, pv);
    if (det == 0) return false;
    double inv = 1.0 / det;
    vec3 tv = v3_sub(r->o, corner);
    double s = v3_dot(tv, pv) * inv;
    if (s < 0 || s > 1) return false;
    vec3 qv = v3_cross(tv, e1);
    double u = v3_dot(r->d, qv) * inv;
    if (u < 0 || (tri ? s + u > 1 : u > 1)) return false;
    *t = v3_dot(e2, qv) * inv;
    return true;
}

static inline bool quad_nearest(const struct object *o, const ray *r, double tmax, double *t) {
    return para_solve(o->u.quad.corner, o->u.quad.e1, o->u.quad.e2, false, r, t) && *t > 0 &&
           *t < tmax;
}

/* The box's slabs (shape_box.c): where the line enters (tn, on part pn)
 * and leaves (tf, pf); false when it misses. */
static inline bool box_slabs(const struct object *o, const ray *r, double *tn_, int *pn_,
                             double *tf_, int *pf_) {
    double o3[3] = {r->o.x, r->o.y, r->o.z}, d3[3] = {r->d.x, r->d.y, r->d.z};
    double lo[3] = {o->u.box.lo.x, o->u.box.lo.y, o->u.box.lo.z};
    double hi[3] = {o->u.box.hi.x, o->u.box.hi.y, o->u.box.hi.z};
    double tn = -INFINITY, tf = INFINITY;
    int pn = 0, pf = 0;
    for (int k = 0; k < 3; k++) {
        if (d3[k] == 0) {
            if (o3[k] < lo[k] || o3[k] > hi[k]) return false;
            continue;
        }
        double a = (lo[k] - o3[k]) / d3[k], b = (hi[k] - o3[k]) / d3[k];
        int pa = 2 * k, pb = 2 * k + 1; /* part: axis * 2 + (1 for the high face) */
        if (a > b) {
            double x = a;
            a = b;
            b = x;
            pa = 2 * k + 1;
            pb = 2 * k;
        }
        if (a > tn) tn = a, pn = pa;
        if (b < tf) tf = b, pf = pb;
    }
    if (!(tn <= tf) || !isfinite(tn) || !isfinite(tf)) return false;
    *tn_ = tn, *pn_ = pn, *tf_ = tf, *pf_ = pf;
    return true;
}

/* shape_hit's rule on the box's two crossings, tmin = 0. */
static inline bool box_nearest(const struct object *o, const ray *r, double tmax, double *t,
                               int *part) {
    double tn, tf;
    int pn, pf;
    if (!box_slabs(o, r, &tn, &pn, &tf, &pf)) return false;
    if (tn > 0 && tn < tmax) {
        *t = tn, *part = pn;
        return true;
    }
    if (tf > 0 && tf < tmax) {
        *t = tf, *part = pf;
        return true;
    }
    return false;
}

/* Shape-specific entry points the tests and the fast paths use. */
bool sphere_hit(const struct object *o, const ray *r, double tmin, double tmax, double *t);
bool plane_hit(const struct object *o, const ray *r, double tmin, double tmax, double *t);
vec3 sphere_normal(const struct object *o, vec3 p);

#endif
