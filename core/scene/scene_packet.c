/* scene_packet.c -- the scene's queries for 16 rays at once.
 *
 * A packet walks the top-level BVH with bvh16.h; at a leaf, mesh objects
 * take the packet into their own BVH (mesh_packet.c), untransformed
 * spheres and planes are tested 16 rays at once (the one-ray code's double
 * operations, lane by lane), and every other object is asked ray by ray.
 * Each ray's search keeps its own state (the
 * struct nearest of scene_query.h, its bound), so the order-free rules
 * there give every ray the same hit as scene_intersect: the packet only
 * shares the memory traffic and the node tests.
 *
 * Shadows go by packet when the scene is opaque (a ray is then either
 * blocked or not, whichever blocker is met first); otherwise the product of
 * the filters met would depend on their order, so those rays go one by
 * one.  The shadow rays of a point light ask its light buffer
 * (light_buffer.c) first: when their origins share a few cells of it, the
 * objects listed there are all they can meet, and the walk is skipped.
 * Where the CPU stops at AVX2, scene_packet8.c's packets of 8 answer
 * instead; without either, everything goes one by one.
 *
 * The rays come as an array of rays or, from the renderer, as structure of
 * arrays (struct ray16, the packet's own form: no transposition); then the
 * one-ray fallbacks get their rays made only when one is needed.
 */
#include <string.h>

#include "accel/bvh16.h"
#include "accel/light_buffer.h"
#include "scene/scene.h"
#include "scene/scene_query.h"

LANES_ALIGN const double scene_unbounded16[16] = {
    INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY,
    INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY};

static uint32_t intersect_each(const rayd_scene *s, const ray r[16], const double tmax[16],
                               uint32_t active, struct hit h[16]) {
    uint32_t hit = 0;
    for (int i = 0; i < 16; i++)
        if (active >> i & 1 && scene_intersect(s, &r[i], tmax[i], &h[i])) hit |= 1u << i;
    return hit;
}

static void transmittance_each(const rayd_scene *s, const ray r[16], const double tmax[16],
                               uint32_t active, vec3 out[16]) {
    for (int i = 0; i < 16; i++)
        if (active >> i & 1) out[i] = scene_transmittance(s, &r[i], tmax[i]);
}

#ifdef CPU_AVX512

/* A packet's nearest-hit search: struct nearest of scene_query.h for 16
 * rays as structure of arrays.  The untransformed spheres and planes keep
 * their hits here (leaf, tmax), written out to h at the end; the other
 * objects write h themselves, through a struct nearest made for the ray. */
struct scene16 {
    struct ray16 rd; /* the rays as structure of arrays (the arrays first: cache lines) */
    LANES_ALIGN double tmax[16];
    int64_t best[16];              /* the rank of each ray's hit so far, -1 none */
    const struct object *leaf[16]; /* ... its object, when that hit is in tmax only */
    const rayd_scene *s;
    const ray *r; /* the same rays one by one when given so, else NULL until lane_rays */
    struct hit *h;
    const struct object *base; /* ranks: rank0 + (o - base) */
    long rank0;
    uint32_t kept;   /* the rays whose hit is in leaf and tmax, not h */
    uint64_t visits; /* objects the top level's walk visited, each once a lane (meter.h) */
    ray rbuf[16];
};

/* The rays one by one, for the one-ray code: made from rd when the packet
 * came as structure of arrays. */
static const ray *lane_rays(struct scene16 *q) {
    if (q->r) return q->r;
    for (int i = 0; i < 16; i++) q->rbuf[i] = ray16_get(&q->rd, i);
    return q->r = q->rbuf;
}

/* Ray i's struct nearest, to ask the one-ray code. */
static struct nearest lane_nearest(struct scene16 *q, int i) {
    return (struct nearest){q->s, NULL, &lane_rays(q)[i], &q->h[i], q->base, q->rank0, q->best[i]};
}

/* After a hit of rank best was taken for ray i into h (a new best): its
 * hit is no longer the one kept in leaf and tmax. */
static void lane_taken(struct scene16 *q, int i, long best) {
    if (best == q->best[i]) return;
    q->best[i] = best;
    q->kept &= ~(1u << i);
}

/* sphere_roots's terms for rays 8h..8h+7 of rd against untransformed
 * sphere o, the one-ray code's double operations: oc = o - centre, b =
 * oc . d, c = oc . oc - r2 (r2 the squared radius), nb = -b and the
 * discriminant r2 - |oc - b d|^2 (d is a unit vector). */
