/* light_buffer.c -- which objects can shadow which directions from a point
 * light: the light buffer of Haines and Greenberg (1986), as POV-Ray has it.
 *
 * A cube around the light is cut into cells; each cell lists the objects
 * whose bounding boxes, seen from the light, cover some of its directions.
 * A shadow ray runs from a surface point toward the light, so every point
 * of it lies, seen from the light, in the direction of its origin: only the
 * objects of that cell can stop it.  A packet of shadow rays whose origins
 * fall in one cell (or a few) tests those objects and nothing else -- most
 * fall in cells with none -- instead of walking the top-level BVH.
 *
 * The answer must be the walk's answer to the bit, so the buffer only ever
 * leaves out objects that cannot be met:
 *   - an object's directions come from its box's corners, widened by
 *     LB_MARGIN in face coordinates, far more than rounding moves them;
 *   - a shadow ray starts a little off the surface and its direction was
 *     computed from the surface point, so its points stray from the line
 *     through the light and the origin by about 1e-9 of the origin's size;
 *     seen from the light, at an object at least `near` away, that is an
 *     angle LB_MARGIN covers while the origin lies within `reach`
 *     (set in buffer_build); packets from farther out walk the BVH;
 *   - a light with an object's box around it or next to it gets no buffer.
 * Each face covers only the rectangle its objects cover, in up to LB_CELLS
 * x LB_CELLS cells; lanes outside it meet no object.
 *
 * Cells an object.  A face holds about LB_CELLS_PER_OBJ cells for each
 * object that shows on it (64 x 64 from 199 objects on).  The cells' lists
 * are built in every process before the first ray, on fresh pages, so more
 * cells than the objects need cost build time for no faster render; fewer
 * leave cells holding too many objects to settle a packet (bench/README.md,
 * "Design records").
 */
#include "accel/light_buffer.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"

#define LB_MARGIN (1.0 / 1024) /* the widening of every object's directions */
#define LB_CELLS 64            /* cells on a side of a face's rectangle, at most */
#define LB_CELLS_MIN 16        /* ... and at least */
#define LB_CELLS_PER_OBJ 20    /* cells a face holds for each object on it, about */
#define LB_MAX_OBJS 65536      /* beyond this the BVH walk does better */
#define LB_MAX_LIGHTS 32       /* lights with a buffer; the others walk */
#define LB_MAX_PAIRS (1 << 21) /* lights x objects: bounds the time to build */
#define LB_MAX_IDS (1u << 22)  /* entries in all the cells of all the lights */

/* An object's rectangle of directions on one face, or none. */
struct lb_rect {
    double u0, u1, v0, v1;
    bool on;
};

/* The range of w / ca over w in [lo, hi] and ca in (ca0, ca1] (ca1 > 0;
 * ca0 <= 0: the box reaches the light's plane, and near it w / ca runs off
 * to the infinity of w's sign). */
static void ratio_range(double lo, double hi, double ca0, double ca1, double *r0, double *r1) {
    *r0 = lo >= 0 ? lo / ca1 : ca0 > 0 ? lo / ca0 : -INFINITY;
    *r1 = hi <= 0 ? hi / ca1 : ca0 > 0 ? hi / ca0 : INFINITY;
}

/* Box b (relative to the light) seen on face f, widened by LB_MARGIN and
 * cut to the face. */
static struct lb_rect face_rect(int f, vec3 lo, vec3 hi) {
    int a = f / 2, b = (a + 1) % 3, c = (a + 2) % 3;
    double sg = f % 2 ? -1 : 1;
    double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
    double ca0 = sg > 0 ? l[a] : -h[a], ca1 = sg > 0 ? h[a] : -l[a];
    struct lb_rect r = {-1, 1, -1, 1, false};
    if (!(ca1 > 0)) return r;
    ratio_range(l[b], h[b], ca0, ca1, &r.u0, &r.u1);
    ratio_range(l[c], h[c], ca0, ca1, &r.v0, &r.v1);
    r.u0 -= LB_MARGIN, r.u1 += LB_MARGIN, r.v0 -= LB_MARGIN, r.v1 += LB_MARGIN;
    if (r.u1 < -1 || r.u0 > 1 || r.v1 < -1 || r.v0 > 1) return r;
    r.u0 = fmax(r.u0, -1), r.u1 = fmin(r.u1, 1);
    r.v0 = fmax(r.v0, -1), r.v1 = fmin(r.v1, 1);
    r.on = true;
    return r;
}

