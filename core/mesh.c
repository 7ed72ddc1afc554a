/* mesh.c -- triangle meshes: build, and the ray queries.
 *
 * A mesh is geometry only: material and placement belong to the objects
 * that refer to it, so one mesh can be drawn many times (instances) for
 * the memory of one.  Vertices are float, like every fast ray tracer's,
 * and triangles are stored as vertex indices in BVH leaf order: 12 bytes a
 * triangle plus ~6 for vertices plus the BVH, no per-triangle copies.
 *
 * The ray/triangle test is the watertight one of Woop, Benthin and Wald
 * (JCGT 2013): the ray is sheared so it points along +z, and the three edge
 * functions are evaluated in that 2-D frame, falling back to double when
 * one is exactly zero.  A ray through a shared edge or vertex hits at least
 * one of the triangles meeting there: no cracks.
 */
#include "mesh.h"

#include <stdlib.h>
#include <string.h>

#include "error.h"

struct tri_ray {
    float org[3];
    int kx, ky, kz;
    float sx, sy, sz;
};

static void tri_ray_init(struct tri_ray *tr, const ray *r) {
    double d[3] = {r->d.x, r->d.y, r->d.z};
    tr->org[0] = (float)r->o.x;
    tr->org[1] = (float)r->o.y;
    tr->org[2] = (float)r->o.z;
    int kz = fabs(d[0]) > fabs(d[1]) ? (fabs(d[0]) > fabs(d[2]) ? 0 : 2)
                                     : (fabs(d[1]) > fabs(d[2]) ? 1 : 2);
    int kx = (kz + 1) % 3, ky = (kx + 1) % 3;
    if (d[kz] < 0) {
        int t = kx;
        kx = ky;
        ky = t;
    }
    tr->kx = kx;
    tr->ky = ky;
    tr->kz = kz;
    tr->sx = (float)(d[kx] / d[kz]);
    tr->sy = (float)(d[ky] / d[kz]);
    tr->sz = (float)(1.0 / d[kz]);
}

/* Watertight test of triangle tri; on a hit closer than *tmax, updates
 * *tmax and h. */
static inline bool tri_hit(const struct mesh *m, uint32_t tri, const struct tri_ray *tr,
                           float *tmax, struct mesh_hit *h) {
    const uint32_t *ix = m->index + 3 * (size_t)tri;
    const float *pa = m->pos + 3 * (size_t)ix[0], *pb = m->pos + 3 * (size_t)ix[1],
                *pc = m->pos + 3 * (size_t)ix[2];
    int kx = tr->kx, ky = tr->ky, kz = tr->kz;
    float az = pa[kz] - tr->org[kz], bz = pb[kz] - tr->org[kz], cz = pc[kz] - tr->org[kz];
    float ax = pa[kx] - tr->org[kx] - tr->sx * az, ay = pa[ky] - tr->org[ky] - tr->sy * az;
    float bx = pb[kx] - tr->org[kx] - tr->sx * bz, by = pb[ky] - tr->org[ky] - tr->sy * bz;
    float cx = pc[kx] - tr->org[kx] - tr->sx * cz, cy = pc[ky] - tr->org[ky] - tr->sy * cz;
    float u = cx * by - cy * bx, v = ax * cy - ay * cx, w = bx * ay - by * ax;
    if (u == 0 || v == 0 || w == 0) { /* on an edge: decide in double */
        u = (float)((double)cx * by - (double)cy * bx);
        v = (float)((double)ax * cy - (double)ay * cx);
        w = (float)((double)bx * ay - (double)by * ax);
    }
    if ((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0)) return false;
    float det = u + v + w;
    if (det == 0) return false;
    float t = u * tr->sz * az + v * tr->sz * bz + w * tr->sz * cz;
    /* t / det in (0, tmax), without dividing yet */
    if (det > 0 ? (t <= 0 || t >= *tmax * det) : (t >= 0 || t <= *tmax * det)) return false;
    float rcp = 1.0f / det;
    *tmax = t * rcp;
    h->t = *tmax;
    h->u = v * rcp;
    h->v = w * rcp;
    h->tri = tri;
    return true;
}