CPU_AVX512_INLINE void sphere16_terms(const struct ray16 *rd, const struct object *o, int h,
                                      __m512d *b, __m512d *c, __m512d *nb, __m512d *disc) {
    const vec3 c3 = o->u.sphere.center;
    const double cen[3] = {c3.x, c3.y, c3.z}, rad = o->u.sphere.radius;
    __m512d oc[3], d[3], hv[3];
    __m512d r2 = _mm512_set1_pd(rad * rad);
    for (int k = 0; k < 3; k++) {
        oc[k] = _mm512_sub_pd(_mm512_loadu_pd(rd->o[k] + 8 * h), _mm512_set1_pd(cen[k]));
        d[k] = _mm512_loadu_pd(rd->d[k] + 8 * h);
    }
    *b = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(oc[0], d[0]), _mm512_mul_pd(oc[1], d[1])),
                       _mm512_mul_pd(oc[2], d[2]));
    *c = _mm512_sub_pd(
        _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(oc[0], oc[0]), _mm512_mul_pd(oc[1], oc[1])),
                      _mm512_mul_pd(oc[2], oc[2])),
        r2);
    *nb = _mm512_castsi512_pd(
        _mm512_xor_si512(_mm512_castpd_si512(*b), _mm512_set1_epi64(INT64_MIN))); /* -b */
    for (int k = 0; k < 3; k++) hv[k] = _mm512_add_pd(oc[k], _mm512_mul_pd(d[k], *nb));
    *disc = _mm512_sub_pd(
        r2, _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(hv[0], hv[0]), _mm512_mul_pd(hv[1], hv[1])),
                          _mm512_mul_pd(hv[2], hv[2])));
}

/* sphere_nearest of untransformed sphere o for the rays in lanes, 16 at
 * once: the same double operations lane by lane (sphere_roots's formula,
 * IEEE square root and division).  Returns the rays that hit before their
 * bound, with t; rays whose roots came out NaN (a NaN or infinite input)
 * are left in *odd for the one-ray code, whose fmin treats NaN its own way. */
CPU_AVX512_FN uint32_t sphere16(const struct ray16 *rd, const struct object *o,
                                const double bound[16], uint32_t lanes, double t_out[16],
                                uint32_t *odd) {
    __m512d zero = _mm512_setzero_pd();
    __m512i sign = _mm512_set1_epi64(INT64_MIN);
    uint32_t hit = 0;
    *odd = 0;
    for (int h = 0; h < 2; h++) {
        __mmask8 lm = (__mmask8)(lanes >> 8 * h);
        if (!lm) continue;
        __m512d b, c, nb, disc;
        sphere16_terms(rd, o, h, &b, &c, &nb, &disc);
        __mmask8 in = lm & _mm512_cmp_pd_mask(disc, zero, _CMP_NLT_UQ); /* !(disc < 0) */
        if (!in) continue;
        __m512i sq = _mm512_castpd_si512(_mm512_sqrt_pd(disc));
        __m512d cs = _mm512_castsi512_pd(_mm512_or_si512(
            _mm512_andnot_si512(sign, sq), _mm512_and_si512(sign, _mm512_castpd_si512(b))));
        __m512d q = _mm512_sub_pd(nb, cs);
        __m512d a1 = _mm512_mask_div_pd(q, _mm512_cmp_pd_mask(q, zero, _CMP_NEQ_UQ), c, q);
        __mmask8 nan = in & _mm512_cmp_pd_mask(q, a1, _CMP_UNORD_Q);
        __m512d t0 = _mm512_min_pd(q, a1), t1 = _mm512_max_pd(q, a1);
        __m512d bnd = _mm512_loadu_pd(bound + 8 * h);
        __mmask8 first =
            _mm512_cmp_pd_mask(t0, zero, _CMP_GT_OQ) & _mm512_cmp_pd_mask(t0, bnd, _CMP_LT_OQ);
        __m512d t = _mm512_mask_blend_pd(first, t1, t0);
        __mmask8 ok = in & (__mmask8)~nan & _mm512_cmp_pd_mask(t, zero, _CMP_GT_OQ) &
                      _mm512_cmp_pd_mask(t, bnd, _CMP_LT_OQ);
        _mm512_storeu_pd(t_out + 8 * h, t);
        hit |= (uint32_t)ok << 8 * h;
        *odd |= (uint32_t)nan << 8 * h;
    }
    return hit;
}

/* What sphere16 would say of the rays in lanes against untransformed
 * sphere o (bound the rays' bounds), where that needs no square root: the
 * rays it would find a hit for, and in *rest those it must be asked about.
 * For an origin outside (c > 0), the roots share the sign of -b: b > 0 is a
 * miss; for b < 0 the nearer root, c / q with q = -b + sqrt(disc) >= -b, is
 * positive and at most c / -b, so a hit when that is well below the bound
 * (the factors stand far above the rounding of the division it spares). */
CPU_AVX512_FN uint32_t sphere16_any(const struct ray16 *rd, const struct object *o,
                                    const double bound[16], uint32_t lanes, uint32_t *rest) {
    __m512d zero = _mm512_setzero_pd();
    uint32_t hit = 0;
    *rest = 0;
    for (int h = 0; h < 2; h++) {
        __mmask8 lm = (__mmask8)(lanes >> 8 * h);
        if (!lm) continue;
        __m512d b, c, nb, disc;
        sphere16_terms(rd, o, h, &b, &c, &nb, &disc);
        __mmask8 in = lm & _mm512_cmp_pd_mask(disc, zero, _CMP_NLT_UQ); /* !(disc < 0) */
        __mmask8 outside = _mm512_cmp_pd_mask(c, _mm512_set1_pd(1e-100), _CMP_GT_OQ) &
                           _mm512_cmp_pd_mask(c, _mm512_set1_pd(1e100), _CMP_LT_OQ);
        __mmask8 away = outside & _mm512_cmp_pd_mask(b, zero, _CMP_GT_OQ);
        __m512d bnd = _mm512_loadu_pd(bound + 8 * h);
        __mmask8 sure =
            in & outside & _mm512_cmp_pd_mask(nb, _mm512_set1_pd(1e-100), _CMP_GT_OQ) &
            _mm512_cmp_pd_mask(nb, _mm512_set1_pd(1e100), _CMP_LT_OQ) &
            _mm512_cmp_pd_mask(_mm512_mul_pd(c, _mm512_set1_pd(1.000000001)),
                               _mm512_mul_pd(_mm512_mul_pd(bnd, nb), _mm512_set1_pd(0.999999999)),
                               _CMP_LT_OQ);
        hit |= (uint32_t)sure << 8 * h;
        *rest |= (uint32_t)(in & (__mmask8)~away & (__mmask8)~sure) << 8 * h;
    }
    return hit;
}

