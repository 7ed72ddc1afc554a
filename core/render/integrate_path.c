/* integrate_path.c -- unbiased path tracing ("render.integrator": "path").
 *
 * At every vertex the material is a mixture of four lobes whose weights
 * sum to one, and the same weights pick the lobe to sample:
 *   diffuse     Lambert, albedo = color * diffuse       weight (1-t)(1-m)(1-r)
 *   metal       GGX microfacets, Fresnel-Schlick with F0 = color,
 *               alpha = roughness^2 (a delta mirror at 0)  weight (1-t) m
 *   mirror      perfect, untinted                        weight (1-t)(1-m) r
 *   glass       smooth dielectric: Fresnel picks reflection or refraction,
 *               refraction tinted by color               weight t
 * with t = transparency, m = metallic, r = reflectivity.  Sampling a
 * non-delta lobe is weighed against the mixture's whole non-delta pdf
 * (one-sample MIS over lobes).
 *
 * Light: next-event estimation at every non-delta vertex -- every light of
 * /lights once (point, directional and spot lights exactly as the Whitted
 * integrator sees them; area lights at one point of their area), and one
 * emissive sphere, disc or quad of the top level picked uniformly, its
 * point sampled by area.  Emissive objects are also found by BSDF
 * sampling; the two strategies are combined by the power heuristic.
 * Escaped rays see the background as a uniform environment, or
 * render.environment (camera rays only when it is visible).  An image
 * environment is also sampled at every non-delta vertex, in proportion to
 * its luminance over the sphere (environment.c), and that light sample and
 * the BSDF's escaped ray are weighed by the power heuristic, as for
 * emitters.  Russian roulette (math/roulette.h: from the third vertex, a
 * chance twice the throughput, clamped to [0.05, 0.95]) keeps long paths
 * cheap and the estimate unbiased.  Every random number is a stratified
 * sample (Owen-scrambled Sobol, rng.h), a pure function of pixel, sample,
 * bounce and the dimension below, so tiles stay exact.  A direction's two
 * numbers, a light point's two and the environment's two are each one 2-D
 * pair.
 *
 * Fireflies.  What NEE cannot reach is found by BSDF sampling alone: light
 * that reaches a diffuse surface through glass or a mirror (a caustic:
 * diffuse -> specular -> the light), whose rare paths each bring the
 * light's whole radiance, 15 in scenes/cornell.json.  Those are its
 * sparkles on the walls, unbiased but slow to converge.  Two biased
 * controls, off by default, trade them for a little darkening
 * (docs/scene-format.md, "Fireflies"): render.clamp_indirect caps the
 * luminance any indirect contribution adds (from the second vertex's
 * light sample, or an emitter hit past the first bounce), and
 * render.filter_glossy gives glossy lobes at least that roughness once
 * the path has made a diffuse or glossy bounce (Cycles' "filter glossy").
 */
#include <stdint.h>

#include "math/roulette.h"
#include "math/turn.h"
#include "render/integrate.h"

#define PI 3.14159265358979323846

enum { D_LOBE, D_DIR1, D_DIR2, D_RR, D_FRESNEL, D_PICK, D_EPT1, D_EPT2, D_LIGHT0 };
/* The environment's light sample: at the top of the 32-bit range, past
 * D_LIGHT0 + 2 x any number of lights a limit could allow. */
#define D_ENV1 0xfffffff0u
#define D_ENV2 0xfffffff1u

struct lobes {
    double w_diff, w_metal, w_mirror, w_glass;
    vec3 albedo; /* diffuse */
    vec3 f0;     /* metal Fresnel at normal incidence */
    double alpha;
};

/* The lobes of material m; rough (> 0) is the least roughness its metal
 * may have (render.filter_glossy after a blurry bounce). */
