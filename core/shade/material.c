/* material.c -- material defaults and the Fresnel equations.
 *
 * The shading model is Whitted's: ambient + Lambert + Blinn-Phong for the
 * local part, plus mirror reflection and Snell refraction whose split is
 * decided by the exact (unpolarised) Fresnel equations rather than Schlick's
 * approximation, so total internal reflection falls out of the same formula.
 */
#include "shade/material.h"

void material_finish(struct material *m) {
    double e = m->shininess;
    m->shine_whole = e >= 0 && e <= 1024 && e == (double)(int)e ? (int)e : -1;
    m->plain = m->texture < 0 && m->transparency <= 0;
    m->spec_cut = 0;
    if (m->specular > 0 && m->shininess > 0) /* a hair low, so nothing above 2^-24 is cut */
        m->spec_cut = pow(0x1p-24 / m->specular, 1 / m->shininess) * (1 - 1e-9);
}

struct material material_default(void) {
    struct material m = {
        .color = {0.8, 0.8, 0.8},
        .emission = {0, 0, 0},
        .ambient = 0.1,
        .diffuse = 0.9,
        .specular = 0,
        .shininess = 32,
        .reflectivity = 0,
        .transparency = 0,
        .ior = 1.5,
        .roughness = 0,
        .metallic = 0,
        .texture = -1,
    };
    return m;
}

double material_fresnel(double n1, double n2, double cos_i, double *cos_t) {
    double eta = n1 / n2;
    double sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if (sin2_t >= 1.0) return 1.0;
    double ct = sqrt(1.0 - sin2_t);
    *cos_t = ct;
    double rs = (n1 * cos_i - n2 * ct) / (n1 * cos_i + n2 * ct);
    double rp = (n1 * ct - n2 * cos_i) / (n1 * ct + n2 * cos_i);
    return 0.5 * (rs * rs + rp * rp);
}