/* plane_nearest of untransformed plane o for the rays in lanes, 16 at
 * once, the same double operations; as sphere16 (no ray is odd here: a NaN
 * t fails t > 0 both ways). */
CPU_AVX512_FN uint32_t plane16(const struct ray16 *rd, const struct object *o,
                               const double bound[16], uint32_t lanes, double t_out[16],
                               uint32_t *odd) {
    const vec3 n3 = o->u.plane.normal, p3 = o->u.plane.point;
    const double n[3] = {n3.x, n3.y, n3.z}, pt[3] = {p3.x, p3.y, p3.z};
    __m512d zero = _mm512_setzero_pd();
    uint32_t hit = 0;
    *odd = 0;
    for (int h = 0; h < 2; h++) {
        __mmask8 lm = (__mmask8)(lanes >> 8 * h);
        if (!lm) continue;
        __m512d dn = zero, pn = zero;
        for (int k = 0; k < 3; k++) { /* v3_dot's order: (x + y) + z */
            __m512d nk = _mm512_set1_pd(n[k]);
            __m512d d = _mm512_loadu_pd(rd->d[k] + 8 * h), o_ = _mm512_loadu_pd(rd->o[k] + 8 * h);
            __m512d po = _mm512_sub_pd(_mm512_set1_pd(pt[k]), o_);
            dn = k ? _mm512_add_pd(dn, _mm512_mul_pd(nk, d)) : _mm512_mul_pd(nk, d);
            pn = k ? _mm512_add_pd(pn, _mm512_mul_pd(nk, po)) : _mm512_mul_pd(nk, po);
        }
        __mmask8 in = lm & _mm512_cmp_pd_mask(dn, zero, _CMP_NEQ_UQ);
        /* t = pn / dn > 0 needs pn and dn of one sign (a shadow ray leaving
         * the floor has not): else no division */
        __mmask8 pos =
            _mm512_cmp_pd_mask(pn, zero, _CMP_GT_OQ) & _mm512_cmp_pd_mask(dn, zero, _CMP_GT_OQ);
        __mmask8 neg =
            _mm512_cmp_pd_mask(pn, zero, _CMP_LT_OQ) & _mm512_cmp_pd_mask(dn, zero, _CMP_LT_OQ);
        if (!(in & (pos | neg))) continue;
        __m512d t = _mm512_div_pd(pn, dn);
        __m512d bnd = _mm512_loadu_pd(bound + 8 * h);
        __mmask8 ok =
            in & _mm512_cmp_pd_mask(t, zero, _CMP_GT_OQ) & _mm512_cmp_pd_mask(t, bnd, _CMP_LT_OQ);
        _mm512_storeu_pd(t_out + 8 * h, t);
        hit |= (uint32_t)ok << 8 * h;
    }
    return hit;
}

/* The kinds tested 16 wide, when untransformed. */
static bool simple16(const struct object *o) {
    return (o->kind == SHAPE_SPHERE || o->kind == SHAPE_PLANE) && o->xform < 0;
}

CPU_AVX512_FN uint32_t simple16_hit(const struct scene16 *q, const struct object *o,
                                    const double bound[16], uint32_t lanes, double t[16],
                                    uint32_t *odd) {
    return o->kind == SHAPE_SPHERE ? sphere16(&q->rd, o, bound, lanes, t, odd)
                                   : plane16(&q->rd, o, bound, lanes, t, odd);
}

/* nearest_bound for untransformed object o (rank) and the 16 rays: just
 * past tmax (the next double up) where o would win a tie with the best hit
 * so far. */
CPU_AVX512_FN void simple_bounds16(const struct scene16 *q, long rank, double bound[16]) {
    __m512i rk = _mm512_set1_epi64(rank), one = _mm512_set1_epi64(1);
    __m512d zero = _mm512_setzero_pd(), inf = _mm512_set1_pd(INFINITY);
    for (int k = 0; k < 16; k += 8) {
        __m512d tm = _mm512_loadu_pd(q->tmax + k);
        __mmask8 tie = _mm512_cmpgt_epi64_mask(_mm512_loadu_si512(q->best + k), rk);
        tie &= _mm512_cmp_pd_mask(tm, zero, _CMP_GE_OQ) & _mm512_cmp_pd_mask(tm, inf, _CMP_NEQ_OQ);
        __m512i bits = _mm512_castpd_si512(tm), up = _mm512_mask_add_epi64(bits, tie, bits, one);
        _mm512_storeu_pd(bound + k, _mm512_castsi512_pd(up));
    }
}

