/* scene_json_env.c -- render.environment: the light from far away.
 *
 *   {"color": [r, g, b]}                        a constant radiance, or
 *   {"file": "sky.hdr"} | {"base64": "...", "format": "hdr" | "exr"}
 *                                               an equirectangular image,
 *   with "rotation" (degrees about +Y), "intensity" (>= 0, a multiplier)
 *   and "visible" (camera rays that miss see it; default true).
 *
 * Images are Radiance .hdr (RGBE), decoded by stb_image (Debian's
 * libstb) once hdr_scan.c has found the data whole, or OpenEXR (exr_read.c, the library rayd writes
 * EXR with); the format is "format", else the file's magic number (.hdr when it is not OpenEXR's).
 * Both headers give the size before any pixel is decoded, so an image over the texture pixel limit
 * is refused without the memory.  The intensity is folded into the pixels once, here, so a lookup
 * is a read. Files are opened like mesh and texture files (sj_read_asset).
 */
#include <stdlib.h>
#include <string.h>

#include <stb/stb_image.h>

#include "load/scene_json_env.h"

#include "format/base64.h"
#include "codec/exr_read.h"
#include "format/hdr_scan.h"
#include "shade/texels.h"
#include "shade/texture.h"

#define DEG2RAD_ENV (3.14159265358979323846 / 180)

/* The encoded bytes of "file" or "base64". */
static enum rayd_status env_encoded(struct loader *ld, const cJSON *ej, const struct jp *at,
                                    struct jp *p, char **data, size_t *len) {
    const cJSON *file = cJSON_GetObjectItemCaseSensitive(ej, "file");
    const cJSON *b64 = cJSON_GetObjectItemCaseSensitive(ej, "base64");
    *p = jp_key(at, file ? "file" : "base64");
    if (file) return sj_read_asset(ld, file, p, data, len);
    if (!cJSON_IsString(b64))
        return sj_fail(ld, RAYD_E_INVALID, p, "must be a string, not %s", sj_type_name(b64));
    unsigned char *bytes;
    enum rayd_status st =
        base64_decode(b64->valuestring, strlen(b64->valuestring), &bytes, len, ld->err);
    if (st != RAYD_OK) return sj_fail(ld, st, p, "%s", ld->err->message);
    *data = (char *)bytes;
    return RAYD_OK;
}

/* Linear floats px (w x h, malloc'd, taken) times k into e, non-finite
 * and negative values as 0. */
static enum rayd_status env_take(float *px, int w, int h, double k, struct environment *e) {
    size_t m = (size_t)w * (size_t)h * 3;
    for (size_t i = 0; i < m; i++) px[i] = isfinite(px[i]) && px[i] > 0 ? (float)(px[i] * k) : 0.0f;
    e->rgb = px;
    e->w = w;
    e->h = h;
    return RAYD_OK;
}

static enum rayd_status env_decode_exr(struct loader *ld, const char *data, size_t len,
                                       const struct jp *p, double k, struct environment *e) {
    float *px;
    int w, h;
    long hw, hh;
    double scratch = 0;
    struct rayd_error x = {0};
    /* the floats and the sampling tables (about as much), charged from the
     * header's data window before a pixel is decoded, and while it decodes
     * the decoder's chunk buffers (a single 4096x4096 ZIP tile: 384 MB of
     * them from a 200 KB file) */
    enum rayd_status st = exr_read_size(data, len, &hw, &hh, &scratch, &x);
    if (st != RAYD_OK) return sj_fail(ld, st, p, "%s", x.message);
    bool fits = hw > 0 && hh > 0 && hw <= TEXTURE_MAX_PIXELS / hh &&
                scratch <= 24.0 * (double)TEXTURE_MAX_PIXELS; /* else exr_read_rgb refuses it */
    size_t charged = fits ? (size_t)hw * (size_t)hh * 3 * sizeof(float) * 2 : 0;
    size_t temp = fits ? (size_t)scratch : 0;
    TRY(sj_charge(ld, p, charged + temp));
    st = exr_read_rgb(data, len, TEXTURE_MAX_PIXELS, &px, &w, &h, &x);
    sj_give_back(ld, temp);
    if (st != RAYD_OK) {
        sj_give_back(ld, charged);
        return sj_fail(ld, st, p, "%s", x.message);
    }
    return env_take(px, w, h, k, e);
}

