/* integrate.c -- the Whitted integrator.
 *
 * For the nearest hit along a ray: emission, plus ambient (material ambient
 * times colour, when the scene has lights at all -- so an emissive object in
 * a scene without lights shows exactly its emission), plus for every light
 * that reaches the point a Lambert term and a Blinn-Phong highlight.
 * Shadow rays start a little off the surface, on the side the light is on,
 * and see through transparent objects (tinted by their colour).  Then,
 * while depth < render.max_depth, a mirror ray (reflectivity) and a
 * refracted ray (transparency) split by the Fresnel equations; total
 * internal reflection sends everything to the mirror ray.  Planes are thin
 * surfaces: what passes through them goes straight on.
 *
 * With render.environment, a ray that escapes sees the environment in its
 * direction (a camera ray only when it is visible, else the background),
 * and every hit gets the environment's ambient light: its mean radiance
 * times colour times the material's diffuse weight -- what a Lambert
 * surface would reflect under a uniform sky of that radiance, unshadowed,
 * deterministic, and exact for a constant environment.
 *
 * whitted_radiance16 does the same for 16 camera rays at once: the hits,
 * each light sample's shadow rays and the opaque mirrors' rays as packets.
 * The common hits are shaded 16 at a time by integrate_wide.c, which
 * repeats this file's operations lane by lane; the others take this file's
 * own functions, ray by ray.  So each ray's colour is exactly
 * whitted_radiance's.
 */
#include "render/integrate.h"

#include "render/integrate_wide.h"

vec3 integrate_visible(const rayd_scene *s, vec3 origin, vec3 to_light, double dist, bool opaque,
                       uint32_t leave, struct meter *mt) {
    ray sr = {origin, to_light};
    if (!meter_ray(mt)) return v3(0, 0, 0); /* stopped: nothing more is traced */
    if (!opaque || s->opaque) return scene_transmittance_from(s, &sr, dist, leave);
    double lit = scene_occluded_from(s, &sr, dist, leave) ? 0 : 1;
    return v3(lit, lit, lit);
}

/* The first half of integrate_light_sample, before the shadow ray: the
 * direction wi toward sample (su, sv) of light l, its distance from origin
 * and what it sends; false when it sends nothing or is behind nf. */
static bool integrate_light_aim(const struct light *l, vec3 p, vec3 nf, double su, double sv,
                                vec3 origin, vec3 *wi, vec3 *radiance, double *dist) {
    if (l->kind == LIGHT_AREA) {
        vec3 q = light_area_point(l, p, su, sv), d = v3_sub(q, origin);
        *dist = v3_len(d);
        if (!(*dist > 0)) return false;
        *wi = v3_scale(d, 1 / *dist);
        *radiance = v3_scale(l->color, l->intensity);
    } else if (!light_at(l, p, wi, dist, radiance)) {
        return false;
    }
    return !(v3_dot(nf, *wi) <= 0);
}

/* What the shadow ray let through (tr) applied to the light's radiance;
 * false when nothing did. */
static inline bool light_pass(vec3 tr, vec3 *radiance) {
    if (tr.x <= 0 && tr.y <= 0 && tr.z <= 0) return false;
    *radiance = v3_mul(*radiance, tr);
    return true;
}

bool integrate_light_sample(const rayd_scene *s, const struct light *l, vec3 p, vec3 nf,
                            vec3 origin, uint32_t leave, double su, double sv, bool opaque,
                            vec3 *wi, vec3 *radiance, struct meter *mt) {
    double dist;
    if (!integrate_light_aim(l, p, nf, su, sv, origin, wi, radiance, &dist)) return false;
    return light_pass(integrate_visible(s, origin, *wi, dist, opaque, leave, mt), radiance);
}

/* x^e for m's Blinn-Phong exponent e: by squaring when e is a whole
 * number up to 1024 (the common case: a few multiplications, within a few
 * ulps of pow), else pow. */
static inline double phong_pow(double x, const struct material *m) {
    if (m->shine_whole < 0) return pow(x, m->shininess);
    double r = 1;
    for (unsigned n = (unsigned)m->shine_whole; n; n >>= 1, x *= x)
        if (n & 1) r *= x;
    return r;
}

/* Lambert + Blinn-Phong from one light direction.  A highlight below
 * 2^-24 (the material's spec_cut, see material.h, for radiance up to 1) is
 * not computed: it could not change an 8-bit pixel, and the power is the
 * costliest step of the shader. */
