/* test_node_tests.c -- the BVH walks' node tests never lose a box a ray
 * enters: the one-ray tests, the packets' child tests and their interval
 * culls, each where this CPU runs it, against exact answers in double. */
#include <math.h>
#include <string.h>

#include "accel/bvh16.h"
#include "accel/bvh_rays8.h"
#include "check.h"

#ifdef CPU_AVX512
/* A culling trial's tallies: children tested, culled, culled though a
 * ray enters them, and rays of a one-origin packet (which takes a child
 * with the cull's bound on its rays' entries) entering before that bound. */
struct cull_count {
    uint32_t tested, culled, wrong, early;
};

/* bvh16_cull against bvh16_child on node nd for the 16 rays q. */
CPU_AVX512_FN void cull_check16(const struct bvh8_node *nd, const struct ray16 *q,
                                const float tm[16], unsigned lanes, struct cull_count *n) {
    struct bvh16_ray r;
    bvh16_ray_init(&r, q, 8);
    if (!r.ia) return; /* the walk culls only such packets */
    __m512 tmax = _mm512_loadu_ps(tm);
    __m256 box_tn;
    unsigned keep =
        bvh16_cull((const char *)nd, &r, bvh16_far_most(tmax, (__mmask16)lanes), &box_tn);
    for (int c = 0; c < 7; c++) {
        __m512 tn;
        /* the walk's test (fused, as r has it) and the unfused one */
        __mmask16 in = bvh16_child((const char *)nd, 8, c, &r, tmax, (__mmask16)lanes, &tn);
        __m512 tn_fused = tn;
        __mmask16 in_fused = in;
        r.fused = false;
        __mmask16 in_plain = bvh16_child((const char *)nd, 8, c, &r, tmax, (__mmask16)lanes, &tn);
        in |= in_plain;
        r.fused = true;
        if (r.one_origin && (keep >> c & 1)) { /* the box's bound before each ray's entry */
            float b[8];
            _mm256_storeu_ps(b, box_tn);
            __m512 bound = _mm512_set1_ps(b[c]);
            n->early +=
                __builtin_popcount(_mm512_mask_cmp_ps_mask(in_fused, bound, tn_fused, _CMP_GT_OQ) |
                                   _mm512_mask_cmp_ps_mask(in_plain, bound, tn, _CMP_GT_OQ));
        }
        n->tested += 1;
        n->culled += !(keep >> c & 1);
        n->wrong += in && !(keep >> c & 1);
    }
}

/* rays8_cull against rays8_child on node nd for each half of q. */
CPU_AVX2_FN void cull_check8(const struct bvh8_node *nd, const struct ray16 *q, const float tm[16],
                             unsigned lanes, struct cull_count *n) {
    for (int h = 0; h < 2; h++) {
        unsigned half = lanes >> 8 * h & 0xffu;
        if (!half) continue;
        struct rays8_ray r;
        rays8_init(&r, q, h, lanes, 8);
        if (!r.ia) continue;
        __m256 tmax = _mm256_loadu_ps(tm + 8 * h);
        __m256 box_tn;
        unsigned keep = rays8_cull((const char *)nd, &r, tmax, half, &box_tn);
        for (int c = 0; c < 7; c++) {
            __m256 tn;
            unsigned in = rays8_child((const char *)nd, 8, c, &r, tmax, half, &tn);
            __m256 tn_fused = tn;
            unsigned in_fused = in;
            r.fused = false;
            unsigned in_plain = rays8_child((const char *)nd, 8, c, &r, tmax, half, &tn);
            in |= in_plain;
            r.fused = true;
            if (r.one_origin && (keep >> c & 1)) { /* the box's bound before each ray's entry */
                float b[8];
                _mm256_storeu_ps(b, box_tn);
                __m256 bound = _mm256_set1_ps(b[c]);
                n->early += (unsigned)__builtin_popcount(
                    (in_fused & rays8_bits(_mm256_cmp_ps(bound, tn_fused, _CMP_GT_OQ))) |
                    (in_plain & rays8_bits(_mm256_cmp_ps(bound, tn, _CMP_GT_OQ))));
            }
            n->tested += 1;
            n->culled += !(keep >> c & 1);
            n->wrong += in && !(keep >> c & 1);
        }
    }
}

