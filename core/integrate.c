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
 */
#include "integrate.h"

vec3 integrate_visible(const rayd_scene *s, vec3 origin, vec3 to_light, double dist,
                       uint64_t *rays) {
    ray sr = {origin, to_light};
    (*rays)++;
    return scene_transmittance(s, &sr, dist);
}

bool integrate_light_sample(const rayd_scene *s, const struct light *l, vec3 p, vec3 nf,
                            vec3 origin, double su, double sv, vec3 *wi, vec3 *radiance,
                            uint64_t *rays) {
    double dist;
    if (l->kind == LIGHT_AREA) {
        vec3 q = light_area_point(l, p, su, sv), d = v3_sub(q, origin);
        dist = v3_len(d);
        if (!(dist > 0)) return false;
        *wi = v3_scale(d, 1 / dist);
        *radiance = v3_scale(l->color, l->intensity);
    } else if (!light_at(l, p, wi, &dist, radiance)) {
        return false;
    }
    if (v3_dot(nf, *wi) <= 0) return false;
    vec3 tr = integrate_visible(s, origin, *wi, dist, rays);
    if (tr.x <= 0 && tr.y <= 0 && tr.z <= 0) return false;
    *radiance = v3_mul(*radiance, tr);
    return true;
}

/* Lambert + Blinn-Phong from one light direction. */
static vec3 shade_one(const struct material *m, vec3 color, vec3 nf, vec3 d, vec3 wi, vec3 rad) {
    vec3 c = v3_mul(rad, v3_scale(color, m->diffuse * v3_dot(nf, wi)));
    if (m->specular > 0) {
        vec3 h = v3_norm(v3_sub(wi, d));
        double ndh = v3_dot(nf, h);
        if (ndh > 0) c = v3_add(c, v3_scale(rad, m->specular * pow(ndh, m->shininess)));
    }
    return c;
}

/* nf: shading normal facing the viewer; origin: the point lifted off the
 * surface on the viewer's side, where shadow rays start.  An area light is
 * the average of `samples` point lights spread over it, stratified. */
static vec3 shade_local(const rayd_scene *s, const struct material *m, vec3 color, vec3 p,
                        vec3 nf, vec3 origin, vec3 d, int depth, const struct rng_key *key,
                        uint64_t *rays) {
    vec3 c = m->emission;
    if (s->nlights > 0) c = v3_add(c, v3_scale(color, m->ambient));
    for (int i = 0; i < s->nlights; i++) {
        const struct light *l = &s->lights[i];
        int n = l->kind == LIGHT_AREA ? l->samples : 1;
        int gx = (int)ceil(sqrt((double)n)), gy = (n + gx - 1) / gx;
        vec3 sum = v3(0, 0, 0);
        for (int k = 0; k < n; k++) {
            double su = 0.5, sv = 0.5;
            if (l->kind == LIGHT_AREA) {
                su = (k % gx + rng_uniform(key, (uint32_t)depth, RNG_AREA_DIM(i, k))) / gx;
                sv = (k / gx + rng_uniform(key, (uint32_t)depth, RNG_AREA_DIM(i, k) + 1)) / gy;
            }
            vec3 wi, rad;
            if (integrate_light_sample(s, l, p, nf, origin, su, sv, &wi, &rad, rays))
                sum = v3_add(sum, shade_one(m, color, nf, d, wi, rad));
        }
        c = v3_madd(c, sum, 1.0 / n);
    }
    return c;
}

static vec3 trace_from(const rayd_scene *s, vec3 o, vec3 d, int depth, const struct rng_key *key,
                       uint64_t *rays) {
    ray r = {o, d};
    return whitted_radiance(s, &r, depth, key, rays);
}

vec3 whitted_radiance(const rayd_scene *s, const ray *r, int depth, const struct rng_key *key,
                      uint64_t *rays) {
    (*rays)++;
    struct hit h;
    if (!scene_intersect(s, r, INFINITY, &h)) return s->rs.background;
    struct surface sf;
    scene_surface(s, r, &h, &sf);
    const struct material *m = sf.m;
    bool inside = v3_dot(sf.ng, r->d) > 0;
    vec3 ngf = inside ? v3_neg(sf.ng) : sf.ng; /* faces the incoming ray */
    vec3 nf = inside ? v3_neg(sf.n) : sf.n;
    if (v3_dot(nf, ngf) < 0) nf = ngf; /* an interpolated normal past the silhouette */
    double off = integrate_offset(sf.p, sf.float_geom);
    vec3 above = v3_madd(sf.p, ngf, off), below = v3_madd(sf.p, ngf, -off);
    vec3 c = shade_local(s, m, sf.color, sf.p, nf, above, r->d, depth, key, rays);
    if (depth >= s->rs.max_depth) return c;

    double kr = m->reflectivity, kt = m->transparency;
    vec3 refl_dir = v3_reflect(r->d, nf);
    if (v3_dot(refl_dir, ngf) <= 0) refl_dir = v3_reflect(r->d, ngf);
    if (kt <= 0) {
        if (kr > 0) c = v3_madd(c, trace_from(s, above, refl_dir, depth + 1, key, rays), kr);
        return c;
    }
    double cos_i = -v3_dot(r->d, nf), cos_t = 0, fr;
    vec3 tdir;
    if (sf.thin) { /* thin surface: no bending, no Fresnel split */
        fr = 0;
        tdir = r->d;
    } else {
        double n1 = inside ? m->ior : 1.0, n2 = inside ? 1.0 : m->ior;
        fr = material_fresnel(n1, n2, cos_i, &cos_t);
        tdir = material_refract(r->d, nf, n1 / n2, cos_i, cos_t);
    }
    c = v3_scale(c, 1.0 - kt);
    double wr = kr + kt * fr;
    if (wr > 0) c = v3_madd(c, trace_from(s, above, refl_dir, depth + 1, key, rays), wr);
    if (fr < 1) {
        vec3 refr = trace_from(s, below, tdir, depth + 1, key, rays);
        c = v3_add(c, v3_mul(refr, v3_scale(sf.color, kt * (1 - fr))));
    }
    return c;
}
