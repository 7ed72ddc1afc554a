/* gltf_material.c -- glTF 2.0 PBR metallic-roughness materials as rayd
 * materials, for the "gltf" object (scene_json_gltf.c).
 *
 * rayd's material is a Whitted (Phong) material with a path tracer's
 * metallic and roughness on top, so a glTF material maps onto both: the
 * path tracer gets glTF's own numbers (colour, metallic, roughness,
 * emission), and the Whitted keys are derived so that a smooth or metallic
 * glTF looks glossy there too: a Blinn-Phong exponent equivalent to the
 * GGX roughness (2 / alpha^2 - 2, alpha = roughness^2), a highlight weight
 * that fades as the surface gets rough, and a mirror weight for smooth
 * metals, taken off the diffuse weight.  docs/scene-format.md ("glTF
 * scenes") has the table.
 *
 * The base colour texture is the only texture read: rayd's textures give
 * a colour in place of the material's, so baseColorFactor is baked into
 * the texels here (linear RGB, after the sRGB decode).  Images come from
 * a bufferView or a URI (data: or a relative file, through the reader's
 * opener) and are PNG (png.c) or JPEG (stb_image, the library .hdr maps
 * use), each at most 4096 x 4096 and all of them together no more texels
 * than one such image.  A decoded texture (its factor baked in) is shared
 * with the scenes of the same image bytes and factor (shade/texels.c), so
 * the frames of an animation decode it once.  The texture's alpha, its sampler's wrap modes
 * (rayd repeats) and KHR_texture_transform are ignored; normal, occlusion,
 * emissive and metallic-roughness textures too.
 *
 * Every value is checked (type and range) and a wrong one refused with its
 * JSON Pointer inside the glTF document, as mesh_gltf.c does.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <stb/stb_image.h>

#include "load/gltf_material.h"

#include "base/error.h"
#include "format/gltf_json.h"
#include "render/image.h"
#include "shade/texels.h"

/* n numbers at o[key], each in [lo, hi], into out; def when absent. */
static enum rayd_status gm_nums(struct rayd_error *err, const cJSON *o, const struct jp *at,
                                const char *key, int n, const double *def, double lo, double hi,
                                double *out) {
    const cJSON *v = gl_get(o, key);
    struct jp p = jp_key(at, key);
    if (!v) {
        memcpy(out, def, sizeof *out * (size_t)n);
        return RAYD_OK;
    }
    bool one = n == 1 && cJSON_IsNumber(v);
    if (!one && (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != n || n == 1))
        return n == 1 ? err_set(err, RAYD_E_INVALID, p.s, "must be a number")
                      : err_set(err, RAYD_E_INVALID, p.s, "must be an array of %d numbers", n);
    /* n entries, each written or refused (a NULL e is no number) */
    const cJSON *e = one ? v : v->child;
    for (int i = 0; i < n; i++, e = e ? e->next : NULL) {
        if (!cJSON_IsNumber(e) || !(e->valuedouble >= lo && e->valuedouble <= hi))
            return err_set(err, RAYD_E_INVALID, p.s, "must be %s in [%g, %g]",
                           n == 1 ? "a number" : "numbers", lo, hi);
        out[i] = e->valuedouble;
    }
    return RAYD_OK;
}

static enum rayd_status gm_num(struct rayd_error *err, const cJSON *o, const struct jp *at,
                               const char *key, double def, double lo, double hi, double *out) {
    return gm_nums(err, o, at, key, 1, &def, lo, hi, out);
}

/* ---- the mapping ---------------------------------------------------------- */

struct material gltf_pbr_material(const struct gltf_pbr *p) {
    struct material m = material_default();
    double r = p->roughness, a2 = r * r * r * r; /* alpha = roughness^2 */
    m.color = v3(p->base[0], p->base[1], p->base[2]);
    m.metallic = p->metallic;
    m.roughness = r;
    m.emission = v3(p->emissive[0], p->emissive[1], p->emissive[2]);
    m.emit_front_only = !p->double_sided;
    /* Whitted: a Blinn-Phong lobe as wide as the GGX one, fading as the
     * surface gets rough; smooth metals a mirror, off the diffuse weight */
    m.shininess = fmin(10000, fmax(1, 2 / fmax(a2, 1e-6) - 2));
    m.specular = (0.25 + 0.75 * p->metallic) * (1 - r);
    m.reflectivity = p->metallic * (1 - r) * (1 - r);
    m.diffuse = 1 - m.reflectivity;
    bool see_through =
        (p->alpha_mode == 2 && p->base[3] < 1) || (p->alpha_mode == 1 && p->base[3] < p->cutoff);
    if (see_through) {
        m.transparency = p->alpha_mode == 1 ? 1 : 1 - p->base[3];
        m.ior = p->ior;
    }
    return m;
}

