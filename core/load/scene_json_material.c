/* scene_json_material.c -- materials: the named ones of /materials and
 * the inline ones of objects.
 *
 * Index 0 is the default material; named materials follow in the order of
 * /materials, and inline ones after them as objects bring them.  Objects
 * name materials by key, so the names are kept sorted for a binary search:
 * a million objects naming ten thousand materials must not scan.
 */
#include <stdlib.h>
#include <string.h>

#include "load/scene_json_material.h"
#include "load/scene_json_texture.h"

static enum rayd_status material(struct loader *ld, const cJSON *m, const struct jp *at,
                                 struct material *out) {
    static const char *const keys[] = {
        "color", "ambient",  "diffuse",   "specular", "shininess", "reflectivity",   "transparency",
        "ior",   "emission", "roughness", "metallic", "texture",   "emission_sides", NULL};
    static const char *const sides[] = {"both", "front", NULL};
    TRY(sj_check_keys(ld, m, at, keys));
    struct material d = material_default();
    *out = d;
    TRY(sj_vec(ld, m, at, "color", d.color, VEC_COLOR, &out->color));
    TRY(sj_vec(ld, m, at, "emission", d.emission, VEC_COLOR, &out->emission));
    int side;
    TRY(sj_enum(ld, m, at, "emission_sides", sides, &side));
    out->emit_front_only = side == 1;
    TRY(sj_num(ld, m, at, "ambient", d.ambient, 0, false, 1, &out->ambient));
    TRY(sj_num(ld, m, at, "diffuse", d.diffuse, 0, false, 1, &out->diffuse));
    TRY(sj_num(ld, m, at, "specular", d.specular, 0, false, 1, &out->specular));
    TRY(sj_num(ld, m, at, "shininess", d.shininess, 0, false, 10000, &out->shininess));
    TRY(sj_num(ld, m, at, "reflectivity", d.reflectivity, 0, false, 1, &out->reflectivity));
    TRY(sj_num(ld, m, at, "transparency", d.transparency, 0, false, 1, &out->transparency));
    TRY(sj_num(ld, m, at, "ior", d.ior, 0, true, 10, &out->ior));
    TRY(sj_num(ld, m, at, "roughness", d.roughness, 0, false, 1, &out->roughness));
    TRY(sj_num(ld, m, at, "metallic", d.metallic, 0, false, 1, &out->metallic));
    const cJSON *tex = cJSON_GetObjectItemCaseSensitive(m, "texture");
    if (tex) {
        struct jp pt = jp_key(at, "texture");
        TRY(sj_texture(ld, tex, &pt, &out->texture));
    }
    return RAYD_OK;
}

enum rayd_status sj_add_material(struct loader *ld, const struct material *m, int *index) {
    rayd_scene *s = ld->s;
    if (!array_grow((void **)&s->mats, &ld->mat_cap, (size_t)s->nmats + 1, sizeof *s->mats))
        return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    s->mats[s->nmats] = *m;
    material_finish(&s->mats[s->nmats]);
    *index = s->nmats++;
    return RAYD_OK;
}

/* Named materials take indices 1..n in the order of /materials; index 0 is
 * the default material. */
enum rayd_status sj_materials(struct loader *ld, const cJSON *root) {
    struct material def = material_default();
    int idx;
    TRY(sj_add_material(ld, &def, &idx));
    const cJSON *ms = cJSON_GetObjectItemCaseSensitive(root, "materials");
    if (!ms) return RAYD_OK;
    struct jp at = {.s = "/materials"};
    TRY(sj_check_keys(ld, ms, &at, NULL));
    if (cJSON_GetArraySize(ms) > ld->lim->max_materials)
        return sj_fail(ld, RAYD_E_LIMIT, &at, "has %d materials; the limit is %d",
                       cJSON_GetArraySize(ms), ld->lim->max_materials);
    for (const cJSON *m = ms->child; m; m = m->next) {
        struct jp p = jp_key(&at, m->string);
        if (m->string[0] == '\0')
            return sj_fail(ld, RAYD_E_INVALID, &p, "a material name may not be empty");
        struct material mat;
        TRY(material(ld, m, &p, &mat));
        TRY(sj_add_material(ld, &mat, &idx));
    }
    return sj_names_sorted(ld, ms, 1, &ld->mat_names, &ld->nmat_names);
}

/* The "material" key of an object: absent (default), a name, or inline. */
enum rayd_status sj_object_material(struct loader *ld, const cJSON *obj, const struct jp *at,
                                    int inherit, int *index) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, "material");
    *index = inherit;
    if (!v) return RAYD_OK;
    struct jp p = jp_key(at, "material");
    if (cJSON_IsObject(v)) {
        struct material mat;
        if (ld->s->nmats > ld->lim->max_materials)
            return sj_fail(ld, RAYD_E_LIMIT, &p,
                           "is past the limit of %d materials (named and inline)",
                           ld->lim->max_materials);
        TRY(material(ld, v, &p, &mat));
        return sj_add_material(ld, &mat, index);
    }
    if (!cJSON_IsString(v))
        return sj_fail(ld, RAYD_E_INVALID, &p,
                       "must be a material name or a material object, not %s", sj_type_name(v));
    const struct named *hit = sj_name_find(ld->mat_names, ld->nmat_names, v->valuestring);
    if (hit) {
        *index = hit->index;
        return RAYD_OK;
    }
    char q[96];
    return sj_fail(ld, RAYD_E_INVALID, &p, "unknown material \"%s\" (not a key of /materials)",
                   jp_quote(q, sizeof q, v->valuestring));
}