/* nearest_take of untransformed object o's hits t (the rays in hit): kept
 * in tmax, best and leaf. */
CPU_AVX512_FN void simple_take16(struct scene16 *q, const struct object *o, long rank,
                                 const double t[16], uint32_t hit) {
    __m512i rk = _mm512_set1_epi64(rank), leaf = _mm512_set1_epi64((int64_t)(intptr_t)o);
    /* blends and whole stores, not masked stores: a later load of these
     * could not be forwarded from a masked store and would wait for it */
    for (int k = 0; hit && k < 16; k += 8) {
        __m512d tt = _mm512_loadu_pd(t + k), tm = _mm512_loadu_pd(q->tmax + k);
        __mmask8 take = (__mmask8)(hit >> k) & _mm512_cmp_pd_mask(tt, tm, _CMP_NGT_UQ);
        __m512i best = _mm512_loadu_si512(q->best + k), lf = _mm512_loadu_si512(q->leaf + k);
        _mm512_storeu_pd(q->tmax + k, _mm512_mask_blend_pd(take, tm, tt));
        _mm512_storeu_si512(q->best + k, _mm512_mask_blend_epi64(take, best, rk));
        _mm512_storeu_si512((void *)(q->leaf + k), _mm512_mask_blend_epi64(take, lf, leaf));
        q->kept |= (uint32_t)take << k;
    }
}

/* An untransformed mesh o for the rays in lanes, nearest hit: what the
 * general case below does (nearest_bound, object_mesh_hit, nearest_take),
 * without a struct nearest for each ray, nor the rays one by one that it
 * needs: the bounds are simple_bounds16's, and the rays stay in q->rd. */
CPU_AVX512_FN void mesh_nearest16(struct scene16 *q, const struct object *o, uint32_t lanes) {
    long rank = q->rank0 + (long)(o - q->base);
    LANES_ALIGN double bound[16];
    simple_bounds16(q, rank, bound);
    struct mesh_hit mh[16];
    uint32_t hit = mesh16_intersect(&q->s->meshes[o->u.mesh.id], &q->rd, bound, lanes, mh);
    for (; hit; hit &= hit - 1) { /* straight into h: no copy of a struct hit to wait on */
        int i = __builtin_ctz(hit);
        if (!object_mesh_nearer(&mh[i], 1, bound[i]) || (double)mh[i].t > q->tmax[i]) continue;
        q->tmax[i] = object_mesh_fill(o, NULL, &mh[i], 1, &q->h[i]);
        lane_taken(q, i, rank);
    }
}

/* Object o for the rays in lanes, nearest hit: meshes as a packet. */
CPU_AVX512_FN void visit_nearest16(struct scene16 *q, const struct object *o, uint32_t lanes) {
    if (simple16(o)) { /* object_hit and nearest_take, 16 wide */
        long rank = q->rank0 + (long)(o - q->base);
        LANES_ALIGN double bound[16];
        LANES_ALIGN double t[16];
        simple_bounds16(q, rank, bound);
        uint32_t odd, hit = simple16_hit(q, o, bound, lanes, t, &odd);
        for (; odd; odd &= odd - 1) {
            int i = __builtin_ctz(odd);
            struct nearest c = lane_nearest(q, i);
            nearest_visit(&c, o, &q->tmax[i]);
            lane_taken(q, i, c.best);
        }
        simple_take16(q, o, rank, t, hit); /* t < bound already: object_hit's tail */
        return;
    }
    if (o->kind == SHAPE_MESH && o->xform < 0) {
        mesh_nearest16(q, o, lanes);
        return;
    }
    if (o->kind != SHAPE_MESH) {
        for (; lanes; lanes &= lanes - 1) {
            int i = __builtin_ctz(lanes);
            struct nearest c = lane_nearest(q, i);
            nearest_visit(&c, o, &q->tmax[i]);
            lane_taken(q, i, c.best);
        }
        return;
    }
    ray lr[16]; /* a moved mesh: the rays in its space */
    double bound[16], scale[16], lmax[16];
    for (uint32_t m = lanes; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        struct nearest c = lane_nearest(q, i);
        bound[i] = nearest_bound(&c, o, q->tmax[i]);
        lr[i] = object_ray_xform(q->s, o, &lane_rays(q)[i], &scale[i]);
        lmax[i] = object_space_bound(bound[i], scale[i]);
    }
    struct mesh_hit mh[16];
    struct ray16 lrd;
    ray16_from_rays(&lrd, lr, lanes);
    uint32_t hit = mesh16_intersect(&q->s->meshes[o->u.mesh.id], &lrd, lmax, lanes, mh);
    for (; hit; hit &= hit - 1) { /* the rest of object_hit, then nearest_take */
        int i = __builtin_ctz(hit);
        struct hit h;
        if (!object_mesh_hit(o, NULL, &mh[i], scale[i], &bound[i], &h)) continue;
        struct nearest c = lane_nearest(q, i);
        nearest_take(&c, o, bound[i], &h, &q->tmax[i]);
        lane_taken(q, i, c.best);
    }
}

/* Object o for the rays in lanes, any hit: the rays it blocks (the scene
 * is opaque). */