static bool mesh_walk(const struct mesh *m, const ray *r, double tmax, struct mesh_hit *h,
                      bool any) {
    if (m->bvh.nnodes == 0) return false;
    struct bvh_ray br;
    struct tri_ray tr;
    bvh_ray_init(&br, r->o, r->d);
    tri_ray_init(&tr, r);
    float tm = tmax > 3e38 ? 3e38f : (float)tmax;
    bool found = false;
    struct bvh_entry stack[BVH_STACK];
    int sp = 1;
    stack[0].node = 0;
    stack[0].count = 0;
    stack[0].tnear = 0;
    while (sp > 0) {
        struct bvh_entry e = stack[--sp];
        if (e.tnear > tm) continue;
        if (e.count) {
            for (uint32_t i = e.node; i < e.node + e.count; i++) {
                if (tri_hit(m, i, &tr, &tm, h)) {
                    found = true;
                    if (any) return true;
                }
            }
            continue;
        }
        const struct bvh4_node *nd = &m->bvh.nodes[e.node];
        float tn[4];
        int mask = bvh4_test(nd, &br, 0, tm, tn);
        sp = bvh4_push_sorted(nd, mask, tn, stack, sp);
    }
    return found;
}

bool mesh_intersect(const struct mesh *m, const ray *r, double tmax, struct mesh_hit *h) {
    return mesh_walk(m, r, tmax, h, false);
}

bool mesh_occluded(const struct mesh *m, const ray *r, double tmax) {
    struct mesh_hit h;
    return mesh_walk(m, r, tmax, &h, true);
}

bool mesh_intersect_brute(const struct mesh *m, const ray *r, double tmax, struct mesh_hit *h) {
    struct tri_ray tr;
    tri_ray_init(&tr, r);
    float tm = tmax > 3e38 ? 3e38f : (float)tmax;
    bool found = false;
    for (uint32_t i = 0; i < m->ntris; i++) found |= tri_hit(m, i, &tr, &tm, h);
    return found;
}

static vec3 vtx(const struct mesh *m, uint32_t i) {
    const float *p = m->pos + 3 * (size_t)i;
    return v3(p[0], p[1], p[2]);
}

vec3 mesh_point(const struct mesh *m, const struct mesh_hit *h) {
    const uint32_t *ix = m->index + 3 * (size_t)h->tri;
    double u = h->u, v = h->v;
    vec3 p = v3_scale(vtx(m, ix[0]), 1.0 - u - v);
    p = v3_madd(p, vtx(m, ix[1]), u);
    return v3_madd(p, vtx(m, ix[2]), v);
}

vec3 mesh_geometric_normal(const struct mesh *m, uint32_t tri) {
    const uint32_t *ix = m->index + 3 * (size_t)tri;
    vec3 a = vtx(m, ix[0]);
    vec3 n = v3_cross(v3_sub(vtx(m, ix[1]), a), v3_sub(vtx(m, ix[2]), a));
    double len = v3_len(n);
    return len > 0 ? v3_scale(n, 1.0 / len) : v3(0, 1, 0);
}

vec3 mesh_shading_normal(const struct mesh *m, const struct mesh_hit *h) {
    if (!m->normal) return mesh_geometric_normal(m, h->tri);
    const uint32_t *ix = m->index + 3 * (size_t)h->tri;
    double u = h->u, v = h->v;
    vec3 n = v3(0, 0, 0);
    const double wgt[3] = {1.0 - u - v, u, v};
    for (int k = 0; k < 3; k++) {
        const float *nn = m->normal + 3 * (size_t)ix[k];
        n = v3_madd(n, v3(nn[0], nn[1], nn[2]), wgt[k]);
    }
    double len = v3_len(n);
    return len > 0 ? v3_scale(n, 1.0 / len) : mesh_geometric_normal(m, h->tri);
}

/* Area-weighted vertex normals (the cross product's length is twice the
 * area, so summing unnormalised face normals weights by area). */