/* The cells [i0, i1] x [j0, j1] of face f that rectangle r covers. */
static void face_cells(const struct light_face *f, const struct lb_rect *r, int32_t *i0,
                       int32_t *i1, int32_t *j0, int32_t *j1) {
    double a = floor((r->u0 - f->u0) * f->su), b = floor((r->u1 - f->u0) * f->su);
    double c = floor((r->v0 - f->v0) * f->sv), d = floor((r->v1 - f->v0) * f->sv);
    *i0 = a < 0 ? 0 : (int32_t)a, *i1 = b >= f->nu ? f->nu - 1 : (int32_t)b;
    *j0 = c < 0 ? 0 : (int32_t)c, *j1 = d >= f->nv ? f->nv - 1 : (int32_t)d;
}

static bool box_finite(const struct aabb *b) {
    return isfinite(b->lo.x) && isfinite(b->lo.y) && isfinite(b->lo.z) && isfinite(b->hi.x) &&
           isfinite(b->hi.y) && isfinite(b->hi.z);
}

/* The distance from the origin to box [lo, hi]. */
static double box_distance(vec3 lo, vec3 hi) {
    vec3 out = v3_max(v3_max(lo, v3(0, 0, 0)), v3_scale(hi, -1));
    return v3_len(out);
}

/* Cells on a side of a face that shown objects show on (see the top). */
static int32_t face_side(int32_t shown) {
    double side = ceil(sqrt((double)shown * LB_CELLS_PER_OBJ));
    return side < LB_CELLS_MIN ? LB_CELLS_MIN : side > LB_CELLS ? LB_CELLS : (int32_t)side;
}

/* Room the build reuses from face to face and light to light: each
 * object's rectangle on the face at hand, a cursor per cell, and a mark
 * per object: the stamp of the last list of 2 x 2 cells it went into (the
 * stamps only grow, so the marks are never cleared). */
struct lb_scratch {
    struct lb_rect *rect;
    uint32_t *fill;
    uint32_t *mark, stamp;
};

/* The objects of the 2 x 2 cells from (i, j) of face f, each once, into
 * out (when not NULL) in the order of the cells' lists; their count. */
static uint32_t quad_list(const struct light_face *f, int32_t i, int32_t j, struct lb_scratch *sc,
                          uint32_t *out) {
    uint32_t n = 0, q = ++sc->stamp;
    for (int32_t y = j < 0 ? 0 : j; y <= j + 1 && y < f->nv; y++)
        for (int32_t x = i < 0 ? 0 : i; x <= i + 1 && x < f->nu; x++) {
            int32_t cell = y * f->nu + x;
            for (uint32_t k = f->start[cell]; k < f->start[cell + 1]; k++) {
                uint32_t id = f->ids[k];
                if (sc->mark[id] == q) continue;
                sc->mark[id] = q;
                if (out) out[n] = id;
                n++;
            }
        }
    return n;
}

/* Every list of 2 x 2 cells of face f: their sizes into f->qstart (from
 * qstart[0] = 0), or with fill their objects into f->quad. */
static void quad_lists(struct light_face *f, struct lb_scratch *sc, bool fill) {
    uint32_t row = (uint32_t)(f->nu + 1), quads = row * (uint32_t)(f->nv + 1);
    for (uint32_t q = 0; q < quads; q++) {
        int32_t i = (int32_t)(q % row) - 1, j = (int32_t)(q / row) - 1;
        uint32_t n = quad_list(f, i, j, sc, fill ? f->quad + f->qstart[q] : NULL);
        if (!fill) f->qstart[q + 1] = f->qstart[q] + n;
    }
}

/* Face f's lists of 2 x 2 cells (light_buffer.h), from its cells' lists,
 * taking their entries from *budget; as face_build.  Made here once, so a
 * packet's shadow rays read one list instead of merging four. */
