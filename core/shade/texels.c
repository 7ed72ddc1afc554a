/* texels.c -- decoded images shared by the scenes that name the same bytes.
 *
 * A scene's image textures, environment image and glTF base colour
 * textures, decoded once while any scene of the same key holds them
 * (base/share.c has the cache and why).  Each kind makes its key its own
 * way (enum texels_key: the encoded bytes; with the format and intensity;
 * with the glTF factor), and keys of two kinds never match.  A decoded
 * image is a pure function of its key, so a hit gives the same texels as
 * decoding; the texel budget, which depends on the scene, is checked by
 * the loader either way.
 */
#include "shade/texels.h"

#include <stdlib.h>
#include <string.h>

static bool texels_fit(const struct share *s, const void *arg) {
    const struct texels *t = (const struct texels *)s;
    return (long)t->w * t->h <= *(const long *)arg;
}

static void texels_drop(struct share *s) {
    struct texels *t = (struct texels *)s;
    free(t->rgb);
    free(t);
}

struct texels *texels_find(struct rayd_asset_cache *c, enum texels_key kind, const void *key,
                           size_t len, long max_pixels) {
    return (struct texels *)share_find(c, SHARE_IMAGE, kind, key, len, texels_fit, &max_pixels);
}

struct texels *texels_add(struct rayd_asset_cache *c, enum texels_key kind, const void *key,
                          size_t len, int w, int h, float *rgb) {
    struct texels *t = calloc(1, sizeof *t);
    unsigned char *copy = malloc(len ? len : 1);
    if (!t || !copy) {
        free(t);
        free(copy);
        free(rgb);
        return NULL;
    }
    memcpy(copy, key, len);
    *t = (struct texels){.sh.drop = texels_drop, .w = w, .h = h, .rgb = rgb};
    share_add(c, &t->sh, SHARE_IMAGE, kind, copy, len, true);
    return t;
}

void texels_unref(struct texels *t) {
    if (t) share_unref(&t->sh);
}