/* Random 8-wide nodes (boxes of any size, some flat, some slots empty)
 * and random packets (one origin or many, each axis one sign, odd
 * bounds) for the culling tests. */
static void cull_trial(uint32_t *s, struct bvh8_node *nd, struct ray16 *q, float tm[16],
                       unsigned *lanes) {
    memset(nd, 0, sizeof *nd);
    for (int c = 0; c < 8; c++)
        for (int k = 0; k < 3; k++) {
            *s = *s * 1664525u + 1013904223u;
            float lo = (float)((*s >> 8) % 2000) / 100.0f - 10.0f;
            *s = *s * 1664525u + 1013904223u;
            float ext = (*s >> 8) % 5 == 0 ? 0.0f : (float)((*s >> 8) % 600) / 100.0f;
            nd->lo[k][c] = c == 7 ? INFINITY : lo;
            nd->hi[k][c] = c == 7 ? -INFINITY : lo + ext;
        }
    static const float bounds[6] = {INFINITY, 0.0f, 1e-3f, 4.0f, 3e38f, NAN};
    double sign[3];
    for (int k = 0; k < 3; k++) sign[k] = (*s >> (4 + k)) & 1 ? -1 : 1;
    bool one_origin = (*s >> 9) & 1;
    for (int i = 0; i < 16; i++) {
        for (int k = 0; k < 3; k++) {
            *s = *s * 1664525u + 1013904223u;
            double u = (double)(*s >> 8) / 16777216.0;
            q->o[k][i] = one_origin && i ? q->o[k][0] : u * 30 - 15;
            *s = *s * 1664525u + 1013904223u;
            double d = (double)(*s >> 8) / 16777216.0;
            q->d[k][i] = sign[k] * (d < 0.01 ? 0 : d);
        }
        *s = *s * 1664525u + 1013904223u;
        tm[i] = bounds[(*s >> 8) % 6 == 5 ? 5 : (*s >> 8) % 5];
    }
    *lanes = (*s >> 3 | 1) & 0xffffu;
}
#endif

/* bvh16_cull and rays8_cull, the packet walks' interval tests on 8-wide
 * nodes, may drop only children that no ray of the packet enters: else a
 * packet would miss a hit its rays find alone.  A packet from one point
 * goes into a child with the cull's bound on its rays' entries, which must
 * then be at most each ray's own (else its walk would drop the child
 * after a hit farther than the bound but nearer than the child).  Each runs where the CPU
 * has its instructions. */
static void test_packet_cull_keeps_every_entered_child(void) {
#ifdef CPU_AVX512
    if (!cpu_avx2()) {
        printf("  skipped: no AVX2 here\n");
        return;
    }
    uint32_t s = 4242;
    struct cull_count n16 = {0, 0, 0, 0}, n8 = {0, 0, 0, 0};
    for (int n = 0; n < 20000; n++) {
        struct bvh8_node nd;
        struct ray16 q;
        float tm[16];
        unsigned lanes;
        cull_trial(&s, &nd, &q, tm, &lanes);
        if (cpu_avx512()) cull_check16(&nd, &q, tm, lanes, &n16);
        cull_check8(&nd, &q, tm, lanes, &n8);
    }
    const struct cull_count *each[2] = {&n16, &n8};
    for (int w = cpu_avx512() ? 0 : 1; w < 2; w++) {
        const struct cull_count *n = each[w];
        printf("  %s: %u children tested, %u culled\n", w ? "8 rays (AVX2)" : "16 rays (AVX-512)",
               n->tested, n->culled);
        CHECK(n->wrong == 0, "%u of %u children culled that a ray enters", n->wrong, n->tested);
        CHECK(n->early == 0, "%u rays enter a child before the bound one-origin packets keep",
              n->early);
        CHECK(n->culled > n->tested / 10, "only %u of %u children culled", n->culled, n->tested);
    }
#endif
}

