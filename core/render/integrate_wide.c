/* integrate_wide.c -- Whitted shading of 16 hits at once.
 *
 * The packet version of the integrator (integrate.c, whitted16) finds 16
 * hits at once, but shading them lane by lane through the one-ray
 * functions costs more than finding them: every vec3 is shuffled in and
 * out of registers, every step is a call.  The common hits -- an
 * untransformed sphere or plane, an untextured opaque material, point and
 * directional lights -- are shaded here instead, 16 at a time in
 * structure-of-arrays form (integrate_wide_body.h), by plain loops the
 * compiler vectorises.  Each lane does exactly the one-ray code's double
 * operations in its order, so the colour is the same to the bit; the
 * AVX-512 copy of the code is used where cpu_avx512 says so, the
 * build's own otherwise, and both give the same bytes.
 *
 * So a change to the one-ray shading (hit_frame, shade_base, light_at,
 * shade_one, mirror_dir) must be made here too: test_shading's
 * test_packets_shade_as_one_ray compares the two bit for bit on random
 * packets and fails on any drift.
 */
#include "render/integrate_wide.h"

#include <string.h>

#include "accel/bvh16.h"

/* One packet's hits as structure of arrays (flags as 0 or 1 doubles, the
 * vectoriser's favourite shape); lanes outside the packet copy its first
 * lane. */
struct wide {
    LANES_ALIGN double ox[16];
    double oy[16], oz[16], dx[16], dy[16], dz[16], t[16]; /* the rays, the hits */
    double gx[16], gy[16], gz[16];                        /* a sphere's centre, a plane's normal */
    double sphere[16];
    double colx[16], coly[16], colz[16], emx[16], emy[16], emz[16]; /* the materials */
    double emf[16]; /* 1: emission from the front only (emit_front_only) */
    double amb[16], dif[16], spec[16], cut[16], kr[16], shin[16];
    int64_t shine[16]; /* the material's shine_whole */
    int64_t top;       /* the bits of all whole exponents */
    bool frac;         /* some exponent is not whole */
    bool gloss;        /* some lane has a highlight (specular > 0) */
    bool spheres;      /* some lane hit a sphere */
    LANES_ALIGN double px[16];
    double py[16], pz[16], nx[16], ny[16], nz[16]; /* point, normal facing the ray */
    double up[3][16];                              /* the point lifted off the surface: x, y, z */
    double cx[16], cy[16], cz[16];                 /* the colour so far */
};

/* A light as the lanes see it: the unit vector toward it, its distance,
 * whether it reaches each lane from the front (1) or not (0), and what the
 * shadow rays toward it let through. */
struct aimed {
    LANES_ALIGN double wi[3][16];
    double dist[16], ok[16];
    double tr[3][16]; /* 0 outside the lanes it reaches */
};

/* Eight lanes in one value (GNU C vector extensions): where a loop over
 * arrays would leave its values in memory between steps. */
typedef double wide_d8 __attribute__((vector_size(64)));
typedef int64_t wide_i8 __attribute__((vector_size(64)));

/* The lights aimed at, and their shadow rays traced, before any is shaded:
 * their square roots, divisions and walks then overlap instead of waiting
 * one on the other. */
#define WIDE_AHEAD 4

#define WIDE(f) f##_base
#define WIDE_FN static inline
#include "render/integrate_wide_body.h"
#undef WIDE
#undef WIDE_FN

#ifdef CPU_AVX512
#define WIDE(f) f##_avx512
#define WIDE_FN CPU_AVX512_FN
#include "render/integrate_wide_body.h"
#undef WIDE
#undef WIDE_FN
#endif

uint32_t whitted_wide_lanes(const rayd_scene *s, const struct hit16 *hs) {
    uint32_t lanes = hs->lanes;
    if (!lanes || !s->simple_lights || s->rs.env.kind != ENV_NONE)
        return 0; /* ambient: integrate.c */
    const struct object *first = hs->leaf[__builtin_ctz(lanes)];
    uint32_t same = 0; /* most packets hit one object: one material to look at */
    for (int j = 0; j < 16; j++) same |= (uint32_t)(hs->leaf[j] == first) << j;
    if ((lanes & same) == lanes) return s->mats[first->material].plain ? lanes : 0;
    uint32_t wide = 0;
    for (uint32_t m = lanes; m; m &= m - 1) { /* no branch a lane: they would mispredict */
        int j = __builtin_ctz(m);
        wide |= (uint32_t)s->mats[hs->leaf[j]->material].plain << j;
    }
    return wide;
}

uint32_t whitted_wide(const rayd_scene *s, const struct ray16 *r, const struct hit16 *hs,
                      uint32_t lanes, int depth, vec3 out[16], struct ray16 *rr, double kr[16],
                      struct meter *mt) {
    if (!lanes) return 0;
#ifdef CPU_AVX512
    if (cpu_avx512()) return whitted_wide_avx512(s, r, hs, lanes, depth, out, rr, kr, mt);
#endif
    return whitted_wide_base(s, r, hs, lanes, depth, out, rr, kr, mt);
}