static bool face_quads(struct light_face *f, struct lb_scratch *sc, size_t *budget, bool *nomem) {
    size_t quads = (size_t)(f->nu + 1) * (size_t)(f->nv + 1);
    if (!(f->qstart = calloc(quads + 1, sizeof *f->qstart))) return !(*nomem = true);
    quad_lists(f, sc, false);
    size_t total = f->qstart[quads];
    if (total > *budget) return false;
    *budget -= total;
    if (!(f->quad = malloc(sizeof *f->quad * (total + 1)))) return !(*nomem = true);
    quad_lists(f, sc, true);
    return true;
}

/* Face f's rectangle, cells and lists over the objects' boxes rel[]
 * (relative to the light), taking their entries from *budget.  False when
 * out of memory (*nomem set) or over the budget; either way the face may
 * hold memory for buffer_free. */
static bool face_build(struct light_face *f, int fi, const struct aabb *rel, int32_t n,
                       struct lb_scratch *sc, size_t *budget, bool *nomem) {
    double u0 = INFINITY, u1 = -INFINITY, v0 = INFINITY, v1 = -INFINITY;
    int32_t shown = 0;
    for (int32_t k = 0; k < n; k++) {
        struct lb_rect r = sc->rect[k] = face_rect(fi, rel[k].lo, rel[k].hi);
        if (!r.on) continue;
        u0 = fmin(u0, r.u0), u1 = fmax(u1, r.u1), v0 = fmin(v0, r.v0), v1 = fmax(v1, r.v1);
        shown++;
    }
    if (!(u0 < u1 && v0 < v1)) return true; /* no object on this face */
    int32_t side = face_side(shown);
    f->nu = f->nv = side;
    f->u0 = u0, f->v0 = v0;
    f->su = side / (u1 - u0), f->sv = side / (v1 - v0);
    f->cu = 1 / f->su, f->cv = 1 / f->sv;
    int32_t cells = f->nu * f->nv;
    f->start = calloc((size_t)cells + 1, sizeof *f->start);
    if (!f->start) return !(*nomem = true);
    size_t total = 0; /* the counts, then the lists */
    for (int32_t k = 0; k < n; k++) {
        if (!sc->rect[k].on) continue;
        int32_t i0, i1, j0, j1;
        face_cells(f, &sc->rect[k], &i0, &i1, &j0, &j1);
        total += (size_t)(i1 - i0 + 1) * (size_t)(j1 - j0 + 1);
        if (total > *budget) return false;
        for (int32_t j = j0; j <= j1; j++)
            for (int32_t i = i0; i <= i1; i++) f->start[j * f->nu + i + 1]++;
    }
    *budget -= total;
    for (int32_t c = 0; c < cells; c++) f->start[c + 1] += f->start[c];
    if (!(f->ids = malloc(sizeof *f->ids * (total + 1)))) return !(*nomem = true);
    memcpy(sc->fill, f->start, sizeof *sc->fill * (size_t)cells);
    for (int32_t k = 0; k < n; k++) {
        if (!sc->rect[k].on) continue;
        int32_t i0, i1, j0, j1;
        face_cells(f, &sc->rect[k], &i0, &i1, &j0, &j1);
        for (int32_t j = j0; j <= j1; j++)
            for (int32_t i = i0; i <= i1; i++) f->ids[sc->fill[j * f->nu + i]++] = (uint32_t)k;
    }
    return face_quads(f, sc, budget, nomem);
}

static void buffer_free(struct light_buffer *b) {
    for (int f = 0; f < 6; f++) {
        struct light_face *lf = &b->face[f];
        free(lf->start), free(lf->ids), free(lf->qstart), free(lf->quad);
    }
    memset(b, 0, sizeof *b);
}

/* The buffer of the point light at p over the objects (boxes rel,
 * relative to p), with at most *budget entries (less those it takes);
 * false when out of memory.  Leaves b->ok false where the buffer would not
 * be sound, or not fit. */
