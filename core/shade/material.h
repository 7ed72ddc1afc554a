/* material.h -- surface description and the optics the tracer needs. */
#ifndef MATERIAL_H
#define MATERIAL_H

#include <stdbool.h>

#include "math/vec.h"

struct material {
    vec3 color;          /* base colour, linear RGB */
    vec3 emission;       /* added as is */
    double ambient;      /* times color: the ambient term */
    double diffuse;      /* Lambert weight */
    double specular;     /* Blinn-Phong highlight weight */
    double shininess;    /* Blinn-Phong exponent */
    double reflectivity; /* mirror weight */
    double transparency; /* refracted weight, tinted by color */
    double ior;          /* index of refraction */
    double roughness;    /* path tracer: 0 smooth mirror .. 1 rough (GGX alpha = roughness^2) */
    double metallic;     /* path tracer: 0 dielectric/diffuse base, 1 conductor tinted by color */
    int texture;         /* index into the scene's textures for color, -1 none */
    /* Derived (material_finish): the highlight is skipped where cos(n, h)
     * <= spec_cut, because there specular * cos^shininess < 2^-24. */
    double spec_cut;
    int shine_whole; /* shininess as a whole number up to 1024, which the shaders
                      * raise to by squaring; -1 when it is not one (they call pow) */
    bool plain;      /* untextured and opaque: integrate_wide.c shades it */
    /* Emission from the front only (the side the geometric normal points
     * to): "emission_sides": "front", and glTF's single-sided materials.
     * The default shines both ways, as scene format v1 says. */
    bool emit_front_only;
};

/* Whether m's emission reaches a ray of direction d that meets the surface
 * whose geometric normal is ng. */
static inline bool material_emits_toward(const struct material *m, vec3 ng, vec3 d) {
    return !m->emit_front_only || v3_dot(ng, d) < 0;
}

/* Fills the derived fields from the others. */
void material_finish(struct material *m);

/* The documented defaults (docs/scene-format.md). */
struct material material_default(void);

/* Unpolarised Fresnel reflectance for a ray going from index n1 into n2 with
 * cos_i = cos of the incidence angle (> 0).  1 under total internal
 * reflection; *cos_t gets the cosine of the refracted angle otherwise. */
double material_fresnel(double n1, double n2, double cos_i, double *cos_t);

/* Snell's law: the refracted unit direction for the unit direction d
 * arriving at a surface with unit normal nf facing it, eta = n1 / n2,
 * cos_i = -d.nf and cos_t from material_fresnel. */
static inline vec3 material_refract(vec3 d, vec3 nf, double eta, double cos_i, double cos_t) {
    return v3_norm(v3_madd(v3_scale(d, eta), nf, eta * cos_i - cos_t));
}

#endif