/* Ray r's entry into box c of nd, exactly (in double, from the float
 * origin the node tests start from and the ray's own direction, which the
 * triangles see: not the rounded 1 / inv each axis's test multiplies by),
 * or NAN when it misses within [0, tmax]. */
static double exact_entry(const struct bvh8_node *nd, int c, const struct bvh_ray *br, const ray *r,
                          double tmax) {
    double tn = 0, tf = tmax, d[3] = {r->d.x, r->d.y, r->d.z};
    for (int k = 0; k < 3; k++) {
        double a = ((double)nd->lo[k][c] - br->org[k]) / d[k],
               b = ((double)nd->hi[k][c] - br->org[k]) / d[k];
        if (d[k] == 0 && (a != a || b != b)) continue; /* the origin on a plane it runs along */
        tn = fmax(tn, fmin(a, b));
        tf = fmin(tf, fmax(a, b));
    }
    return tn <= tf ? tn : NAN;
}

/* One random 8-wide node and ray for test_node_tests_are_conservative:
 * boxes at three scales, origins near them or 1e4-1e6 away, directions
 * with zero components, or aimed exactly at a corner (grazing rays). */
static void node_trial(uint32_t *s, struct bvh8_node *nd, ray *r, double *tmax) {
    static const double scales[3] = {1, 1e3, 1e-3}, far[4] = {1, 1, 1e4, 1e6};
    double sc = scales[*s % 3];
    memset(nd, 0, sizeof *nd);
    for (int c = 0; c < 8; c++)
        for (int k = 0; k < 3; k++) {
            double lo = (lcg_unit(s) * 20 - 10) * sc,
                   ext = lcg_unit(s) < 0.2 ? 0 : lcg_unit(s) * 6 * sc;
            nd->lo[k][c] = (float)lo;
            nd->hi[k][c] = (float)(lo + ext);
        }
    double o[3], d[3];
    double away = far[(*s >> 4) % 4];
    bool at_zero = lcg_unit(s) < 0.25; /* org * inv is 0: no slack beside the rounding */
    for (int k = 0; k < 3; k++) o[k] = at_zero ? 0 : (lcg_unit(s) * 30 - 15) * sc * away;
    int aim = (int)(lcg_unit(s) * 4), c = (int)(lcg_unit(s) * 8), bits = (int)(lcg_unit(s) * 8);
    for (int k = 0; k < 3; k++) { /* 0: at a corner of box c, 1-2: at its centre, 3: anywhere */
        double corner = (bits >> k) & 1 ? nd->hi[k][c] : nd->lo[k][c];
        double centre = 0.5 * ((double)nd->lo[k][c] + nd->hi[k][c]);
        double at = aim == 0 ? corner : centre;
        d[k] = aim < 3 ? at - (double)(float)o[k] : lcg_unit(s) - 0.5;
        if (lcg_unit(s) < 0.1) d[k] = 0;
    }
    r->o = v3(o[0], o[1], o[2]);
    r->d = v3(d[0], d[1], d[2]);
    *tmax = lcg_unit(s) < 0.3 ? lcg_unit(s) * 40 * sc * away : 3e38;
}

#ifdef CPU_AVX512
CPU_AVX2_FN int fused_test(const struct bvh8_node *nd, struct bvh_ray *br, float tmax,
                           float tn[8]) {
    bvh_ray_fused(br);
    return bvh8_test_fused(nd, br, 0, tmax, tn);
}

/* The packet walk's child test (bvh16_child), fused where the packet is:
 * ray r in every lane, lane 0's answer. */