/* Decodes a Radiance .hdr into linear floats times k. */
static enum rayd_status env_decode_hdr(struct loader *ld, const char *data, size_t len,
                                       const struct jp *p, double k, struct environment *e) {
    if (len > (size_t)0x7fffffff) return sj_fail(ld, RAYD_E_LIMIT, p, "the image is too large");
    const stbi_uc *b = (const stbi_uc *)data;
    int w, h, n;
    char why[200];
    if (!stbi_is_hdr_from_memory(b, (int)len))
        return sj_fail(ld, RAYD_E_INVALID, p, "is not a Radiance .hdr image (%s)",
                       hdr_header_why(b, len, why, sizeof why) ? why : "stb_image refuses it");
    if (!stbi_info_from_memory(b, (int)len, &w, &h, &n))
        return sj_fail(ld, RAYD_E_INVALID, p, "is not a readable .hdr image: %s",
                       hdr_header_why(b, len, why, sizeof why) ? why : stbi_failure_reason());
    if (w <= 0 || h <= 0) /* stb reads a header's missing size as 0 */
        return sj_fail(ld, RAYD_E_INVALID, p, "the .hdr image is %d x %d pixels: it has none", w,
                       h);
    if ((long)w * h > TEXTURE_MAX_PIXELS)
        return sj_fail(ld, RAYD_E_LIMIT, p, "the image is %d x %d pixels; the limit is %ld pixels",
                       w, h, TEXTURE_MAX_PIXELS);
    if (!hdr_scan(b, len, w, h, why, sizeof why)) /* stb would read zeros past the end, or spin */
        return sj_fail(ld, RAYD_E_INVALID, p, "%s", why);
    /* stb's floats and our copy, then the sampling tables (about as much) */
    TRY(sj_charge(ld, p, (size_t)w * (size_t)h * 3 * sizeof(float) * 3));
    float *px = stbi_loadf_from_memory(b, (int)len, &w, &h, &n, 3);
    if (px && (w <= 0 || h <= 0 || (long)w * h > TEXTURE_MAX_PIXELS)) { /* as stbi_info said */
        stbi_image_free(px);
        return sj_fail(ld, RAYD_E_INVALID, p, "the .hdr image's size changed while decoding");
    }
    if (!px)
        return sj_fail(ld, RAYD_E_INVALID, p, "cannot decode the .hdr image: %s",
                       stbi_failure_reason());
    size_t m = (size_t)w * (size_t)h * 3;
    float *own = malloc(m * sizeof *own); /* stb's allocator is its own: copy into ours */
    if (own) memcpy(own, px, m * sizeof *own);
    stbi_image_free(px);
    sj_give_back(ld, m * sizeof(float)); /* stb's floats */
    if (!own) return err_set(ld->err, RAYD_E_NOMEM, p->s, "out of memory for the environment");
    return env_take(own, w, h, k, e);
}

/* What an environment image is shared under (lim->assets): its encoded
 * bytes, its format and the intensity folded into its floats.  malloc'd. */
static unsigned char *env_key(const char *data, size_t len, bool exr, double k, size_t *n) {
    *n = len + sizeof k + 1;
    unsigned char *key = malloc(*n);
    if (!key) return NULL;
    if (data && len) memcpy(key, data, len);
    memcpy(key + len, &k, sizeof k);
    key[len + sizeof k] = exr;
    return key;
}

/* The image of data (len bytes) times k into e: taken decoded from a live
 * scene of the same key when lim->assets has one, else decoded and offered
 * there.  A shared image is charged as its decode is (the decoder's
 * floats, its copy, the sampling tables), so whether another scene holds
 * it changes no answer of the limits. */
