/* scene_json_texture.c -- material textures.
 *
 *   {"type": "checker" | "stripes" | "gradient" | "image",
 *    "colors": [[r, g, b], [r, g, b]], "scale": 1, "space": "object" | "world" | "uv",
 *    "axis": [1, 0, 0],                       (stripes, gradient)
 *    "png_base64": "...", or "file": "x.png"}  (image; space is uv)
 *
 * Images are decoded once, with a pixel limit, and kept as linear floats.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "load/scene_json_texture.h"

#include "format/base64.h"
#include "render/image.h"
#include "shade/texels.h"
#include "shade/texture.h"

enum rayd_status sj_add_texture(struct loader *ld, const struct texture *t, int *index) {
    rayd_scene *s = ld->s;
    if (!array_grow((void **)&s->textures, &ld->tex_cap, (size_t)s->ntextures + 1,
                    sizeof *s->textures))
        return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    s->textures[s->ntextures] = *t;
    *index = s->ntextures++;
    return RAYD_OK;
}

/* The texels a PNG's header announces (0 if it has none to read): what
 * its decode will take is charged from it before a pixel is decoded. */
static uint64_t png_texels(const char *d, size_t len) {
    const unsigned char *b = (const unsigned char *)d;
    if (len < 24 || memcmp(b, "\x89PNG\r\n\x1a\n", 8) || memcmp(b + 12, "IHDR", 4)) return 0;
    uint64_t w = (uint64_t)b[16] << 24 | (uint64_t)b[17] << 16 | (uint64_t)b[18] << 8 | b[19];
    uint64_t h = (uint64_t)b[20] << 24 | (uint64_t)b[21] << 16 | (uint64_t)b[22] << 8 | b[23];
    return w * h;
}

/* A decoded texel: its linear floats, and the 8-bit pixels they are made
 * from, held together for a moment. */
#define SJ_TEXEL_CHARGE (3 * sizeof(float) + 4)

/* t takes the image another scene decoded from the same len bytes at
 * data (lim->assets), if one is live and fits the max pixels this scene
 * has room for; false to decode it (a bigger one is refused there, with
 * the decoder's words).  The caller charges it as a decode. */
static bool image_shared(struct loader *ld, const char *data, size_t len, long max,
                         struct texture *t) {
    struct texels *x = texels_find(ld->lim->assets, TEXELS_IMAGE, data, len, max);
    if (!x) return false;
    ld->texels += (long)x->w * x->h;
    t->w = x->w;
    t->h = x->h;
    t->rgb = x->rgb;
    t->shared = x;
    return true;
}

static enum rayd_status load_image(struct loader *ld, const cJSON *tj, const struct jp *at,
                                   struct texture *t) {
    const cJSON *b64 = cJSON_GetObjectItemCaseSensitive(tj, "png_base64");
    const cJSON *file = cJSON_GetObjectItemCaseSensitive(tj, "file");
    if (!!b64 + !!file != 1)
        return sj_fail(ld, RAYD_E_INVALID, at,
                       "an image texture needs exactly one of \"png_base64\" or \"file\"");
    struct jp p = jp_key(at, b64 ? "png_base64" : "file");
    char *data = NULL;
    size_t len = 0;
    if (file) {
        TRY(sj_read_asset(ld, file, &p, &data, &len));
    } else {
        if (!cJSON_IsString(b64))
            return sj_fail(ld, RAYD_E_INVALID, &p, "must be a string, not %s", sj_type_name(b64));
        unsigned char *bytes;
        enum rayd_status st =
            base64_decode(b64->valuestring, strlen(b64->valuestring), &bytes, &len, ld->err);
        if (st != RAYD_OK) return sj_fail(ld, st, &p, "%s", ld->err->message);
        data = (char *)bytes;
    }
    rayd_image *img = NULL;
    struct rayd_error e = {0};
    long room = sj_max_texels(ld) - ld->texels;
    if (room <= 0) { /* never 0 to the decoder: there 0 means its own default */
        free(data);
        return sj_fail(ld, RAYD_E_LIMIT, &p,
                       "the scene's image textures together are over the limit of %ld pixels",
                       sj_max_texels(ld));
    }
    long max = room < TEXTURE_MAX_PIXELS ? room : TEXTURE_MAX_PIXELS;
    uint64_t texels = png_texels(data, len);
    if (image_shared(ld, data, len, max, t)) {
        /* charged as its decode is, so the limits answer as if decoded:
         * whether another scene holds the image changes no answer */
        enum rayd_status st = sj_charge(ld, &p, (size_t)texels * SJ_TEXEL_CHARGE);
        if (st == RAYD_OK)
            sj_give_back(ld, (size_t)texels * (SJ_TEXEL_CHARGE - 3 * sizeof(float)));
        else
            texture_free(t);
        free(data);
        if (file) sj_give_back(ld, len + 1);
        return st;
    }
    enum rayd_status st = texels > 0 && texels <= (uint64_t)max
                              ? sj_charge(ld, &p, (size_t)texels * SJ_TEXEL_CHARGE)
                              : RAYD_OK; /* else the decoder refuses it */
    if (st != RAYD_OK) {
        free(data);
        return st;
    }
    st = rayd_png_decode(data, len, max, &img, &e);
    if (st == RAYD_OK) {
        ld->texels += (long)img->w * img->h;
        t->w = img->w;
        t->h = img->h;
        t->rgb = texture_linear_from_srgb8(img->px, img->w, img->h);
        rayd_image_free(img);
        if (t->rgb && ld->lim->assets) { /* the next scene of these bytes takes it */
            t->shared = texels_add(ld->lim->assets, TEXELS_IMAGE, data, len, t->w, t->h, t->rgb);
            if (!t->shared) t->rgb = NULL; /* freed */
        }
    }
    free(data);
    if (file) sj_give_back(ld, len + 1); /* the file read, charged by sj_read_asset */
    if (st != RAYD_OK) return sj_fail(ld, st, &p, "%s", e.message);
    if (texels > 0 && texels <= (uint64_t)max) /* the 8-bit pixels are gone */
        sj_give_back(ld, (size_t)texels * (SJ_TEXEL_CHARGE - 3 * sizeof(float)));
    if (!t->rgb) return err_set(ld->err, RAYD_E_NOMEM, p.s, "out of memory for a texture");
    return RAYD_OK;
}