CPU_AVX512_FN uint32_t visit_any16(struct scene16 *q, const struct object *o, uint32_t lanes) {
    uint32_t blocked = 0;
    if (simple16(o)) { /* object_filter, 16 wide */
        LANES_ALIGN double t[16];
        uint32_t odd = 0;
        if (o->kind == SHAPE_SPHERE) { /* most rays settled without a square root */
            blocked = sphere16_any(&q->rd, o, q->tmax, lanes, &lanes);
            if (lanes) blocked |= sphere16(&q->rd, o, q->tmax, lanes, t, &odd);
        } else {
            blocked = plane16(&q->rd, o, q->tmax, lanes, t, &odd);
        }
        lanes = odd; /* left to the one-ray code below */
    }
    if (o->kind == SHAPE_MESH && o->xform < 0) /* the rays as they are */
        return mesh16_occluded(&q->s->meshes[o->u.mesh.id], &q->rd, q->tmax, lanes);
    if (o->kind == SHAPE_MESH) { /* moved: the rays in its space */
        ray lr[16];
        double lmax[16];
        for (uint32_t m = lanes; m; m &= m - 1) {
            int i = __builtin_ctz(m);
            double scale;
            lr[i] = object_ray_xform(q->s, o, &lane_rays(q)[i], &scale);
            lmax[i] = q->tmax[i] * scale;
        }
        struct ray16 lrd;
        ray16_from_rays(&lrd, lr, lanes);
        return mesh16_occluded(&q->s->meshes[o->u.mesh.id], &lrd, lmax, lanes);
    }
    for (; lanes; lanes &= lanes - 1) {
        int i = __builtin_ctz(lanes);
        vec3 trans = v3(1, 1, 1);
        if (!object_filter(q->s, o, &lane_rays(q)[i], q->tmax[i], &trans)) blocked |= 1u << i;
    }
    return blocked;
}

/* The rays' bounds, lanes outside active copying the first one in it (every
 * lane then holds a number the walk may read). */
CPU_AVX512_FN void bounds16_load(double out[16], const double tmax[16], uint32_t active) {
    __m512d first = _mm512_set1_pd(tmax[__builtin_ctz(active)]);
    for (int k = 0; k < 16; k += 8)
        _mm512_storeu_pd(out + k, _mm512_mask_loadu_pd(first, (__mmask8)(active >> k), tmax + k));
}

/* Each ray's float bound for the node tests, as objects_walk has it. */
CPU_AVX512_FN __m512 node_bounds16(const double tmax[16]) {
    __m512d big = _mm512_set1_pd(3e38);
    __m512d lo = _mm512_loadu_pd(tmax), hi = _mm512_loadu_pd(tmax + 8);
    /* tmax > 3e38 ? 3e38f : (float)tmax, the rounding to nearest of a cast */
    lo = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(lo, big, _CMP_GT_OQ), lo, big);
    hi = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(hi, big, _CMP_GT_OQ), hi, big);
    return _mm512_insertf32x8(_mm512_castps256_ps512(_mm512_cvtpd_ps(lo)), _mm512_cvtpd_ps(hi), 1);
}

CPU_AVX512_FN __mmask16 tlas_nearest(void *ctx, uint32_t first, uint32_t count, __mmask16 lanes,
                                     __m512 *tm, float far_most) {
    (void)far_most; /* 4-wide nodes: no culling test */
    struct scene16 *q = ctx;
    q->visits += (uint64_t)count * (uint64_t)__builtin_popcount(lanes);
    for (uint32_t k = first; k < first + count; k++) visit_nearest16(q, &q->s->objs[k], lanes);
    *tm = node_bounds16(q->tmax);
    return 0;
}

CPU_AVX512_FN __mmask16 tlas_any(void *ctx, uint32_t first, uint32_t count, __mmask16 lanes,
                                 __m512 *tm, float far_most) {
    (void)far_most; /* 4-wide nodes: no culling test */
    struct scene16 *q = ctx;
    (void)tm;
    __mmask16 blocked = 0;
    for (uint32_t k = first; k < first + count && blocked != lanes; k++) {
        __mmask16 open = lanes & (__mmask16)~blocked;
        q->visits += (uint64_t)__builtin_popcount(open);
        blocked |= (__mmask16)visit_any16(q, &q->s->objs[k], open);
    }
    return blocked;
}

/* The nearest hits of the rays in q->rd: into h, or for the untransformed
 * spheres and planes into simple when given. */