/* ---- images ----------------------------------------------------------------- */

/* The bytes an image of w x h pixels takes here: its 8-bit pixels, then
 * its linear floats (the 8-bit ones given back once converted). */
#define GM_PIXEL_CHARGE (3 + 3 * sizeof(float))
#define GM_TEXEL_CHARGE (3 * sizeof(float)) /* the floats alone: the 8-bit pixels are not its */

/* Charges, or gives back, what makes *charged (the image's) equal w x h
 * pixels' worth. */
static enum rayd_status gm_charge_px(struct gltf_mats *g, size_t *charged, long w, long h,
                                     size_t per_px, const struct jp *p, struct rayd_error *err) {
    size_t want = (size_t)w * (size_t)h * per_px;
    if (want <= *charged) {
        mesh_give_back(g->lim, &g->charged, *charged - want);
        *charged = want;
        return RAYD_OK;
    }
    char why[200];
    enum rayd_status st = mesh_charge(g->lim, &g->charged, want - *charged, why, sizeof why);
    if (st != RAYD_OK)
        return err_set(err, st, p->s, "the image is %ld x %ld pixels: %s", w, h, why);
    *charged = want;
    return RAYD_OK;
}

/* gm_charge_px of a decode: its 8-bit pixels and its floats. */
static enum rayd_status gm_charge(struct gltf_mats *g, size_t *charged, long w, long h,
                                  const struct jp *p, struct rayd_error *err) {
    return gm_charge_px(g, charged, w, h, GM_PIXEL_CHARGE, p, err);
}

/* A PNG's size from its IHDR (the first chunk), before it is decoded; 0
 * x 0 when unreadable (the decoder then says why). */
static void gm_png_size(const unsigned char *b, size_t len, long *w, long *h) {
    *w = *h = 0;
    if (len < 24 || memcmp(b + 12, "IHDR", 4)) return;
    *w = (long)((uint32_t)b[16] << 24 | (uint32_t)b[17] << 16 | (uint32_t)b[18] << 8 | b[19]);
    *h = (long)((uint32_t)b[20] << 24 | (uint32_t)b[21] << 16 | (uint32_t)b[22] << 8 | b[23]);
    if (*w <= 0 || *h <= 0 || *w > 65535 || *h > 65535) *w = *h = 0;
}

/* A w x h image within a texture's limit and what is left of the file's
 * texture budget, or RAYD_E_LIMIT saying both. */
static enum rayd_status gm_fits(struct rayd_error *err, const struct jp *p, long w, long h,
                                long budget) {
    long max = budget < TEXTURE_MAX_PIXELS ? budget : TEXTURE_MAX_PIXELS;
    if (w * h <= max) return RAYD_OK;
    return err_set(err, RAYD_E_LIMIT, p->s,
                   "the image is %ld x %ld pixels; the limit is %ld pixels (%ld left of the "
                   "file's textures)",
                   w, h, TEXTURE_MAX_PIXELS, budget > 0 ? budget : 0);
}

/* Decoded 8-bit sRGB pixels of a PNG or a JPEG, into *img, charged (into
 * *charged) from the header's size before they are decoded. */