static struct lobes lobes_of(const struct material *m, vec3 color, double rough) {
    double t = m->transparency, mt = m->metallic, r = m->reflectivity;
    double ro = m->roughness > rough ? m->roughness : rough;
    struct lobes l = {(1 - t) * (1 - mt) * (1 - r),
                      (1 - t) * mt,
                      (1 - t) * (1 - mt) * r,
                      t,
                      v3_scale(color, m->diffuse),
                      color,
                      ro * ro};
    if (l.alpha < 1e-3) { /* a smooth metal is a tinted mirror: treated as delta below */
        l.alpha = 0;
    }
    return l;
}

static double ggx_d(double alpha, double cos_h) {
    double a2 = alpha * alpha, c2 = cos_h * cos_h, k = c2 * (a2 - 1) + 1;
    return a2 / (PI * k * k);
}

static double ggx_g1(double alpha, double cos_v) {
    double c2 = cos_v * cos_v, t2 = (1 - c2) / v3_fmax(c2, 1e-12);
    return 2 / (1 + sqrt(1 + alpha * alpha * t2));
}

static vec3 schlick(vec3 f0, double c) {
    double x = 1 - v3_fmax(0, v3_fmin(1, c)), x2 = x * x, k = x2 * x2 * x; /* pow(x, 5) */
    return v3_add(f0, v3_scale(v3_sub(v3(1, 1, 1), f0), k));
}

/* The non-delta part of the BSDF (times cos_i) and its sampling pdf, for
 * wo (toward the viewer) and wi (toward the light) about normal n.
 * Inlined (twice a vertex), like frame_dir: passing three vectors through
 * memory cost more than the call saved (3-5% of a Cornell box). */
__attribute__((always_inline)) static inline vec3 eval_nondelta(const struct lobes *l, vec3 n,
                                                                vec3 wo, vec3 wi, double *pdf) {
    double ci = v3_dot(n, wi), co = v3_dot(n, wo);
    *pdf = 0;
    if (ci <= 0 || co <= 0) return v3(0, 0, 0);
    vec3 f = v3(0, 0, 0);
    if (l->w_diff > 0) {
        f = v3_scale(l->albedo, l->w_diff * ci / PI);
        *pdf += l->w_diff * ci / PI;
    }
    if (l->w_metal > 0 && l->alpha > 0) {
        vec3 h = v3_norm(v3_add(wo, wi));
        double ch = v3_dot(n, h), oh = v3_dot(wo, h);
        double d = ggx_d(l->alpha, ch), g = ggx_g1(l->alpha, co) * ggx_g1(l->alpha, ci);
        vec3 fr = schlick(l->f0, oh);
        f = v3_madd(f, fr, l->w_metal * d * g / (4 * co)); /* (D G F / 4 co ci) * ci */
        *pdf += l->w_metal * d * ch / (4 * fabs(oh));
    }
    return f;
}

__attribute__((always_inline)) static inline vec3 frame_dir(vec3 n, double x, double y, double z) {
    vec3 u, v;
    v3_frame(n, &u, &v);
    return v3_add(v3_add(v3_scale(u, x), v3_scale(v, y)), v3_scale(n, z));
}

struct vertex {
    vec3 p, n, ng, above, below;
    bool inside, thin;
    /* The top-level object hit (its index in objs) when rays from above
     * cannot meet it again (leave_index), else SCENE_NO_LEAVE. */
    uint32_t leave;
};

/* The index in objs of the object of hit h at point p when rays leaving
 * it there cannot meet it again (scene_leave.c: *flat from either side,
 * else outward only), or SCENE_NO_LEAVE; their queries pass over it. */
static uint32_t leave_index(const rayd_scene *s, const struct hit *h, vec3 p, bool *flat) {
    uintptr_t at = (uintptr_t)h->leaf, lo = (uintptr_t)s->objs,
              hi = (uintptr_t)(s->objs + s->nobjs);
    *flat = false;
    if (h->outer || h->orient || at < lo || at >= hi) return SCENE_NO_LEAVE;
    uint32_t i = (uint32_t)(h->leaf - s->objs);
    if (!(s->leave[i].scale <= 1e4 * (1 + v3_maxabs(p)))) return SCENE_NO_LEAVE;
    *flat = s->leave[i].flat;
    return i;
}