CPU_AVX512_FN uint32_t intersect16(struct scene16 *q, const double tmax[16], uint32_t active,
                                   struct hit h[16], struct hit16 *simple) {
    /* q comes with s, r and rd set; the rest is set here before it is read
     * (the 3 KB are not zeroed on purpose): */
    // cppcheck-suppress ctuuninitvar
    const rayd_scene *s = q->s;
    q->h = h;
    bounds16_load(q->tmax, tmax, active);
    for (int k = 0; k < 16; k += 8) {
        _mm512_storeu_si512(q->best + k, _mm512_set1_epi64(-1));
        _mm512_storeu_si512((void *)(q->leaf + k), _mm512_setzero_si512());
    }
    q->kept = 0;
    q->base = s->planes, q->rank0 = 0;
    for (int32_t k = 0; k < s->nplanes; k++) visit_nearest16(q, &s->planes[k], active);
    q->base = s->objs, q->rank0 = s->nplanes;
    if (s->nobjs == 1) {
        visit_nearest16(q, &s->objs[0], active);
    } else if (s->nobjs > 1) {
        struct bvh16_ray br;
        bvh16_ray_init(&br, &q->rd, 4);
        __m512 tm = node_bounds16(q->tmax);
        q->visits = 0;
        bvh16_walk(s->tlas.nodes, 4, NULL, 0, &br, &tm, (__mmask16)active, tlas_nearest, NULL, q,
                   true);
        meter_visits(q->visits,
                     (uint64_t)__builtin_popcount(active)); /* a stop: at the next look */
    }
    uint32_t kept = q->kept & active;
    if (simple) {
        memcpy(simple->t, q->tmax, sizeof simple->t);
        memcpy(simple->leaf, q->leaf, sizeof simple->leaf);
        simple->lanes = kept;
    } else {
        for (uint32_t m = kept; m; m &= m - 1) { /* as nearest_take would have */
            int i = __builtin_ctz(m);            /* (a sphere's or plane's: no mh) */
            h[i].t = q->tmax[i], h[i].leaf = q->leaf[i], h[i].outer = NULL;
            h[i].part = h[i].orient = 0;
        }
    }
    __m512i none = _mm512_set1_epi64(-1);
    uint32_t hit = _mm512_cmpgt_epi64_mask(_mm512_loadu_si512(q->best), none) |
                   (uint32_t)_mm512_cmpgt_epi64_mask(_mm512_loadu_si512(q->best + 8), none) << 8;
    return hit & active;
}

CPU_AVX512_FN uint32_t intersect16_aos(const rayd_scene *s, const ray r[16], const double tmax[16],
                                       uint32_t active, struct hit h[16]) {
    struct scene16 q; /* every field used is set: no zeroing of its 3 KB */
    q.s = s;
    q.r = r;
    ray16_from_rays(&q.rd, r, active);
    return intersect16(&q, tmax, active, h, NULL);
}

CPU_AVX512_FN uint32_t intersect16_soa(const rayd_scene *s, const struct ray16 *r,
                                       const double tmax[16], uint32_t active, struct hit h[16],
                                       struct hit16 *simple) {
    struct scene16 q;
    q.s = s;
    q.r = NULL;
    ray16_from_arrays(&q.rd, r->o, r->d, active);
    return intersect16(&q, tmax, active, h, simple);
}

/* For face coordinates (u, v) = w of face f: the 2 x 2 cells nearest w,
 * from cell ij[0], ij[1] on, and the stretch [lo, hi) of u and of v they
 * cover -- unbounded on the side of cells beyond the rectangle.  Without
 * a branch: which cells is as good as a coin toss. */
CPU_AVX512_FN void lb_span(const struct light_face *f, __m128d w, int32_t ij[2], __m128d *lo,
                           __m128d *hi) {
    __m128d w0 = _mm_set_pd(f->v0, f->u0), sw = _mm_set_pd(f->sv, f->su);
    __m128d cw = _mm_set_pd(f->cv, f->cu), n = _mm_set_pd(f->nv, f->nu), two = _mm_set1_pd(2);
    /* the cell w is in, less one if w is in its lower half */
    __m128d c = _mm_floor_pd(_mm_sub_pd(_mm_mul_pd(_mm_sub_pd(w, w0), sw), _mm_set1_pd(0.5)));
    c = _mm_min_pd(_mm_max_pd(c, _mm_set1_pd(-2)), n);
    __m128d at_lo = _mm_add_pd(w0, _mm_mul_pd(c, cw));
    __m128d at_hi = _mm_add_pd(w0, _mm_mul_pd(_mm_add_pd(c, two), cw));
    *lo = _mm_blendv_pd(at_lo, _mm_set1_pd(-INFINITY), _mm_cmplt_pd(c, _mm_setzero_pd()));
    *hi = _mm_blendv_pd(at_hi, _mm_set1_pd(INFINITY), _mm_cmpgt_pd(_mm_add_pd(c, two), n));
    __m128i k = _mm_cvttpd_epi32(c);
    ij[0] = _mm_cvtsi128_si32(k), ij[1] = _mm_cvtsi128_si32(_mm_srli_si128(k, 4));
}

/* The objects of light buffer b (light_buffer.h) that can stop the shadow
 * rays in lanes open of rd, as (*ids)[0..*n) (at most LB_MAX_TEST; the
 * buffer's own list, no copy): those
 * of the 2 x 2 cells around the first ray's (or the stretch beyond the
 * rectangle, which holds none) when all the rays' origins, seen from the
 * light through one face, fall in them, and the rays leave from within the
 * buffer's reach.  False otherwise: then the BVH must be walked.  The rays
 * are checked against the cells' edges by multiplying, not dividing: a few
 * roundings off at an edge, which LB_MARGIN covers. */