static enum rayd_status gm_decode(struct rayd_error *err, const unsigned char *b, size_t len,
                                  const struct jp *p, long budget, struct gltf_mats *g,
                                  size_t *charged, rayd_image **img) {
    struct rayd_error e = {0};
    if (budget <= 0) /* and never 0 to the PNG decoder: there 0 means its own default */
        return err_set(err, RAYD_E_LIMIT, p->s,
                       "the textures together are over the limit (%ld pixels a glTF file, %ld "
                       "a scene)",
                       (long)GLTF_MAX_TEXELS, (long)TEXTURE_MAX_SCENE_PIXELS);
    long max = budget < TEXTURE_MAX_PIXELS ? budget : TEXTURE_MAX_PIXELS;
    if (len >= 8 && !memcmp(b, "\x89PNG", 4)) {
        long w, h;
        gm_png_size(b, len, &w, &h);
        if (w * h <= max)
            TRY_GL(gm_charge(g, charged, w, h, p, err)); /* else the decoder refuses */
        enum rayd_status st = rayd_png_decode(b, len, max, img, &e);
        if (st != RAYD_OK) return err_set(err, st, p->s, "%s", e.message);
        return gm_charge(g, charged, (*img)->w, (*img)->h, p, err); /* the same, as decoded */
    }
    if (len < 3 || b[0] != 0xFF || b[1] != 0xD8 || b[2] != 0xFF)
        return err_set(err, RAYD_E_INVALID, p->s, "is neither a PNG nor a JPEG image");
    if (len > (size_t)0x7fffffff) return err_set(err, RAYD_E_LIMIT, p->s, "the image is too large");
    int w, h, n;
    if (!stbi_info_from_memory(b, (int)len, &w, &h, &n) || w <= 0 || h <= 0)
        return err_set(err, RAYD_E_INVALID, p->s, "is not a readable JPEG image");
    TRY_GL(gm_fits(err, p, w, h, budget));
    TRY_GL(gm_charge(g, charged, w, h, p, err));
    int w2, h2;
    stbi_uc *px = stbi_load_from_memory(b, (int)len, &w2, &h2, &n, 3);
    if (!px) return err_set(err, RAYD_E_INVALID, p->s, "cannot decode the JPEG image");
    if (w2 != w || h2 != h) {
        stbi_image_free(px);
        return err_set(err, RAYD_E_INVALID, p->s, "the JPEG image's size changed while decoding");
    }
    *img = calloc(1, sizeof **img);
    size_t m = (size_t)w * (size_t)h * 3;
    if (*img) (*img)->px = malloc(m); /* stb's allocator is its own: copy into ours */
    if (!*img || !(*img)->px) {
        stbi_image_free(px);
        rayd_image_free(*img);
        *img = NULL; /* the caller frees what it is handed */
        return err_set(err, RAYD_E_NOMEM, p->s, "out of memory for a texture");
    }
    memcpy((*img)->px, px, m);
    (*img)->w = w, (*img)->h = h;
    stbi_image_free(px);
    return RAYD_OK;
}

/* Image i's decoded pixels (gm_decode) into *img, this material charged
 * its texels' 12 bytes a pixel: decoded here once a file, then kept
 * for the other materials of the same image (g->decoded), so a file
 * naming one image from many materials costs one decode, not one each.
 * The kept copy holds the 8-bit share of its first material's charge
 * (gm_decode's 15 bytes a pixel) until gm_forget frees it once the
 * materials are read; *img is g's. */
static enum rayd_status gm_decoded(struct rayd_error *err, const unsigned char *b, size_t len,
                                   const struct jp *p, long budget, struct gltf_mats *g, int i,
                                   size_t *charged, const rayd_image **img) {
    for (int k = 0; k < g->ndecoded; k++) {
        if (g->decoded[k].image != i) continue;
        *img = g->decoded[k].img;
        TRY_GL(gm_fits(err, p, (*img)->w, (*img)->h, budget));
        return gm_charge_px(g, charged, (*img)->w, (*img)->h, GM_TEXEL_CHARGE, p, err);
    }
    rayd_image *own = NULL;
    enum rayd_status st = gm_decode(err, b, len, p, budget, g, charged, &own);
    if (st != RAYD_OK || g->ndecoded == GLTF_MAX_TEXTURES) {
        rayd_image_free(own);
        return st == RAYD_OK ? err_set(err, RAYD_E_LIMIT, p->s, "too many images") : st;
    }
    *charged -= 3 * (size_t)own->w * (size_t)own->h; /* the kept copy's now, in g->charged */
    g->decoded[g->ndecoded++] = (struct gltf_decoded){i, own};
    g->decodes++;
    *img = own;
    return RAYD_OK;
}

/* The images gm_decoded kept, freed and their charge given back: the
 * materials are read. */
static void gm_forget(struct gltf_mats *g) {
    for (int i = 0; i < g->ndecoded; i++) {
        const rayd_image *img = g->decoded[i].img;
        mesh_give_back(g->lim, &g->charged, 3 * (size_t)img->w * (size_t)img->h);
        rayd_image_free(g->decoded[i].img);
    }
    g->ndecoded = 0;
}

/* The image in b as linear texels with factor baked in, into t: taken
 * from a live scene of the same bytes and factor (g->assets), or decoded
 * and offered to the next (a frame of an animation takes them, rather
 * than decoding them again); charged as decoded either way.  On failure
 * t may hold texels to free. */
