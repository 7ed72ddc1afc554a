/* shape.h -- the primitives the scene is made of.
 *
 * One struct for every kind, tagged by `kind`, so objects sit in one flat
 * array that the BVH reorders and the tracer walks without indirection or
 * function pointers.  Each kind lives in its own shape_<kind>.c with its
 * intersection, normal and bounds.  Unbounded kinds (planes) are kept out of
 * the BVH and tested directly.
 */
#ifndef SHAPE_H
#define SHAPE_H

#include <stdbool.h>
#include <stdint.h>

#include "vec.h"

enum shape_kind { SHAPE_SPHERE, SHAPE_PLANE, SHAPE_MESH };

struct aabb {
    vec3 lo, hi;
};

struct object {
    enum shape_kind kind;
    int material;  /* index into the scene's materials */
    int32_t xform; /* index into the scene's transforms, -1 for none */
    union {
        struct {
            vec3 center;
            double radius;
        } sphere;
        struct {
            vec3 point;  /* Q */
            vec3 normal; /* unit n */
        } plane;
        struct {
            uint32_t id; /* index into the scene's meshes */
        } mesh;
    } u;
};

/* Nearest intersection with t in (tmin, tmax): true and *t set, or false. */
bool sphere_hit(const struct object *o, const ray *r, double tmin, double tmax, double *t);
bool plane_hit(const struct object *o, const ray *r, double tmin, double tmax, double *t);

/* Outward unit normal at the surface point p. */
vec3 sphere_normal(const struct object *o, vec3 p);

struct aabb sphere_bounds(const struct object *o);

static inline bool shape_bounded(const struct object *o) { return o->kind != SHAPE_PLANE; }

#endif