static bool buffer_build(struct light_buffer *b, vec3 p, const struct aabb *rel, int32_t n,
                         struct lb_scratch *sc, size_t *budget) {
    double near = INFINITY;
    for (int32_t k = 0; k < n; k++) {
        if (!box_finite(&rel[k])) return true;
        near = fmin(near, box_distance(rel[k].lo, rel[k].hi));
    }
    /* light_buffer.h's reach: within it a shadow ray strays from its line by
     * far less than LB_MARGIN sees at distance near */
    double reach = near * 1e3 - 1 - 1e-5 * v3_maxabs(p);
    if (!(reach > 0) || !(near > 1e-6 * (1 + v3_maxabs(p)))) return true;
    size_t left = *budget;
    bool nomem = false;
    for (int f = 0; f < 6; f++) {
        if (face_build(&b->face[f], f, rel, n, sc, &left, &nomem)) continue;
        buffer_free(b);
        return !nomem;
    }
    *budget = left;
    b->at = p;
    b->reach = reach;
    b->ok = true;
    return true;
}

bool light_buffers_worth(const struct light_buffer_light *lights, int nlights, int32_t nobjs) {
    bool point = false;
    for (int i = 0; i < nlights; i++) point |= lights[i].point;
    return point && nobjs >= 2 && nobjs <= LB_MAX_OBJS;
}

enum rayd_status light_buffers_build(const struct aabb *box, int32_t nobjs,
                                     const struct light_buffer_light *lights, int nlights,
                                     struct light_buffer **out, struct rayd_error *err) {
    *out = NULL;
    if (!light_buffers_worth(lights, nlights, nobjs)) return RAYD_OK;
    struct light_buffer *bufs = calloc((size_t)nlights, sizeof *bufs);
    struct aabb *rel = malloc(sizeof *rel * (size_t)nobjs);
    size_t side = (size_t)face_side(nobjs); /* no face shows more objects */
    struct lb_scratch sc = {malloc(sizeof *sc.rect * (size_t)nobjs),
                            malloc(sizeof *sc.fill * side * side),
                            calloc((size_t)nobjs, sizeof *sc.mark), 0};
    bool ok = bufs && rel && sc.rect && sc.fill && sc.mark;
    size_t ids = LB_MAX_IDS;
    int built = 0,
        most = LB_MAX_PAIRS / nobjs < LB_MAX_LIGHTS ? LB_MAX_PAIRS / nobjs : LB_MAX_LIGHTS;
    for (int i = 0; ok && i < nlights && built < most; i++) {
        if (!lights[i].point) continue;
        vec3 p = lights[i].at;
        for (int32_t k = 0; k < nobjs; k++)
            rel[k] = (struct aabb){v3_sub(box[k].lo, p), v3_sub(box[k].hi, p)};
        ok = buffer_build(&bufs[i], p, rel, nobjs, &sc, &ids);
        built++;
    }
    free(rel);
    free(sc.rect);
    free(sc.fill);
    free(sc.mark);
    if (ok) {
        *out = bufs;
        return RAYD_OK;
    }
    light_buffers_free(bufs, nlights);
    return err_set(err, RAYD_E_NOMEM, NULL, "out of memory building the light buffers");
}

size_t light_buffers_bytes(const struct light_buffer *bufs, int nlights) {
    size_t bytes = 0;
    for (int i = 0; bufs && i < nlights; i++) {
        const struct light_buffer *b = &bufs[i];
        bytes += sizeof *b;
        for (int f = 0; b->ok && f < 6; f++) {
            const struct light_face *lf = &b->face[f];
            size_t cells = (size_t)lf->nu * (size_t)lf->nv;
            size_t quads = (size_t)(lf->nu + 1) * (size_t)(lf->nv + 1);
            if (cells)
                bytes += sizeof *lf->start * (cells + 1) + sizeof *lf->ids * lf->start[cells] +
                         sizeof *lf->qstart * (quads + 1) + sizeof *lf->quad * lf->qstart[quads];
        }
    }
    return bytes;
}

void light_buffers_free(struct light_buffer *bufs, int nlights) {
    if (!bufs) return;
    for (int i = 0; i < nlights; i++) buffer_free(&bufs[i]);
    free(bufs);
}