static enum rayd_status gm_texels(struct rayd_error *err, const unsigned char *b, size_t len,
                                  const struct jp *p, long budget, struct gltf_mats *g, int image,
                                  const double *factor, size_t *charged, struct texture *t) {
    size_t klen = 3 * sizeof *factor + len;
    unsigned char *key = g->assets ? malloc(klen) : NULL;
    if (key) {
        memcpy(key, factor, 3 * sizeof *factor);
        memcpy(key + 3 * sizeof *factor, b, len);
    }
    long max = budget < TEXTURE_MAX_PIXELS ? budget : TEXTURE_MAX_PIXELS;
    struct texels *x = key && max > 0 ? texels_find(g->assets, TEXELS_GLTF, key, klen, max) : NULL;
    enum rayd_status st = RAYD_OK;
    if (x) { /* charged as its decode is: the limits answer as if decoded */
        t->w = x->w, t->h = x->h, t->rgb = x->rgb, t->shared = x;
        st = gm_charge_px(g, charged, x->w, x->h, GM_TEXEL_CHARGE, p, err); /* its floats */
    } else {
        const rayd_image *img = NULL;
        st = gm_decoded(err, b, len, p, budget, g, image, charged, &img);
        if (st == RAYD_OK) {
            t->w = img->w, t->h = img->h;
            t->rgb = texture_linear_from_srgb8(img->px, img->w, img->h);
        }
        if (st == RAYD_OK && !t->rgb)
            st = err_set(err, RAYD_E_NOMEM, p->s, "out of memory for a texture");
        for (size_t k = 0; st == RAYD_OK && k < (size_t)t->w * (size_t)t->h * 3; k++)
            t->rgb[k] *= (float)factor[k % 3];
        if (st == RAYD_OK && key &&
            !(t->shared = texels_add(g->assets, TEXELS_GLTF, key, klen, t->w, t->h, t->rgb))) {
            t->rgb = NULL; /* freed */
            st = err_set(err, RAYD_E_NOMEM, p->s, "out of memory for a texture");
        }
    }
    free(key);
    return st;
}

/* The image /images/i: its bytes from a bufferView or a URI, as texels
 * (gm_texels). */
static enum rayd_status gm_image(struct gltf_doc *d, struct rayd_error *err, int i, long budget,
                                 struct gltf_mats *g, const double *factor, size_t *charged,
                                 struct texture *t) {
    const cJSON *ij = cJSON_GetArrayItem(gl_get(gltf_doc_root(d), "images"), i);
    struct jp p = {.s = ""};
    snprintf(p.s, sizeof p.s, "/images/%d", i);
    if (!cJSON_IsObject(ij)) return err_set(err, RAYD_E_INVALID, p.s, "must be an object");
    const cJSON *uri = gl_get(ij, "uri"), *view = gl_get(ij, "bufferView");
    struct jp pu = jp_key(&p, uri ? "uri" : "bufferView");
    if (!!uri + !!view != 1)
        return err_set(err, RAYD_E_INVALID, p.s, "needs exactly one of \"uri\" and \"bufferView\"");
    if (view) {
        const unsigned char *b;
        size_t len;
        TRY_GL(gltf_doc_view(d, ij, p.s, "bufferView", &b, &len));
        return gm_texels(err, b, len, &pu, budget, g, i, factor, charged, t);
    }
    if (!cJSON_IsString(uri)) return err_set(err, RAYD_E_INVALID, pu.s, "must be a string");
    unsigned char *b;
    size_t len;
    TRY_GL(gltf_doc_uri(d, uri->valuestring, pu.s, &b, &len));
    enum rayd_status st = gm_texels(err, b, len, &pu, budget, g, i, factor, charged, t);
    free(b);
    return st;
}

/* The texture info ti (baseColorTexture at p): the image, decoded, with
 * the factor baked into linear texels. */