/* Power heuristic for two strategies. */
static double mis(double a, double b) { return a * a / (a * a + b * b); }

static bool is_emitter(const rayd_scene *s, const struct hit *h) {
    const struct object *o = h->leaf;
    uintptr_t at = (uintptr_t)o, lo = (uintptr_t)s->objs, hi = (uintptr_t)(s->objs + s->nobjs);
    return !h->outer && h->orient == 0 && o->xform < 0 && at >= lo && at < hi && /* top level */
           (o->kind == SHAPE_SPHERE || o->kind == SHAPE_DISC || o->kind == SHAPE_QUAD) &&
           v3_maxabs(s->mats[o->material].emission) > 0;
}

static double emitter_area(const struct object *o) {
    switch (o->kind) {
    case SHAPE_SPHERE: return 4 * PI * o->u.sphere.radius * o->u.sphere.radius;
    case SHAPE_DISC:
        return PI * (o->u.disc.radius * o->u.disc.radius - o->u.disc.inner * o->u.disc.inner);
    default: return o->u.quad.area;
    }
}

static vec3 emitter_point(const struct object *o, double a, double b, vec3 *n) {
    switch (o->kind) {
    case SHAPE_SPHERE: {
        double z = 1 - 2 * a, r = sqrt(v3_fmax(0, 1 - z * z)), sp, cp;
        turn_sincos(b, &sp, &cp);
        *n = v3(r * cp, r * sp, z);
        return v3_madd(o->u.sphere.center, *n, o->u.sphere.radius);
    }
    case SHAPE_DISC: {
        double r2 = o->u.disc.inner * o->u.disc.inner, R2 = o->u.disc.radius * o->u.disc.radius;
        double r = sqrt(r2 + a * (R2 - r2)), sp, cp;
        vec3 u, v;
        turn_sincos(b, &sp, &cp);
        v3_frame(o->u.disc.normal, &u, &v);
        *n = o->u.disc.normal;
        return v3_madd(v3_madd(o->u.disc.center, u, r * cp), v, r * sp);
    }
    default:
        *n = o->u.quad.n;
        return v3_madd(v3_madd(o->u.quad.corner, o->u.quad.e1, a), o->u.quad.e2, b);
    }
}

/* Light arriving at x from one direction drawn from the environment map. */
static vec3 env_event(const rayd_scene *s, const struct lobes *lb, const struct vertex *x, vec3 wo,
                      const struct rng_key *key, uint32_t b, struct meter *mt) {
    const struct environment *e = &s->rs.env;
    vec3 wi, le;
    double pdf_l, pdf_b, u, v;
    rng_pair(key, b, D_ENV1, &u, &v);
    if (!env_sample(e, u, v, &wi, &pdf_l, &le)) return v3(0, 0, 0);
    if (v3_dot(x->n, wi) <= 0 || v3_dot(x->ng, wi) <= 0) return v3(0, 0, 0);
    vec3 f = eval_nondelta(lb, x->n, wo, wi, &pdf_b);
    if (v3_maxabs(f) == 0) return v3(0, 0, 0);
    vec3 tr = integrate_visible(s, x->above, wi, INFINITY, true, x->leave, mt);
    if (v3_maxabs(tr) == 0) return v3(0, 0, 0);
    return v3_scale(v3_mul(v3_mul(le, tr), f), mis(pdf_l, pdf_b) / pdf_l);
}

/* What a path that escapes along d after bounce b adds (beta aside). */
static vec3 escaped(const rayd_scene *s, vec3 d, uint32_t b, bool prev_delta, double prev_pdf) {
    const struct environment *e = &s->rs.env;
    if (b == 0 || prev_delta || !env_can_sample(e) || s->rs.no_nee)
        return integrate_escape(s, d, (int)b);
    double pdf;
    vec3 le = env_radiance_pdf(e, d, &pdf);
    return v3_scale(le, mis(prev_pdf, pdf));
}

