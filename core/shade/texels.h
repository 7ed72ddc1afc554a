/* texels.h -- decoded images shared by the scenes that name the same bytes. */
#ifndef TEXELS_H
#define TEXELS_H

#include <stdbool.h>
#include <stddef.h>

struct rayd_image_cache; /* rayd.h's opaque handle, defined in texels.c */

/* One decoded image's linear RGB floats (w x h x 3, rows from the top),
 * held by every scene that uses it. */
struct texels {
    int w, h;
    float *rgb;
    /* the cache's: */
    struct rayd_image_cache *cache;
    long refs;
    unsigned long long hash;
    size_t key_len;
    unsigned char *key; /* the encoded bytes it was decoded from */
    struct texels *next;
    bool dropped; /* a holding cache let go of its reference */
};

/* The image decoded from the len bytes at key, referenced, or NULL when
 * no live scene holds one or it has more than max_pixels (then decoding
 * refuses it, with the decoder's words).  c may be NULL (then NULL).  A
 * find counts as shared, an add as decoded. */
struct texels *texels_find(struct rayd_image_cache *c, const void *key, size_t len,
                           long max_pixels);
/* rgb (w x h x 3 floats, malloc'd; taken in every case) kept in c as the
 * image of key's len bytes, referenced; NULL when out of memory (rgb
 * freed).  Another thread may add the same bytes meanwhile: both live. */
struct texels *texels_add(struct rayd_image_cache *c, const void *key, size_t len, int w, int h,
                          float *rgb);
/* Lets go of one reference: the last one frees the image and takes it out
 * of its cache. */
void texels_unref(struct texels *t);

#endif