static enum rayd_status gm_texture(struct gltf_doc *d, struct rayd_error *err, const cJSON *ti,
                                   const struct jp *p, const double *factor, struct gltf_mats *g,
                                   long *texels, int *uv_set) {
    const cJSON *texs = gl_get(gltf_doc_root(d), "textures");
    int ntex = cJSON_IsArray(texs) ? cJSON_GetArraySize(texs) : 0;
    double index, set, source;
    if (!cJSON_IsObject(ti)) return err_set(err, RAYD_E_INVALID, p->s, "must be an object");
    /* any number first, then the range here: a message that names what an
     * index must be, and says so when the file has no textures at all */
    TRY_GL(gm_num(err, ti, p, "index", -1, -HUGE_VAL, HUGE_VAL, &index));
    TRY_GL(gm_num(err, ti, p, "texCoord", 0, -HUGE_VAL, HUGE_VAL, &set));
    struct jp pi = jp_key(p, "index"), pc = jp_key(p, "texCoord");
    if (ntex == 0)
        return err_set(err, RAYD_E_INVALID, pi.s, "names a texture, but the file has no /textures");
    if (index < 0 || index >= ntex || floor(index) != index)
        return err_set(err, RAYD_E_INVALID, pi.s, "must be a texture index in 0..%d", ntex - 1);
    if (set < 0 || set > 7 || floor(set) != set)
        return err_set(err, RAYD_E_INVALID, pc.s,
                       "must be an integer in 0..7 (TEXCOORD_0 to TEXCOORD_7)");
    if (g->ntex >= GLTF_MAX_TEXTURES)
        return err_set(err, RAYD_E_LIMIT, p->s, "is past the limit of %d textured materials",
                       GLTF_MAX_TEXTURES);
    const cJSON *tj = cJSON_GetArrayItem(texs, (int)index);
    struct jp pt = {.s = ""};
    snprintf(pt.s, sizeof pt.s, "/textures/%d", (int)index);
    int nimg = cJSON_GetArraySize(gl_get(gltf_doc_root(d), "images"));
    TRY_GL(gm_num(err, tj, &pt, "source", -1, -HUGE_VAL, HUGE_VAL, &source));
    struct jp ps = jp_key(&pt, "source");
    if (nimg == 0)
        return err_set(err, RAYD_E_INVALID, ps.s,
                       "the file has no /images (images of other extensions are not read)");
    if (source < 0 || source >= nimg || floor(source) != source)
        return err_set(err, RAYD_E_INVALID, ps.s,
                       "must be an image index in 0..%d (other image extensions are not read)",
                       nimg - 1);
    struct texture t = {.kind = TEX_IMAGE, .space = TEX_UV, .scale = 1};
    size_t charged = 0; /* this image's, in g->charged */
    enum rayd_status st =
        gm_image(d, err, (int)source, g->budget - *texels, g, factor, &charged, &t);
    if (st != RAYD_OK) {
        texture_free(&t);
        mesh_give_back(g->lim, &g->charged, charged);
        return st;
    }
    *texels += (long)t.w * t.h;
    g->tex[g->ntex++] = t;
    *uv_set = (int)set;
    return RAYD_OK;
}

/* ---- materials --------------------------------------------------------------- */

static enum rayd_status gm_alpha_mode(struct rayd_error *err, const cJSON *mj, const struct jp *p,
                                      int *mode) {
    static const char *const modes[] = {"OPAQUE", "MASK", "BLEND"};
    const cJSON *v = gl_get(mj, "alphaMode");
    struct jp pa = jp_key(p, "alphaMode");
    *mode = 0;
    if (!v) return RAYD_OK;
    for (int i = 0; i < 3 && cJSON_IsString(v); i++)
        if (!strcmp(v->valuestring, modes[i])) return *mode = i, RAYD_OK;
    return err_set(err, RAYD_E_INVALID, pa.s, "must be \"OPAQUE\", \"MASK\" or \"BLEND\"");
}

/* doubleSided: false when absent, as glTF says. */
static enum rayd_status gm_double_sided(struct rayd_error *err, const cJSON *mj, const struct jp *p,
                                        bool *out) {
    const cJSON *v = gl_get(mj, "doubleSided");
    *out = cJSON_IsTrue(v);
    if (!v || cJSON_IsBool(v)) return RAYD_OK;
    struct jp pd = jp_key(p, "doubleSided");
    return err_set(err, RAYD_E_INVALID, pd.s, "must be true or false");
}

