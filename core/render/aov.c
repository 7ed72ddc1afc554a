/* aov.c -- the arbitrary output variables of a camera ray.
 *
 * Compositors and denoisers want, beside the beauty pass, what each
 * pixel sees: the reflectance of its surface (albedo), the surface's
 * shading normal, its distance (Z), its coverage (alpha) and which
 * object and material it is.  They are properties of the camera ray's
 * hits, not of the light, so one walk here serves both integrators: the
 * Whitted and the path tracer's pixels get the very same AOVs, and a
 * render that asks for none pays nothing but a test per block sample.
 *
 * Definitions (docs/scene-format.md, "AOVs"):
 *   - alpha: 1 when the camera ray hits anything, else 0; averaged over
 *     the samples, it is the pixel's coverage.
 *   - depth: the hit's distance along the ray from its origin (the eye, or
 *     the lens point), averaged over the samples that hit (the sums keep
 *     depth and hits apart; the resolve divides).
 *   - normal: the unit shading normal at the first hit, turned to face the
 *     camera, in world space; averaged (not renormalised).
 *   - albedo: the surface colour (texture included) at the first hit that
 *     is not a perfect specular one.  A pure mirror, a smooth metal and a
 *     pure glass pass the ray on (mirror direction, or the refracted one,
 *     reflected under total internal reflection) for up to render.max_depth
 *     bounces; a ray that escapes has albedo 0.
 *   - object and material id: those of the first hit of the pixel's first
 *     sample (sample 0, or the centre ray of a one-sample render): ids are
 *     not averaged.  The object id is the index in /objects of the object
 *     hit; a CSG operand is its CSG object, a hit inside an instance of a
 *     group (or a glTF object) is the instance.  -1 for no hit.
 *
 * Exact sums.  Each term is rounded to a multiple of 2^-22 (and capped
 * at +-RENDER_SUM_CAP) as the beauty's are (render.c), ids being whole
 * numbers: so any split of the samples into ranges, summed anywhere and
 * added in any order, gives the sums of one render bit for bit.  The ids
 * are summed too, as 1 + id from the first sample and 0 from every other,
 * which makes them exact under the same rule.
 */
#include "render/aov.h"

#include <math.h>
#include <string.h>

#include "base/error.h"
#include "render/integrate.h"
#include "render/render.h"
#include "render/srgb.h"

static double aov_term(double v) {
    if (!(v == v)) return 0; /* NaN */
    if (v > RENDER_SUM_CAP) v = RENDER_SUM_CAP;
    if (v < -RENDER_SUM_CAP) v = -RENDER_SUM_CAP;
    return nearbyint(v * RENDER_SUM_SCALE) * (1.0 / RENDER_SUM_SCALE);
}

/* A perfect specular surface: no lobe of it is spread (integrate_path.c's
 * lobes: no diffuse weight, and a metal part, if any, smooth). */
static bool aov_specular(const struct material *m) {
    double t = m->transparency, mt = m->metallic, r = m->reflectivity;
    bool diffuse = (1 - t) * (1 - mt) * (1 - r) > 0 && m->diffuse > 0;
    bool rough_metal = (1 - t) * mt > 0 && m->roughness * m->roughness >= 1e-3;
    return !diffuse && !rough_metal;
}

/* The ray a perfect specular hit passes on. */
static ray aov_bounce(const ray *r, const struct surface *sf) {
    bool entering = v3_dot(sf->ng, r->d) < 0;
    vec3 nf = v3_dot(sf->n, r->d) < 0 ? sf->n : v3_neg(sf->n);
    vec3 ngf = entering ? sf->ng : v3_neg(sf->ng);
    double off = integrate_offset(sf->p, sf->float_geom);
    vec3 above = v3_madd(sf->p, ngf, off), below = v3_madd(sf->p, ngf, -off);
    vec3 d = v3_reflect(r->d, nf);
    if (v3_dot(d, ngf) <= 0) d = v3_reflect(r->d, ngf);
    if (!(sf->m->transparency > 0)) return (ray){above, d};
    if (sf->thin) return (ray){below, r->d};
    double n1 = entering ? 1.0 : sf->m->ior, n2 = entering ? sf->m->ior : 1.0;
    double cos_i = -v3_dot(r->d, nf), cos_t = 0;
    if (material_fresnel(n1, n2, cos_i, &cos_t) >= 1) return (ray){above, d};
    return (ray){below, material_refract(r->d, nf, n1 / n2, cos_i, cos_t)};
}