CPU_AVX512_FN int packet_test(const struct bvh8_node *nd, const ray *r, float tmax, float tn[8]) {
    ray rs[16];
    for (int i = 0; i < 16; i++) rs[i] = *r;
    struct ray16 q;
    ray16_from_rays(&q, rs, 0xffff);
    struct bvh16_ray br;
    bvh16_ray_init(&br, &q, 8);
    int hit = 0;
    for (int c = 0; c < 8; c++) {
        __m512 t;
        hit |= (bvh16_child((const char *)nd, 8, c, &br, _mm512_set1_ps(tmax), 1, &t) & 1) << c;
        tn[c] = _mm512_cvtss_f32(t);
    }
    return hit;
}

/* The same of the AVX2 packets' child test (rays8_child). */
CPU_AVX2_FN int packet8_test(const struct bvh8_node *nd, const ray *r, float tmax, float tn[8]) {
    struct ray16 q;
    for (int i = 0; i < 16; i++) ray16_set(&q, i, *r);
    struct rays8_ray br;
    rays8_init(&br, &q, 0, 0xffff, 8);
    int hit = 0;
    for (int c = 0; c < 8; c++) {
        __m256 t;
        hit |= (int)(rays8_child((const char *)nd, 8, c, &br, _mm256_set1_ps(tmax), 1, &t) & 1)
               << c;
        tn[c] = _mm256_cvtss_f32(t);
    }
    return hit;
}
#endif

/* A node test may say a ray enters a box it misses, never the reverse,
 * and its entry distance is never past the true one (beyond BVH_SLACK):
 * else a walk would skip a subtree that holds the nearest hit.  The
 * build's test and, where they run, the ones with fused multiply-adds
 * (AVX2's bvh8_test_fused and packet rays8_child; AVX-512's packet
 * bvh16_child), against the exact entry in double. */
static void test_node_tests_are_conservative(void) {
    uint32_t s = 9090, missed[4] = {0, 0, 0, 0}, late[4] = {0, 0, 0, 0}, entered = 0, tested = 0;
    int tests = 1;
#ifdef CPU_AVX512
    tests = cpu_avx512() ? 4 : cpu_avx2() ? 3 : 1;
#endif
    for (int n = 0; n < 30000; n++) {
        struct bvh8_node nd;
        ray r;
        double tmax;
        node_trial(&s, &nd, &r, &tmax);
        struct bvh_ray br;
        bvh_ray_init(&br, r.o, r.d);
        /* the bound as the walks pass it: an entry may round past tmax */
        float bound = (float)tmax * BVH_SLACK;
        for (int which = 0; which < tests; which++) {
            float tn[8];
            int hit = bvh8_test(&nd, &br, 0, bound, tn);
#ifdef CPU_AVX512
            if (which == 1) hit = fused_test(&nd, &br, bound, tn);
            if (which == 2) hit = packet8_test(&nd, &r, bound, tn);
            if (which == 3) hit = packet_test(&nd, &r, bound, tn);
#endif
            for (int c = 0; c < 8; c++) {
                double want = exact_entry(&nd, c, &br, &r, (float)tmax);
                entered += !which && want == want;
                tested += !which;
                if (want != want) continue;
                missed[which] += !(hit >> c & 1);
                late[which] += (hit >> c & 1) && tn[c] > want * BVH_SLACK;
            }
        }
    }
    printf("  %u boxes, %u entered; %d test(s)\n", tested, entered, tests);
    CHECK(entered > tested / 25 && entered < tested, "%u of %u boxes entered", entered, tested);
    for (int w = 0; w < tests; w++) {
        CHECK(missed[w] == 0, "test %d: %u entered boxes missed", w, missed[w]);
        CHECK(late[w] == 0, "test %d: %u entries past the true one", w, late[w]);
    }
}

int main(void) {
    RUN(test_packet_cull_keeps_every_entered_child);
    RUN(test_node_tests_are_conservative);
    CHECK_EXIT();
}