static vec3 shade_one(const struct material *m, vec3 color, vec3 nf, vec3 d, vec3 wi, vec3 rad) {
    vec3 c = v3_mul(rad, v3_scale(color, m->diffuse * v3_dot(nf, wi)));
    if (m->specular > 0) {
        vec3 h = v3_norm(v3_sub(wi, d));
        double ndh = v3_dot(nf, h);
        if (ndh > m->spec_cut || v3_maxabs(rad) > 1) /* spec_cut holds for lights up to 1 */
            c = v3_add(c, v3_scale(rad, m->specular * phong_pow(ndh, m)));
    }
    return c;
}

/* Light l's samples: n of them, on a gx x gy grid. */
static int light_samples(const struct light *l, int *gx, int *gy) {
    int n = l->kind == LIGHT_AREA ? l->samples : 1;
    *gx = (int)ceil(sqrt((double)n));
    *gy = (n + *gx - 1) / *gx;
    return n;
}

/* Where sample k of light i falls (stratified, jittered by the pixel
 * sample's random numbers); the centre for point-like lights. */
static void light_uv(const struct light *l, int i, int k, int gx, int gy, int depth,
                     const struct rng_key *key, double *su, double *sv) {
    *su = 0.5, *sv = 0.5;
    if (l->kind != LIGHT_AREA) return;
    *su = (k % gx + rng_uniform(key, (uint32_t)depth, RNG_AREA_DIM(i, k))) / gx;
    *sv = (k / gx + rng_uniform(key, (uint32_t)depth, RNG_AREA_DIM(i, k) + 1)) / gy;
}

/* A hit as the shader sees it. */
struct frame {
    struct surface sf;
    bool inside;  /* the ray is leaving the solid */
    vec3 ngf, nf; /* geometric and shading normals facing the incoming ray */
    vec3 above;   /* the point lifted off the surface on the ray's side */
    vec3 below;   /* ... and on the far side */
};

static void hit_frame(const rayd_scene *s, const ray *r, const struct hit *h, struct frame *f) {
    scene_surface(s, r, h, &f->sf);
    f->inside = v3_dot(f->sf.ng, r->d) > 0;
    f->ngf = f->inside ? v3_neg(f->sf.ng) : f->sf.ng; /* faces the incoming ray */
    f->nf = f->inside ? v3_neg(f->sf.n) : f->sf.n;
    if (v3_dot(f->nf, f->ngf) < 0) f->nf = f->ngf; /* an interpolated normal past the silhouette */
    double off = integrate_offset(f->sf.p, f->sf.float_geom);
    f->above = v3_madd(f->sf.p, f->ngf, off);
    f->below = v3_madd(f->sf.p, f->ngf, -off);
}

vec3 integrate_escape(const rayd_scene *s, vec3 d, int depth) {
    const struct environment *e = &s->rs.env;
    if (e->kind == ENV_NONE || (depth == 0 && !e->visible)) return s->rs.background;
    return env_radiance(e, d);
}

/* Emission, plus ambient when the scene has lights, plus the environment's. */
static vec3 shade_base(const rayd_scene *s, const struct frame *f) {
    vec3 c = f->inside && f->sf.m->emit_front_only ? v3(0, 0, 0) : f->sf.m->emission;
    if (s->nlights > 0) c = v3_add(c, v3_scale(f->sf.color, f->sf.m->ambient));
    if (s->rs.env.kind != ENV_NONE)
        c = v3_add(c, v3_mul(s->rs.env.mean, v3_scale(f->sf.color, f->sf.m->diffuse)));
    return c;
}

/* Direct light at the hit: an area light is the average of its samples,
 * each a point light, stratified. */
static vec3 shade_local(const rayd_scene *s, const struct frame *f, vec3 d, int depth,
                        const struct rng_key *key, struct meter *mt) {
    vec3 c = shade_base(s, f);
    for (int i = 0; i < s->nlights && meter_going(mt); i++) {
        const struct light *l = &s->lights[i];
        int gx, gy, n = light_samples(l, &gx, &gy);
        vec3 sum = v3(0, 0, 0);
        for (int k = 0; k < n && meter_going(mt); k++) {
            double su, sv;
            light_uv(l, i, k, gx, gy, depth, key, &su, &sv);
            vec3 wi, rad;
            if (integrate_light_sample(s, l, f->sf.p, f->nf, f->above, SCENE_NO_LEAVE, su, sv,
                                       false, &wi, &rad, mt))
                sum = v3_add(sum, shade_one(f->sf.m, f->sf.color, f->nf, d, wi, rad));
        }
        c = v3_madd(c, sum, 1.0 / n);
    }
    return c;
}

