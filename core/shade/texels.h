/* texels.h -- decoded images shared by the scenes that name the same bytes. */
#ifndef TEXELS_H
#define TEXELS_H

#include <stdbool.h>
#include <stddef.h>

#include "base/share.h"

/* One decoded image's linear RGB floats (w x h x 3, rows from the top),
 * held by every scene that uses it. */
struct texels {
    struct share sh; /* first: its key is the encoded bytes */
    int w, h;
    float *rgb;
};

/* What an image's key is made of, one kind of key apart from another: an
 * image texture's encoded bytes, an environment's (with its format and
 * intensity), a glTF texture's factor and bytes. */
enum texels_key { TEXELS_IMAGE, TEXELS_ENV, TEXELS_GLTF };

/* The image decoded from the len bytes at key of kind, referenced, or
 * NULL when no live scene holds one or it has more than max_pixels (then
 * decoding refuses it, with the decoder's words).  c may be NULL (then
 * NULL).  A find counts as shared, an add as decoded. */
struct texels *texels_find(struct rayd_asset_cache *c, enum texels_key kind, const void *key,
                           size_t len, long max_pixels);
/* rgb (w x h x 3 floats, malloc'd; taken in every case) kept in c as the
 * image of key's len bytes of kind, referenced; NULL when out of memory
 * (rgb freed).  Another thread may add the same bytes meanwhile: both
 * live. */
struct texels *texels_add(struct rayd_asset_cache *c, enum texels_key kind, const void *key,
                          size_t len, int w, int h, float *rgb);
/* Lets go of one reference: the last one frees the image and takes it out
 * of its cache. */
void texels_unref(struct texels *t);

#endif