#define LB_MAX_TEST 16
CPU_AVX512_FN bool shadow_candidates(const struct light_buffer *b, const struct ray16 *rd,
                                     uint32_t open, const uint32_t **ids, int *n) {
    int i0 = __builtin_ctz(open);
    const double at[3] = {b->at.x, b->at.y, b->at.z};
    double r0[3], m0[3];
    for (int k = 0; k < 3; k++) r0[k] = rd->o[k][i0] - at[k], m0[k] = fabs(r0[k]);
    int a = m0[0] >= m0[1] && m0[0] >= m0[2] ? 0 : m0[1] >= m0[2] ? 1 : 2;
    int bx = (a + 1) % 3, cx = (a + 2) % 3;
    double sg = r0[a] < 0 ? -1.0 : 1.0, ca0 = r0[a] * sg;
    const struct light_face *f = &b->face[2 * a + (r0[a] < 0)];
    if (!(ca0 > 0)) return false;
    __m128d lo = _mm_set1_pd(-INFINITY), hi = _mm_set1_pd(INFINITY);
    int32_t ij[2] = {0, 0};
    if (f->nu)
        lb_span(f, _mm_mul_pd(_mm_set_pd(r0[cx], r0[bx]), _mm_set1_pd(1 / ca0)), ij, &lo, &hi);
    double ulo = _mm_cvtsd_f64(lo), uhi = _mm_cvtsd_f64(hi);
    double vlo = _mm_cvtsd_f64(_mm_unpackhi_pd(lo, lo)),
           vhi = _mm_cvtsd_f64(_mm_unpackhi_pd(hi, hi));
    int32_t ci = ij[0], cj = ij[1];
    __m512d zero = _mm512_setzero_pd(), reach = _mm512_set1_pd(b->reach);
    for (int h = 0; h < 16; h += 8) {
        __mmask8 lm = (__mmask8)(open >> h);
        if (!lm) continue;
        __m512d r[3];
        __mmask8 ok = lm;
        for (int k = 0; k < 3; k++) {
            __m512d o = _mm512_loadu_pd(rd->o[k] + h);
            ok &= _mm512_cmp_pd_mask(_mm512_abs_pd(o), reach, _CMP_LE_OQ);
            r[k] = _mm512_sub_pd(o, _mm512_set1_pd(at[k]));
        }
        __m512d ca = _mm512_mul_pd(r[a], _mm512_set1_pd(sg));
        ok &= _mm512_cmp_pd_mask(ca, zero, _CMP_GT_OQ) &
              _mm512_cmp_pd_mask(ca, _mm512_abs_pd(r[bx]), _CMP_GE_OQ) &
              _mm512_cmp_pd_mask(ca, _mm512_abs_pd(r[cx]), _CMP_GE_OQ) &
              _mm512_cmp_pd_mask(r[bx], _mm512_mul_pd(_mm512_set1_pd(ulo), ca), _CMP_GE_OQ) &
              _mm512_cmp_pd_mask(r[bx], _mm512_mul_pd(_mm512_set1_pd(uhi), ca), _CMP_LT_OQ) &
              _mm512_cmp_pd_mask(r[cx], _mm512_mul_pd(_mm512_set1_pd(vlo), ca), _CMP_GE_OQ) &
              _mm512_cmp_pd_mask(r[cx], _mm512_mul_pd(_mm512_set1_pd(vhi), ca), _CMP_LT_OQ);
        if (ok != lm) return false;
    }
    *n = 0;
    if (!f->nu || ci < -1 || ci >= f->nu || cj < -1 || cj >= f->nv) return true; /* none */
    uint32_t q = (uint32_t)(cj + 1) * (uint32_t)(f->nu + 1) + (uint32_t)(ci + 1);
    uint32_t k0 = f->qstart[q], k1 = f->qstart[q + 1];
    if (k1 - k0 > LB_MAX_TEST) return false;
    *ids = f->quad + k0;
    *n = (int)(k1 - k0);
    return true;
}

/* The shadow rays in q->rd: the mask of those that get through.  With
 * light buffer b (else NULL), the objects it names for them stand in for
 * the walk where it can name them. */
CPU_AVX512_FN uint32_t transmittance16(struct scene16 *q, const double tmax[16], uint32_t active,
                                       const struct light_buffer *b) {
    /* as in intersect16: */
    // cppcheck-suppress ctuuninitvar
    const rayd_scene *s = q->s;
    bounds16_load(q->tmax, tmax, active);
    uint32_t open = active;
    const uint32_t *ids = NULL;
    int n;
    for (int32_t k = 0; k < s->nplanes && open; k++) open &= ~visit_any16(q, &s->planes[k], open);
    if (open && s->nobjs == 1) {
        open &= ~visit_any16(q, &s->objs[0], open);
    } else if (open && b && b->ok && shadow_candidates(b, &q->rd, open, &ids, &n)) {
        for (int k = 0; k < n && open; k++) open &= ~visit_any16(q, &s->objs[ids[k]], open);
    } else if (open && s->nobjs > 1) {
        struct bvh16_ray br;
        bvh16_ray_init(&br, &q->rd, 4);
        __m512 tm = node_bounds16(q->tmax);
        uint64_t lanes = (uint64_t)__builtin_popcount(open);
        q->visits = 0;
        open &= ~(uint32_t)bvh16_walk(s->tlas.nodes, 4, NULL, 0, &br, &tm, (__mmask16)open,
                                      tlas_any, NULL, q, false);
        meter_visits(q->visits, lanes);
    }
    return open;
}

CPU_AVX512_FN void transmittance16_aos(const rayd_scene *s, const ray r[16], const double tmax[16],
                                       uint32_t active, vec3 out[16]) {
    struct scene16 q; /* every field used is set: no zeroing of its 3 KB */
    q.s = s;
    q.r = r;
    ray16_from_rays(&q.rd, r, active);
    uint32_t open = transmittance16(&q, tmax, active, NULL);
    for (int i = 0; i < 16; i++)
        if (active >> i & 1) out[i] = open >> i & 1 ? v3(1, 1, 1) : v3(0, 0, 0);
}