/* The object id of hit h: the instance's for a hit inside one. */
static int32_t aov_object(const rayd_scene *s, const struct hit *h) {
    if (h->outer && s->inst_ids) return s->inst_ids[h->outer - s->xforms];
    return h->leaf->id;
}

/* The albedo seen along r past the specular surface sf: up to max_depth
 * more bounces. */
static vec3 aov_albedo(const rayd_scene *s, ray r, struct surface sf) {
    for (int depth = 0; aov_specular(sf.m); depth++) {
        if (depth >= s->rs.max_depth) return v3(0, 0, 0);
        r = aov_bounce(&r, &sf);
        struct hit h;
        if (!scene_intersect(s, &r, INFINITY, &h)) return v3(0, 0, 0);
        scene_surface(s, &r, &h, &sf);
    }
    return sf.color;
}

void aov_sample_hit(const rayd_scene *s, const ray *r, const struct hit *hp, bool first,
                    double sum[AOV_SUMS]) {
    struct hit h = *hp;
    struct surface sf;
    scene_surface(s, r, &h, &sf);
    vec3 n = v3_dot(sf.n, r->d) > 0 ? v3_neg(sf.n) : sf.n;
    vec3 a = aov_albedo(s, *r, sf);
    double terms[AOV_SUMS] = {a.x, a.y, a.z, n.x, n.y, n.z, h.t, 1, 0, 0};
    if (first) {
        terms[AOV_OBJECT] = 1.0 + aov_object(s, &h);
        terms[AOV_MATERIAL] = 1.0 + h.leaf->material;
    }
    for (int c = 0; c < AOV_SUMS; c++) sum[c] += aov_term(terms[c]);
}

void aov_resolve(const double sum[AOV_SUMS], int n, float out[RAYD_AOV_FLOATS]) {
    double scale = 1.0 / n, hits = sum[AOV_ALPHA];
    for (int c = AOV_ALBEDO_R; c <= AOV_NORMAL_Z; c++) out[c] = (float)(sum[c] * scale);
    out[AOV_DEPTH] = hits > 0 ? (float)(sum[AOV_DEPTH] / hits) : INFINITY; /* as compositors */
    out[AOV_ALPHA] = (float)(hits * scale);
    out[AOV_OBJECT] = (float)(sum[AOV_OBJECT] - 1);
    out[AOV_MATERIAL] = (float)(sum[AOV_MATERIAL] - 1);
}

/* 0..1 to a byte, linearly. */
static uint8_t aov_byte(double v) {
    return (uint8_t)(v <= 0 ? 0 : v >= 1 ? 255 : (int)nearbyint(v * 255));
}

/* A colour for an id, the same everywhere: the bits of a hash of it, kept
 * away from black (no hit). */
static void aov_id_colour(float id, uint8_t px[3]) {
    if (!(id >= 0)) {
        px[0] = px[1] = px[2] = 0;
        return;
    }
    uint32_t h = (uint32_t)id * 2654435761u;
    h ^= h >> 15;
    h *= 2246822519u;
    h ^= h >> 13;
    for (int c = 0; c < 3; c++) px[c] = (uint8_t)(64 + (h >> (8 * c) & 0xff) * 191 / 255);
}