enum rayd_status sj_texture(struct loader *ld, const cJSON *tj, const struct jp *at, int *index) {
    static const char *const types[] = {"checker", "stripes", "gradient", "image", NULL};
    static const char *const spaces[] = {"object", "world", "uv", NULL};
    static const char *const keys[] = {"type", "colors",     "scale", "space",
                                       "axis", "png_base64", "file",  NULL};
    if (!cJSON_IsObject(tj))
        return sj_fail(ld, RAYD_E_INVALID, at, "must be an object, not %s", sj_type_name(tj));
    TRY(sj_check_keys(ld, tj, at, keys));
    struct texture t;
    memset(&t, 0, sizeof t);
    int kind, space;
    TRY(sj_type(ld, tj, at, types, &kind));
    TRY(sj_enum(ld, tj, at, "space", spaces, &space));
    t.kind = (enum texture_kind)kind;
    t.space = space < 0 ? (kind == TEX_IMAGE ? TEX_UV : TEX_OBJECT) : (enum texture_space)space;
    TRY(sj_num(ld, tj, at, "scale", 1, 0, true, 1e6, &t.scale));
    vec3 axis;
    TRY(sj_vec(ld, tj, at, "axis", v3(1, 0, 0), VEC_NONZERO, &axis));
    t.axis = v3_norm(axis);
    t.a = v3(0.9, 0.9, 0.9);
    t.b = v3(0.1, 0.1, 0.1);
    const cJSON *colors = cJSON_GetObjectItemCaseSensitive(tj, "colors");
    if (colors) {
        struct jp pc = jp_key(at, "colors");
        if (!cJSON_IsArray(colors) || cJSON_GetArraySize(colors) != 2)
            return sj_fail(ld, RAYD_E_INVALID, &pc, "must be an array of 2 colours");
        struct jp p0 = jp_index(&pc, 0), p1 = jp_index(&pc, 1);
        TRY(sj_vec_value(ld, colors->child, &p0, VEC_COLOR, &t.a));
        TRY(sj_vec_value(ld, colors->child->next, &p1, VEC_COLOR, &t.b));
    }
    if (kind == TEX_IMAGE) {
        TRY(load_image(ld, tj, at, &t));
    } else if (cJSON_GetObjectItemCaseSensitive(tj, "png_base64") ||
               cJSON_GetObjectItemCaseSensitive(tj, "file")) {
        return sj_fail(ld, RAYD_E_INVALID, at, "png_base64 and file belong to image textures");
    }
    enum rayd_status st = sj_add_texture(ld, &t, index);
    if (st != RAYD_OK) texture_free(&t);
    return st;
}