/* Light arriving at vertex x through the lights and one emitter (NEE). */
__attribute__((always_inline)) static inline vec3
next_event(const rayd_scene *s, const struct lobes *lb, const struct vertex *x, vec3 wo,
           const struct rng_key *key, uint32_t b, struct meter *mt) {
    vec3 sum = v3(0, 0, 0);
    for (int i = 0; i < s->nlights; i++) {
        vec3 wi, rad;
        double pdf, su, sv;
        rng_pair(key, b, D_LIGHT0 + 2 * (uint32_t)i, &su, &sv);
        if (!integrate_light_sample(s, &s->lights[i], x->p, x->n, x->above, x->leave, su, sv, true,
                                    &wi, &rad, mt))
            continue;
        sum = v3_add(sum, v3_mul(rad, eval_nondelta(lb, x->n, wo, wi, &pdf)));
    }
    if (env_can_sample(&s->rs.env)) sum = v3_add(sum, env_event(s, lb, x, wo, key, b, mt));
    int ne = s->nemitters;
    if (ne == 0) return sum;
    /* one emitter: no pick to draw (the number would only give 0) */
    int k = ne == 1 ? 0 : (int)(rng_stratified(key, b, D_PICK) * ne);
    const struct object *e = &s->objs[s->emitters[k < ne ? k : ne - 1]];
    double eu, ev;
    rng_pair(key, b, D_EPT1, &eu, &ev);
    vec3 ln, q = emitter_point(e, eu, ev, &ln);
    vec3 d = v3_sub(q, x->above);
    double dist = v3_len(d);
    if (!(dist > 0)) return sum;
    vec3 wi = v3_scale(d, 1 / dist);
    double cl = -v3_dot(ln, wi);
    const struct material *em = &s->mats[e->material];
    if (e->kind != SHAPE_SPHERE && !em->emit_front_only) cl = fabs(cl); /* both ways */
    if (cl <= 0 || v3_dot(x->n, wi) <= 0) return sum;
    double pdf_b;
    vec3 f = eval_nondelta(lb, x->n, wo, wi, &pdf_b);
    if (v3_maxabs(f) == 0) return sum;
    vec3 tr = integrate_visible(s, x->above, wi, dist * (1 - 1e-7), true, x->leave, mt);
    if (v3_maxabs(tr) == 0) return sum;
    /* mis(pdf_l, pdf_b) / pdf_l with pdf_l = dist^2 / (cl area ne), in two
     * divisions rather than four, none of them of squares that overflow */
    double inv = cl * emitter_area(e) * ne / (dist * dist), r = pdf_b * inv; /* 1 / pdf_l */
    double w = inv / (1 + r * r);
    vec3 le = em->emission;
    return v3_add(sum, v3_scale(v3_mul(v3_mul(le, tr), f), w));
}

/* Samples the next direction; returns false when the path ends.  Updates
 * *beta and says whether the lobe was a delta one and its pdf. */