CPU_AVX512_FN void transmittance16_soa(const rayd_scene *s, const struct light_buffer *b,
                                       const double o[3][16], const double d[3][16],
                                       const double tmax[16], uint32_t active, double out[3][16]) {
    struct scene16 q;
    q.s = s;
    q.r = NULL;
    ray16_from_arrays(&q.rd, o, d, active);
    __mmask8 open[2];
    uint32_t got = transmittance16(&q, tmax, active, b);
    open[0] = (__mmask8)got, open[1] = (__mmask8)(got >> 8);
    for (int k = 0; k < 3; k++)
        for (int h = 0; h < 2; h++)
            _mm512_storeu_pd(out[k] + 8 * h, _mm512_maskz_mov_pd(open[h], _mm512_set1_pd(1)));
}

#endif

#ifdef CPU_AVX512
/* Whether scene_packet8.c's packets run (no AVX-512 here, but AVX2): they
 * pay where they meet meshes (8 rays a triangle test) or walk a top level
 * of many objects together; a few objects of other kinds (a scene the
 * one-ray walk tests all at once, s->flat) are met as fast ray by ray:
 * whitted.json rendered 2.5% slower by packet. */
static bool packets8(const rayd_scene *s) {
    return !s->brute && (s->nmeshes > 0 || !s->flat) && cpu_avx2();
}
#endif

uint32_t scene_intersect16(const rayd_scene *s, const ray r[16], const double tmax[16],
                           uint32_t active, struct hit h[16]) {
    if (!active) return 0;
#ifdef CPU_AVX512
    if (!s->brute && cpu_avx512()) return intersect16_aos(s, r, tmax, active, h);
    if (packets8(s)) {
        struct ray16 rd;
        ray16_fill(&rd, r, active);
        return scene8_intersect(s, &rd, r, tmax, active, h);
    }
#endif
    return intersect_each(s, r, tmax, active, h);
}

uint32_t scene_intersect16_soa(const rayd_scene *s, const struct ray16 *r, const double tmax[16],
                               uint32_t active, struct hit h[16], struct hit16 *simple) {
    if (simple) simple->lanes = 0;
    if (!active) return 0;
#ifdef CPU_AVX512
    if (!s->brute && cpu_avx512()) return intersect16_soa(s, r, tmax, active, h, simple);
    if (packets8(s)) {
        struct ray16 rd = *r; /* its lanes outside active may hold anything */
        ray16_fill_rest(&rd, active);
        return scene8_intersect(s, &rd, NULL, tmax, active, h);
    }
#endif
    ray each[16];
    for (int i = 0; i < 16; i++)
        if (active >> i & 1) each[i] = ray16_get(r, i);
    return intersect_each(s, each, tmax, active, h);
}

void scene_transmittance16(const rayd_scene *s, const ray r[16], const double tmax[16],
                           uint32_t active, vec3 out[16]) {
    if (!active) return;
#ifdef CPU_AVX512
    if (!s->brute && s->opaque && cpu_avx512()) {
        transmittance16_aos(s, r, tmax, active, out);
        return;
    }
    if (s->opaque && packets8(s)) {
        struct ray16 rd;
        ray16_fill(&rd, r, active);
        uint32_t blocked = scene8_blocked(s, &rd, r, tmax, active);
        for (int i = 0; i < 16; i++)
            if (active >> i & 1) out[i] = blocked >> i & 1 ? v3(0, 0, 0) : v3(1, 1, 1);
        return;
    }
#endif
    transmittance_each(s, r, tmax, active, out);
}

void scene_transmittance16_soa(const rayd_scene *s, int light, const double o[3][16],
                               const double d[3][16], const double tmax[16], uint32_t active,
                               double out[3][16]) {
    (void)light; /* for the light buffers of the AVX-512 code */
#ifdef CPU_AVX512
    if (active && !s->brute && s->opaque && cpu_avx512()) {
        const struct light_buffer *b =
            light >= 0 && s->light_buffers ? &s->light_buffers[light] : NULL;
        transmittance16_soa(s, b, o, d, tmax, active, out);
        return;
    }
    if (active && s->opaque && packets8(s)) {
        struct ray16 rd;
        memcpy(rd.o, o, sizeof rd.o);
        memcpy(rd.d, d, sizeof rd.d);
        ray16_fill_rest(&rd, active);
        uint32_t open = active & ~scene8_blocked(s, &rd, NULL, tmax, active);
        for (int k = 0; k < 3; k++)
            for (int i = 0; i < 16; i++) out[k][i] = open >> i & 1 ? 1 : 0;
        return;
    }
#endif
    for (int i = 0; i < 16; i++) {
        vec3 t = v3(0, 0, 0);
        if (active >> i & 1) {
            ray r = {v3(o[0][i], o[1][i], o[2][i]), v3(d[0][i], d[1][i], d[2][i])};
            t = scene_transmittance(s, &r, tmax[i]);
        }
        out[0][i] = t.x, out[1][i] = t.y, out[2][i] = t.z;
    }
}