static vec3 trace_from(const rayd_scene *s, vec3 o, vec3 d, int depth, const struct rng_key *key,
                       struct meter *mt) {
    ray r = {o, d};
    return whitted_radiance(s, &r, depth, key, mt);
}

/* The mirror direction a hit sends a reflected ray in: about the shading normal, unless
 * that would go below the surface. */
static vec3 mirror_dir(const ray *r, const struct frame *f) {
    vec3 d = v3_reflect(r->d, f->nf);
    return v3_dot(d, f->ngf) <= 0 ? v3_reflect(r->d, f->ngf) : d;
}

/* c (the direct light) plus the mirror and refracted rays, while depth <
 * render.max_depth. */
static vec3 shade_secondary(const rayd_scene *s, const ray *r, const struct frame *f, vec3 c,
                            int depth, const struct rng_key *key, struct meter *mt) {
    if (depth >= s->rs.max_depth) return c;
    const struct material *m = f->sf.m;
    double kr = m->reflectivity, kt = m->transparency;
    if (kt <= 0) { /* opaque: a mirror ray only where the material reflects */
        if (kr > 0)
            c = v3_madd(c, trace_from(s, f->above, mirror_dir(r, f), depth + 1, key, mt), kr);
        return c;
    }
    vec3 refl_dir = mirror_dir(r, f);
    double cos_i = -v3_dot(r->d, f->nf), cos_t = 0, fr;
    vec3 tdir;
    if (f->sf.thin) { /* thin surface: no bending, no Fresnel split */
        fr = 0;
        tdir = r->d;
    } else {
        double n1 = f->inside ? m->ior : 1.0, n2 = f->inside ? 1.0 : m->ior;
        fr = material_fresnel(n1, n2, cos_i, &cos_t);
        tdir = material_refract(r->d, f->nf, n1 / n2, cos_i, cos_t);
    }
    c = v3_scale(c, 1.0 - kt);
    double wr = kr + kt * fr;
    if (wr > 0) c = v3_madd(c, trace_from(s, f->above, refl_dir, depth + 1, key, mt), wr);
    if (fr < 1) {
        vec3 refr = trace_from(s, f->below, tdir, depth + 1, key, mt);
        c = v3_add(c, v3_mul(refr, v3_scale(f->sf.color, kt * (1 - fr))));
    }
    return c;
}

vec3 whitted_radiance(const rayd_scene *s, const ray *r, int depth, const struct rng_key *key,
                      struct meter *mt) {
    if (!meter_ray(mt)) return v3(0, 0, 0); /* stopped: the colour is thrown away */
    struct hit h;
    if (!scene_intersect(s, r, INFINITY, &h)) return integrate_escape(s, r->d, depth);
    struct frame f;
    hit_frame(s, r, &h, &f);
    vec3 c = shade_local(s, &f, r->d, depth, key, mt);
    return shade_secondary(s, r, &f, c, depth, key, mt);
}

/* ---- 16 camera rays at once --------------------------------------------------- */

/* shade_local for the hits in `hit`, each light sample's 16 shadow rays as
 * one packet: the same operations in the same order for every ray. */