__attribute__((always_inline)) static inline bool
sample_bsdf(const struct lobes *lb, const struct vertex *x, vec3 color, const struct material *m,
            vec3 wo, const struct rng_key *key, uint32_t b, vec3 *wi, vec3 *beta, bool *delta,
            double *pdf, bool *through) {
    double u = rng_stratified(key, b, D_LOBE), u1, u2;
    rng_pair(key, b, D_DIR1, &u1, &u2);
    *through = false;
    *delta = true;
    if (u < lb->w_glass) {
        double cos_i = v3_dot(wo, x->n), cos_t = 0, fr = 0;
        vec3 d = v3_neg(wo);
        double n1 = x->inside ? m->ior : 1.0, n2 = x->inside ? 1.0 : m->ior;
        if (!x->thin) fr = material_fresnel(n1, n2, cos_i, &cos_t);
        if (rng_stratified(key, b, D_FRESNEL) < fr) {
            *wi = v3_reflect(d, x->n);
        } else {
            *wi = x->thin ? d : material_refract(d, x->n, n1 / n2, cos_i, cos_t);
            *beta = v3_mul(*beta, color);
            *through = true;
        }
        return true;
    }
    u -= lb->w_glass;
    if (u < lb->w_mirror) {
        *wi = v3_reflect(v3_neg(wo), x->n);
        return true;
    }
    u -= lb->w_mirror;
    if (u < lb->w_metal && lb->alpha == 0) {
        *wi = v3_reflect(v3_neg(wo), x->n);
        *beta = v3_mul(*beta, schlick(lb->f0, v3_dot(wo, x->n)));
        return true;
    }
    *delta = false;
    if (u < lb->w_metal) { /* GGX: sample the half vector by D(h) cos */
        double a2 = lb->alpha * lb->alpha;
        double ct = sqrt((1 - u1) / (1 + (a2 - 1) * u1)), st = sqrt(v3_fmax(0, 1 - ct * ct));
        double sp, cp;
        turn_sincos(u2, &sp, &cp);
        vec3 h = frame_dir(x->n, st * cp, st * sp, ct);
        *wi = v3_reflect(v3_neg(wo), h);
    } else { /* cosine-weighted hemisphere */
        double r = sqrt(u1), sp, cp;
        turn_sincos(u2, &sp, &cp);
        *wi = frame_dir(x->n, r * cp, r * sp, sqrt(v3_fmax(0, 1 - u1)));
    }
    vec3 f = eval_nondelta(lb, x->n, wo, *wi, pdf);
    if (!(*pdf > 0) || v3_dot(*wi, x->ng) <= 0) return false;
    *beta = v3_mul(*beta, v3_scale(f, 1 / *pdf));
    return true;
}

/* Whether Russian roulette (number rr) surely ends the path at a Lambert
 * vertex, whatever direction sample_bsdf would draw: then the direction
 * (its sine and cosine, the costliest numbers of a bounce) is not drawn.
 * There sample_bsdf multiplies beta by albedo x (f / pdf), whose ratio is
 * 1 to within a few roundings, so the roulette's q is at most that of
 * beta x albedo lifted by far more than those roundings (and an absolute
 * bit for underflow); a number at or above that bound ends the path in
 * either order, and anything closer is left to the exact test after the
 * draw.  Pure functions of the same numbers: the same bits as drawing
 * first. */
static bool rr_ends_first(const struct lobes *lb, vec3 beta, double rr) {
    if (lb->w_diff != 1 || lb->w_metal != 0 || lb->w_mirror != 0 || lb->w_glass != 0) return false;
    vec3 p = v3_mul(beta, lb->albedo);
    double sum = fabs(p.x) + fabs(p.y) + fabs(p.z); /* NaN or infinite: no shortcut */
    if (!(sum < INFINITY)) return false;
    double hi = v3_maxabs(p) * (1 + 1e-12) + 1e-300;
    return rr >= roulette_chance(hi);
}

/* c added to L; an indirect contribution first scaled down to the
 * luminance render.clamp_indirect when it is brighter. */
static vec3 path_add(const rayd_scene *s, vec3 L, vec3 c, bool indirect) {
    double cap = s->rs.clamp_indirect;
    if (indirect && cap > 0) {
        double l = 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
        if (l > cap) c = v3_scale(c, cap / l);
    }
    return v3_add(L, c);
}

/* The path from r0; first, when not NULL, is r0's nearest hit already
 * found (first_hit says whether *first is a hit or r0 escapes). */