static float *smooth_normals(const float *pos, uint32_t nverts, const uint32_t *index,
                             uint32_t ntris) {
    float *n = calloc((size_t)nverts * 3, sizeof *n);
    if (!n) return NULL;
    for (uint32_t t = 0; t < ntris; t++) {
        const uint32_t *ix = index + 3 * (size_t)t;
        const float *a = pos + 3 * (size_t)ix[0], *b = pos + 3 * (size_t)ix[1],
                    *c = pos + 3 * (size_t)ix[2];
        vec3 fn = v3_cross(v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]),
                           v3(c[0] - a[0], c[1] - a[1], c[2] - a[2]));
        for (int k = 0; k < 3; k++) {
            float *d = n + 3 * (size_t)ix[k];
            d[0] += (float)fn.x;
            d[1] += (float)fn.y;
            d[2] += (float)fn.z;
        }
    }
    for (uint32_t i = 0; i < nverts; i++) {
        float *d = n + 3 * (size_t)i;
        double len = sqrt((double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2]);
        if (len > 0)
            for (int k = 0; k < 3; k++) d[k] = (float)(d[k] / len);
    }
    return n;
}

static struct bbox tri_box(const float *pos, const uint32_t *ix) {
    struct bbox b;
    for (int k = 0; k < 3; k++) {
        float a = pos[3 * (size_t)ix[0] + k], c = pos[3 * (size_t)ix[1] + k],
              d = pos[3 * (size_t)ix[2] + k];
        b.lo[k] = fminf(a, fminf(c, d));
        b.hi[k] = fmaxf(a, fmaxf(c, d));
    }
    return b;
}

enum rayd_status mesh_build(struct mesh *m, float *pos, uint32_t nverts, uint32_t *index,
                            uint32_t ntris, float *normal, float *uv, bool smooth, int threads,
                            struct rayd_error *err) {
    memset(m, 0, sizeof *m);
    m->pos = pos;
    m->nverts = nverts;
    m->index = index;
    m->ntris = ntris;
    m->normal = normal;
    m->uv = uv;
    if (smooth && !normal && !(m->normal = smooth_normals(pos, nverts, index, ntris)))
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for mesh normals");
    if (!smooth && normal) {
        free(m->normal);
        m->normal = NULL;
    }
    struct bbox *boxes = malloc(sizeof *boxes * ((size_t)ntris + 1));
    uint32_t *order = malloc(sizeof *order * ((size_t)ntris + 1));
    uint32_t *sorted = malloc(sizeof *sorted * 3 * ((size_t)ntris + 1));
    enum rayd_status st = RAYD_OK;
    if (!boxes || !order || !sorted) {
        st = err_set(err, RAYD_E_NOMEM, NULL, "out of memory building a mesh of %u triangles",
                     ntris);
    } else {
        for (uint32_t t = 0; t < ntris; t++) boxes[t] = tri_box(pos, index + 3 * (size_t)t);
        st = bvh_build(&m->bvh, boxes, ntris, order, threads, err);
    }
    if (st == RAYD_OK) { /* triangles in leaf order: leaves index them directly */
        for (uint32_t t = 0; t < ntris; t++) memcpy(sorted + 3 * (size_t)t, index + 3 * (size_t)order[t], sizeof *sorted * 3);
        free(m->index);
        m->index = sorted;
        sorted = NULL;
        const struct bbox *b = &m->bvh.bounds;
        m->lo = v3(b->lo[0], b->lo[1], b->lo[2]);
        m->hi = v3(b->hi[0], b->hi[1], b->hi[2]);
    }
    free(boxes);
    free(order);
    free(sorted);
    return st;
}

void mesh_free(struct mesh *m) {
    if (!m) return;
    free(m->pos);
    free(m->normal);
    free(m->uv);
    free(m->index);
    bvh_free(&m->bvh);
    memset(m, 0, sizeof *m);
}

size_t mesh_bytes(const struct mesh *m) {
    size_t b = (size_t)m->nverts * 3 * sizeof(float) + (size_t)m->ntris * 3 * sizeof(uint32_t) +
               (size_t)m->bvh.nnodes * sizeof(struct bvh4_node);
    if (m->normal) b += (size_t)m->nverts * 3 * sizeof(float);
    if (m->uv) b += (size_t)m->nverts * 2 * sizeof(float);
    return b;
}