static void shade_local16(const rayd_scene *s, const ray r[16], uint32_t hit,
                          const struct frame f[16], int depth, const struct rng_key key[16],
                          vec3 c[16], struct meter *mt) {
    for (uint32_t m = hit; m; m &= m - 1) c[__builtin_ctz(m)] = shade_base(s, &f[__builtin_ctz(m)]);
    for (int i = 0; i < s->nlights; i++) {
        const struct light *l = &s->lights[i];
        int gx, gy, n = light_samples(l, &gx, &gy);
        vec3 sum[16], wi[16], rad[16], tr[16];
        ray sr[16];
        double dist[16];
        for (uint32_t m = hit; m; m &= m - 1) sum[__builtin_ctz(m)] = v3(0, 0, 0);
        for (int k = 0; k < n; k++) {
            uint32_t aim = 0;
            for (uint32_t m = hit; m; m &= m - 1) {
                int j = __builtin_ctz(m);
                double su, sv;
                light_uv(l, i, k, gx, gy, depth, &key[j], &su, &sv);
                if (!integrate_light_aim(l, f[j].sf.p, f[j].nf, su, sv, f[j].above, &wi[j], &rad[j],
                                         &dist[j]))
                    continue;
                sr[j] = (ray){f[j].above, wi[j]};
                aim |= 1u << j;
            }
            if (!meter_rays(mt, (uint64_t)__builtin_popcount(aim))) return; /* stopped */
            scene_transmittance16(s, sr, dist, aim, tr);
            for (; aim; aim &= aim - 1) {
                int j = __builtin_ctz(aim);
                if (light_pass(tr[j], &rad[j]))
                    sum[j] = v3_add(sum[j], shade_one(f[j].sf.m, f[j].sf.color, f[j].nf, r[j].d,
                                                      wi[j], rad[j]));
            }
        }
        for (uint32_t m = hit; m; m &= m - 1) {
            int j = __builtin_ctz(m);
            c[j] = v3_madd(c[j], sum[j], 1.0 / n);
        }
    }
}

/* whitted_radiance of the rays in active after `depth` bounces, as packets.
 * The common hits are shaded 16 wide (integrate_wide.c), the others lane by
 * lane with their shadow rays as a packet.  The mirror rays of opaque
 * mirrors go on as a packet of their own when at least a quarter of the
 * lanes have one (fewer are not worth a packet); everything else takes
 * shade_secondary, ray by ray. */
static void whitted16(const rayd_scene *s, const struct ray16 *r, uint32_t active, int depth,
                      const struct rng_key key[16], vec3 out[16], struct meter *mt) {
    if (!meter_rays(mt, (uint64_t)__builtin_popcount(active))) { /* stopped: thrown away */
        for (uint32_t m = active; m; m &= m - 1) out[__builtin_ctz(m)] = v3(0, 0, 0);
        return;
    }
    double kr[16];
    struct hit h[16];
    struct hit16 hs; /* the hits on spheres and planes, most of them: the wide shader's */
    uint32_t hit = scene_intersect16_soa(s, r, scene_unbounded16, active, h, &hs);
    for (uint32_t m = active & ~hit; m; m &= m - 1)
        out[__builtin_ctz(m)] = integrate_escape(s, ray16_get(r, __builtin_ctz(m)).d, depth);
    struct ray16 rr;
    uint32_t wide = whitted_wide_lanes(s, &hs), rest = hit & ~wide;
    for (uint32_t m = rest & hs.lanes; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        h[i] = hit16_get(&hs, i);
    }
    uint32_t mirror = whitted_wide(s, r, &hs, wide, depth, out, &rr, kr, mt);
    struct frame f[16];
    ray ri[16]; /* the other lanes' rays, one by one */
    for (uint32_t m = rest; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        ri[i] = ray16_get(r, i);
        hit_frame(s, &ri[i], &h[i], &f[i]);
    }
    shade_local16(s, ri, rest, f, depth, key, out, mt);
    for (uint32_t m = rest; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        const struct material *mat = f[i].sf.m;
        if (depth < s->rs.max_depth && mat->transparency <= 0 && mat->reflectivity > 0) {
            mirror |= 1u << i;
            ray16_set(&rr, i, (ray){f[i].above, mirror_dir(&ri[i], &f[i])});
            kr[i] = mat->reflectivity;
        } else {
            out[i] = shade_secondary(s, &ri[i], &f[i], out[i], depth, &key[i], mt);
        }
    }
    if (__builtin_popcount(mirror) < 4) { /* c + kr * the mirror ray, as shade_secondary */
        for (uint32_t m = mirror; m; m &= m - 1) {
            int i = __builtin_ctz(m);
            ray mr = ray16_get(&rr, i);
            out[i] = v3_madd(out[i], whitted_radiance(s, &mr, depth + 1, &key[i], mt), kr[i]);
        }
        return;
    }
    vec3 rc[16];
    whitted16(s, &rr, mirror, depth + 1, key, rc, mt);
    for (uint32_t m = mirror; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        out[i] = v3_madd(out[i], rc[i], kr[i]);
    }
}

void whitted_radiance16(const rayd_scene *s, const struct ray16 *r, uint32_t active,
                        const struct rng_key key[16], vec3 out[16], struct meter *mt) {
    whitted16(s, r, active, 0, key, out, mt);
}
