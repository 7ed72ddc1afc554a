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

/* nf: shading normal facing the viewer; origin: the point lifted off the
 * surface on the viewer's side, where shadow rays start. */
static vec3 shade_local(const rayd_scene *s, const struct material *m, vec3 color, vec3 p,
                        vec3 nf, vec3 origin, vec3 d, uint64_t *rays) {
    vec3 c = m->emission;
    if (s->nlights > 0) c = v3_add(c, v3_scale(color, m->ambient));
    for (int i = 0; i < s->nlights; i++) {
        vec3 to_l, rad;
        double dist;
        if (!light_at(&s->lights[i], p, &to_l, &dist, &rad)) continue;
        double ndl = v3_dot(nf, to_l);
        if (ndl <= 0) continue;
        ray sr = {origin, to_l};
        (*rays)++;
        vec3 tr = scene_transmittance(s, &sr, dist);
        if (tr.x <= 0 && tr.y <= 0 && tr.z <= 0) continue;
        rad = v3_mul(rad, tr);
        c = v3_add(c, v3_mul(rad, v3_scale(color, m->diffuse * ndl)));
        if (m->specular > 0) {
            vec3 h = v3_norm(v3_sub(to_l, d));
            double ndh = v3_dot(nf, h);
            if (ndh > 0) c = v3_add(c, v3_scale(rad, m->specular * pow(ndh, m->shininess)));
        }
    }
    return c;
}

static vec3 trace_from(const rayd_scene *s, vec3 o, vec3 d, int depth, uint64_t *rays) {
    ray r = {o, d};
    return whitted_radiance(s, &r, depth, rays);
}

vec3 whitted_radiance(const rayd_scene *s, const ray *r, int depth, uint64_t *rays) {
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
    vec3 c = shade_local(s, m, sf.color, sf.p, nf, above, r->d, rays);
    if (depth >= s->rs.max_depth) return c;

    double kr = m->reflectivity, kt = m->transparency;
    vec3 refl_dir = v3_reflect(r->d, nf);
    if (v3_dot(refl_dir, ngf) <= 0) refl_dir = v3_reflect(r->d, ngf);
    if (kt <= 0) {
        if (kr > 0) c = v3_madd(c, trace_from(s, above, refl_dir, depth + 1, rays), kr);
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
    if (wr > 0) c = v3_madd(c, trace_from(s, above, refl_dir, depth + 1, rays), wr);
    if (fr < 1) {
        vec3 refr = trace_from(s, below, tdir, depth + 1, rays);
        c = v3_add(c, v3_mul(refr, v3_scale(sf.color, kt * (1 - fr))));
    }
    return c;
}