static vec3 path_trace(const rayd_scene *s, const ray *r0, const struct hit *first, bool first_hit,
                       const struct rng_key *key, struct meter *mt) {
    vec3 L = v3(0, 0, 0), beta = v3(1, 1, 1);
    ray r = *r0;
    bool prev_delta = true;
    double prev_pdf = 0;
    vec3 prev_p = r.o;
    bool blurry = false;            /* a diffuse or glossy bounce was made */
    uint32_t from = SCENE_NO_LEAVE; /* the object r leaves, not tested (leave_index) */
    for (uint32_t b = 0;; b++) {
        struct hit h;
        if (!meter_ray(mt)) break; /* stopped: the colour is thrown away */
        bool found = b == 0 && first ? first_hit : scene_intersect_from(s, &r, INFINITY, from, &h);
        if (b == 0 && first && first_hit) h = *first;
        if (!found)
            return path_add(s, L, v3_mul(beta, escaped(s, r.d, b, prev_delta, prev_pdf)), b >= 2);
        struct surface sf;
        scene_surface(s, &r, &h, &sf);
        const struct material *m = sf.m;
        if (v3_maxabs(m->emission) > 0 && material_emits_toward(m, sf.ng, r.d)) {
            double w = 1;
            if (!prev_delta && !s->rs.no_nee && is_emitter(s, &h)) {
                vec3 d = v3_sub(sf.p, prev_p);
                double dist2 = v3_dot(d, d), cl = fabs(v3_dot(sf.ng, r.d));
                /* mis(prev_pdf, pdf_l), pdf_l = dist2 / (cl area ne), in two
                 * divisions rather than three */
                double t = dist2 / (cl * emitter_area(h.leaf) * s->nemitters * prev_pdf);
                w = 1 / (1 + t * t);
            }
            L = path_add(s, L, v3_scale(v3_mul(beta, m->emission), w), b >= 2);
        }
        if ((int)b >= s->rs.max_depth) break;
        struct vertex x;
        x.inside = v3_dot(sf.ng, r.d) > 0;
        x.ng = x.inside ? v3_neg(sf.ng) : sf.ng;
        x.n = x.inside ? v3_neg(sf.n) : sf.n;
        if (v3_dot(x.n, x.ng) < 0) x.n = x.ng;
        x.p = sf.p;
        x.thin = sf.thin;
        bool flat; /* every ray leaving it, from either side, cannot meet it */
        uint32_t leave = leave_index(s, &h, sf.p, &flat);
        /* rays from above: outward unless the ray came from inside */
        x.leave = flat || !x.inside ? leave : SCENE_NO_LEAVE;
        double off = integrate_offset(sf.p, sf.float_geom);
        x.above = v3_madd(sf.p, x.ng, off);
        x.below = v3_madd(sf.p, x.ng, -off);
        vec3 wo = v3_neg(r.d);
        struct lobes lb = lobes_of(m, sf.color, blurry ? s->rs.filter_glossy : 0);
        if (!s->rs.no_nee && (lb.w_diff > 0 || (lb.w_metal > 0 && lb.alpha > 0)))
            L = path_add(s, L, v3_mul(beta, next_event(s, &lb, &x, wo, key, b, mt)), b >= 1);
        double rr = b >= ROULETTE_FROM ? rng_stratified(key, b, D_RR) : 0;
        if (b >= ROULETTE_FROM && rr_ends_first(&lb, beta, rr)) break;
        vec3 wi;
        bool delta, through;
        double pdf = 0;
        if (!sample_bsdf(&lb, &x, sf.color, m, wo, key, b, &wi, &beta, &delta, &pdf, &through))
            break;
        if (b >= ROULETTE_FROM) { /* Russian roulette */
            double q = roulette_chance(v3_maxabs(beta));
            if (rr >= q) break;
            beta = v3_scale(beta, 1 / q);
        }
        prev_delta = delta;
        blurry = blurry || !delta;
        prev_pdf = pdf;
        prev_p = sf.p;
        r.o = through ? x.below : x.above;
        r.d = wi;
        /* below is outward when the ray was inside */
        from = flat || x.inside == through ? leave : SCENE_NO_LEAVE;
    }
    return L;
}

vec3 path_radiance(const rayd_scene *s, const ray *r, const struct rng_key *key, struct meter *mt) {
    return path_trace(s, r, NULL, false, key, mt);
}

vec3 path_radiance_from(const rayd_scene *s, const ray *r, const struct hit *h, bool hit,
                        const struct rng_key *key, struct meter *mt) {
    return path_trace(s, r, h, hit, key, mt);
}