static enum rayd_status env_image(struct loader *ld, const char *data, size_t len, bool exr,
                                  const struct jp *p, double k, struct environment *e) {
    size_t n = 0;
    unsigned char *key = ld->lim->assets ? env_key(data, len, exr, k, &n) : NULL;
    struct texels *x =
        key ? texels_find(ld->lim->assets, TEXELS_ENV, key, n, TEXTURE_MAX_PIXELS) : NULL;
    enum rayd_status st;
    if (x) {
        e->rgb = x->rgb;
        e->shared = x;
        e->w = x->w;
        e->h = x->h;
        size_t floats = (size_t)x->w * (size_t)x->h * 3 * sizeof(float);
        st = sj_charge(ld, p, floats * (exr ? 2 : 3));
        if (st == RAYD_OK && !exr) sj_give_back(ld, floats); /* stb's floats */
    } else {
        st = exr ? env_decode_exr(ld, data, len, p, k, e) : env_decode_hdr(ld, data, len, p, k, e);
        if (st == RAYD_OK && key) {
            e->shared = texels_add(ld->lim->assets, TEXELS_ENV, key, n, e->w, e->h, e->rgb);
            if (!e->shared) e->rgb = NULL; /* freed */
            if (!e->rgb)
                st = err_set(ld->err, RAYD_E_NOMEM, p->s, "out of memory for the environment");
        }
    }
    free(key);
    return st;
}

enum rayd_status sj_environment(struct loader *ld, const cJSON *r, const struct jp *render_at) {
    static const char *const keys[] = {"color",    "file",      "base64",  "format",
                                       "rotation", "intensity", "visible", NULL};
    const cJSON *ej = cJSON_GetObjectItemCaseSensitive(r, "environment");
    if (!ej) return RAYD_OK;
    struct jp at = jp_key(render_at, "environment");
    if (!cJSON_IsObject(ej))
        return sj_fail(ld, RAYD_E_INVALID, &at, "must be an object, not %s", sj_type_name(ej));
    TRY(sj_check_keys(ld, ej, &at, keys));
    const char *kinds[] = {"color", "file", "base64"};
    int given = 0;
    for (int i = 0; i < 3; i++) given += cJSON_GetObjectItemCaseSensitive(ej, kinds[i]) != NULL;
    if (given != 1)
        return sj_fail(ld, RAYD_E_INVALID, &at,
                       "needs exactly one of \"color\", \"file\" or \"base64\"");
    struct environment *e = &ld->s->rs.env;
    double rot, k;
    TRY(sj_num(ld, ej, &at, "rotation", 0, -NUM_MAX, false, NUM_MAX, &rot));
    TRY(sj_num(ld, ej, &at, "intensity", 1, 0, false, 1e6, &k));
    TRY(sj_bool(ld, ej, &at, "visible", true, &e->visible));
    e->cos_r = cos(rot * DEG2RAD_ENV);
    e->sin_r = sin(rot * DEG2RAD_ENV);
    if (cJSON_GetObjectItemCaseSensitive(ej, "color")) {
        if (cJSON_GetObjectItemCaseSensitive(ej, "format")) {
            struct jp pf = jp_key(&at, "format");
            return sj_fail(ld, RAYD_E_INVALID, &pf, "belongs to an image environment (\"base64\")");
        }
        TRY(sj_vec(ld, ej, &at, "color", v3(0, 0, 0), VEC_COLOR, &e->color));
        e->color = v3_scale(e->color, k);
        e->kind = ENV_CONSTANT;
    } else {
        static const char *const formats[] = {"hdr", "exr", NULL};
        int format;
        TRY(sj_enum(ld, ej, &at, "format", formats, &format));
        struct jp p = {.s = ""};
        char *data = NULL;
        size_t len = 0;
        TRY(env_encoded(ld, ej, &at, &p, &data, &len));
        bool exr = format == 1 ||
                   (format < 0 && data && len >= 4 && memcmp(data, "\x76\x2f\x31\x01", 4) == 0);
        enum rayd_status st = env_image(ld, data, len, exr, &p, k, e);
        free(data);
        TRY(st);
        e->kind = ENV_IMAGE;
    }
    if (!env_prepare(e))
        return err_set(ld->err, RAYD_E_NOMEM, at.s, "out of memory for the environment");
    return RAYD_OK;
}