/* Material mj at p (NULL: glTF's default material). */
static enum rayd_status gm_material(struct gltf_doc *d, struct rayd_error *err, const cJSON *mj,
                                    const struct jp *p, struct gltf_mats *g, int i, long *texels) {
    static const double white[4] = {1, 1, 1, 1}, black[3] = {0, 0, 0};
    struct gltf_pbr pbr;
    if (mj && !cJSON_IsObject(mj)) return err_set(err, RAYD_E_INVALID, p->s, "must be an object");
    const cJSON *pj = gl_get(mj, "pbrMetallicRoughness"), *ext = gl_get(mj, "extensions");
    struct jp pp = jp_key(p, "pbrMetallicRoughness"), pe = jp_key(p, "extensions");
    if (pj && !cJSON_IsObject(pj)) return err_set(err, RAYD_E_INVALID, pp.s, "must be an object");
    TRY_GL(gm_nums(err, pj, &pp, "baseColorFactor", 4, white, 0, 1, pbr.base));
    TRY_GL(gm_num(err, pj, &pp, "metallicFactor", 1, 0, 1, &pbr.metallic));
    TRY_GL(gm_num(err, pj, &pp, "roughnessFactor", 1, 0, 1, &pbr.roughness));
    TRY_GL(gm_nums(err, mj, p, "emissiveFactor", 3, black, 0, 1, pbr.emissive));
    TRY_GL(gm_alpha_mode(err, mj, p, &pbr.alpha_mode));
    TRY_GL(gm_num(err, mj, p, "alphaCutoff", 0.5, 0, 1e6, &pbr.cutoff));
    TRY_GL(gm_double_sided(err, mj, p, &pbr.double_sided));
    const cJSON *es = gl_get(ext, "KHR_materials_emissive_strength");
    const cJSON *ij = gl_get(ext, "KHR_materials_ior");
    struct jp pes = jp_key(&pe, "KHR_materials_emissive_strength");
    struct jp pior = jp_key(&pe, "KHR_materials_ior");
    double strength, ior;
    TRY_GL(gm_num(err, es, &pes, "emissiveStrength", 1, 0, 1e6, &strength));
    TRY_GL(gm_num(err, ij, &pior, "ior", 1, 0, 10, &ior));
    for (int k = 0; k < 3; k++) pbr.emissive[k] *= strength;
    pbr.ior = ior > 0 ? ior : 1; /* glTF's ior 0 is "a perfect reflector": ignored */
    g->m[i] = gltf_pbr_material(&pbr);
    g->uv_set[i] = -1;
    const cJSON *ti = gl_get(pj, "baseColorTexture");
    if (!ti) return RAYD_OK;
    struct jp pt = jp_key(&pp, "baseColorTexture");
    g->m[i].texture = g->ntex;
    return gm_texture(d, err, ti, &pt, pbr.base, g, texels, &g->uv_set[i]);
}

enum rayd_status gltf_mats_read(struct gltf_doc *d, int max, long texels,
                                const struct mesh_limits *lim, struct rayd_asset_cache *assets,
                                struct gltf_mats *out, struct rayd_error *err) {
    const cJSON *ms = gl_get(gltf_doc_root(d), "materials");
    struct jp at = {.s = "/materials"};
    memset(out, 0, sizeof *out);
    out->lim = lim;
    out->assets = assets;
    if (ms && !cJSON_IsArray(ms)) return err_set(err, RAYD_E_INVALID, at.s, "must be an array");
    int n = ms ? cJSON_GetArraySize(ms) : 0;
    if (max > GLTF_MAX_MATERIALS) max = GLTF_MAX_MATERIALS;
    if (n > max)
        return err_set(err, RAYD_E_LIMIT, at.s, "has %d materials; the limit is %d", n, max);
    out->m = calloc((size_t)n + 1, sizeof *out->m);
    out->uv_set = calloc((size_t)n + 1, sizeof *out->uv_set);
    out->tex = calloc(GLTF_MAX_TEXTURES, sizeof *out->tex);
    out->n = n;
    if (!out->m || !out->uv_set || !out->tex)
        return err_set(err, RAYD_E_NOMEM, at.s, "out of memory");
    out->budget = texels < GLTF_MAX_TEXELS ? texels : GLTF_MAX_TEXELS;
    int i = 0;
    enum rayd_status st = RAYD_OK;
    for (const cJSON *m = ms ? ms->child : NULL; m && st == RAYD_OK; m = m->next, i++) {
        struct jp p = {.s = ""};
        snprintf(p.s, sizeof p.s, "/materials/%d", i);
        st = gm_material(d, err, m, &p, out, i, &out->texels);
    }
    if (st == RAYD_OK) st = gm_material(d, err, NULL, &at, out, n, &out->texels);
    gm_forget(out);
    return st;
}

void gltf_mats_free(struct gltf_mats *g) {
    for (int i = 0; g->tex && i < g->ntex; i++) texture_free(&g->tex[i]);
    free(g->tex);
    free(g->m);
    free(g->uv_set);
    mesh_give_back(g->lim, &g->charged, g->charged);
    memset(g, 0, sizeof *g);
}
