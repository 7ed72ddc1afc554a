/* scene_leave.c -- which top-level objects a ray leaving them can never
 * meet again, worked out once when the scene is frozen.
 *
 * A secondary ray starts integrate_offset off the surface it leaves, on
 * the side it goes to, and every hit test takes t > 0 only.  So it cannot
 * meet again a flat object (a quad, disc or triangle: it crosses that
 * plane once, behind its origin), nor a convex closed one (a sphere or a
 * box) that it leaves outward: both crossings are behind it.  The path
 * tracer's queries then pass over that object (scene_intersect_from):
 * most rays of a room leave a wall that each of them would otherwise test
 * again for nothing.
 *
 * That reasoning holds while the offset dominates the rounding of the hit
 * tests, as it must for integrate_offset's own purpose.  The offset is
 * 1e-9 of the point's scale (1 + its largest coordinate); a test rounds at
 * about 1e-16 of the coordinates it works with, the object's own and the
 * ray's origin, each through the object's transform, and a flat test
 * divides by the sine of the angle between the edges.  So each object gets
 * the scale it rounds at -- its largest coordinate, its transform's size
 * and condition, its edges' angle folded in -- and the path tracer skips
 * it only at points where that scale is within 1e4 of the point's: the
 * rounding then stays a thousandth of the offset, and every answer is the
 * same, bit for bit.  An object of another kind, a badly conditioned
 * transform (over 1e3) or nearly parallel edges (sine under 0.01) is
 * never skipped; nor are CSG, meshes, instances (a ray may meet another
 * part of them) or the unbounded planes (tested one by one, apart).
 */
#include <math.h>
#include <stdlib.h>

#include "base/error.h"
#include "scene/scene.h"

/* Sine of the angle between e1 and e2 at least 0.01. */
static bool leave_edges(vec3 e1, vec3 e2) {
    vec3 c = v3_cross(e1, e2);
    return v3_dot(c, c) >= 1e-4 * v3_dot(e1, e1) * v3_dot(e2, e2);
}

/* The largest coordinate object o's test works with, in its own space;
 * *flat for the flat kinds; INFINITY for the kinds never skipped. */
static double leave_size(const struct object *o, bool *flat) {
    *flat = false;
    switch (o->kind) {
    case SHAPE_SPHERE: return v3_maxabs(o->u.sphere.center) + o->u.sphere.radius;
    case SHAPE_BOX: return v3_fmax(v3_maxabs(o->u.box.lo), v3_maxabs(o->u.box.hi));
    case SHAPE_DISC: *flat = true; return v3_maxabs(o->u.disc.center) + o->u.disc.radius;
    case SHAPE_QUAD:
        *flat = true;
        if (!leave_edges(o->u.quad.e1, o->u.quad.e2)) return INFINITY;
        return v3_maxabs(o->u.quad.corner) + v3_maxabs(o->u.quad.e1) + v3_maxabs(o->u.quad.e2);
    case SHAPE_TRIANGLE: {
        vec3 a = o->u.tri.a, b = o->u.tri.b, c = o->u.tri.c;
        *flat = true;
        if (!leave_edges(v3_sub(b, a), v3_sub(c, a))) return INFINITY;
        return v3_fmax(v3_maxabs(a), v3_fmax(v3_maxabs(b), v3_maxabs(c)));
    }
    default: return INFINITY;
    }
}

/* The scale object o's test rounds at, in world units (see above). */
static double leave_scale(const rayd_scene *s, const struct object *o, bool *flat) {
    double size = leave_size(o, flat);
    if (o->xform < 0 || !(size < INFINITY)) return size;
    const struct xform *x = &s->xforms[o->xform];
    double fm = 0, fi = 0; /* Frobenius norms squared: their product bounds the condition */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            fm += x->m[i][j] * x->m[i][j];
            fi += x->inv[i][j] * x->inv[i][j];
        }
    if (!(fm * fi <= 1e6)) return INFINITY;
    vec3 it = v3(x->inv[0][3], x->inv[1][3], x->inv[2][3]);
    return sqrt(fm * fi) * (size + v3_maxabs(it)) * sqrt(fm);
}

enum rayd_status scene_leave_freeze(rayd_scene *s, struct rayd_error *err) {
    s->leave = malloc(sizeof *s->leave * (size_t)s->nobjs);
    if (!s->leave) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory");
    for (int32_t i = 0; i < s->nobjs; i++) {
        bool flat;
        double scale = leave_scale(s, &s->objs[i], &flat);
        s->leave[i] = (struct scene_leave){scale, flat};
    }
    return RAYD_OK;
}