void aov_pixel8(const float f[RAYD_AOV_FLOATS], unsigned which, double focus, uint8_t px[3]) {
    switch (which) {
    case RAYD_AOV_ALBEDO:
        for (int c = 0; c < 3; c++) px[c] = render_srgb8(f[AOV_ALBEDO_R + c]);
        return;
    case RAYD_AOV_NORMAL: /* the usual normal map: -1..1 to 0..255 */
        for (int c = 0; c < 3; c++) px[c] = aov_byte(0.5 + 0.5 * f[AOV_NORMAL_X + c]);
        return;
    case RAYD_AOV_DEPTH: { /* near white, focus mid-grey, far and no hit black */
        double z = f[AOV_DEPTH];
        px[0] = px[1] = px[2] = isfinite(z) ? aov_byte(focus / (focus + z)) : 0;
        return;
    }
    case RAYD_AOV_ALPHA: px[0] = px[1] = px[2] = aov_byte(f[AOV_ALPHA]); return;
    case RAYD_AOV_OBJECT: aov_id_colour(f[AOV_OBJECT], px); return;
    default: aov_id_colour(f[AOV_MATERIAL], px); return;
    }
}

/* ---- names ------------------------------------------------------------------- */

static const struct {
    const char *name;
    unsigned mask;
} aov_names[] = {{"albedo", RAYD_AOV_ALBEDO},
                 {"normal", RAYD_AOV_NORMAL},
                 {"depth", RAYD_AOV_DEPTH},
                 {"alpha", RAYD_AOV_ALPHA},
                 {"object", RAYD_AOV_OBJECT},
                 {"material", RAYD_AOV_MATERIAL},
                 {"id", RAYD_AOV_OBJECT | RAYD_AOV_MATERIAL},
                 {"all", RAYD_AOV_ALL}};

const char *rayd_aov_name(unsigned aov) {
    for (size_t i = 0; i < 6; i++)
        if (aov_names[i].mask == aov) return aov_names[i].name;
    return NULL;
}

/* The mask of the name s[0..len), 0 for none. */
static unsigned aov_lookup(const char *s, size_t len) {
    for (size_t i = 0; i < sizeof aov_names / sizeof aov_names[0]; i++)
        if (strlen(aov_names[i].name) == len && !strncmp(aov_names[i].name, s, len))
            return aov_names[i].mask;
    return 0;
}

/* The first name before p in list whose AOVs meet one (the caller saw
 * one's AOVs in the list's mask already, so there is such a name); its
 * length in *len. */
static const char *aov_earlier(const char *list, const char *p, unsigned one, size_t *len) {
    for (const char *q = list; q < p; q += *len + 1) {
        *len = strcspn(q, ",");
        if (aov_lookup(q, *len) & one) return q;
    }
    *len = 0;
    return p;
}

/* RAYD_E_ARG for the name p (len bytes), whose AOVs the list named already
 * before it: a repeat is a mistake of the caller's (a typo for another
 * name, most likely), not something to merge in silence. */
static enum rayd_status aov_repeated(const char *list, const char *p, size_t len, unsigned one,
                                     struct rayd_error *err) {
    size_t qlen;
    const char *q = aov_earlier(list, p, one, &qlen);
    int n = len > 64 ? 64 : (int)len, qn = qlen > 64 ? 64 : (int)qlen;
    if (qlen == len && !strncmp(q, p, len))
        return err_set(err, RAYD_E_ARG, "aov", "'%.*s' is named more than once", n, p);
    return err_set(err, RAYD_E_ARG, "aov", "'%.*s' names an AOV that '%.*s' named already", n, p,
                   qn, q);
}

enum rayd_status rayd_aov_parse(const char *list, unsigned *mask, struct rayd_error *err) {
    static const char known[] = "albedo, normal, depth, alpha, object, material, id or all";
    if (!list || !*list)
        return err_set(err, RAYD_E_ARG, "aov", "must name at least one AOV: %s", known);
    unsigned m = 0;
    for (const char *p = list;; p++) {
        const char *end = strchr(p, ',');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        unsigned one = aov_lookup(p, len);
        if (!one) {
            if (len == 0) return err_set(err, RAYD_E_ARG, "aov", "has an empty name in '%s'", list);
            return err_set(err, RAYD_E_ARG, "aov", "'%.*s' is no AOV; the AOVs are %s",
                           len > 64 ? 64 : (int)len, p, known);
        }
        if (one & m) return aov_repeated(list, p, len, one, err);
        m |= one;
        if (!end) break;
        p = end;
    }
    *mask = m;
    return RAYD_OK;
}
