/* exr_read.h -- OpenEXR in, as linear float RGB (exr_read.c). */
#ifndef EXR_READ_H
#define EXR_READ_H

#include <stddef.h>

#include "base/error.h"

/* Decodes an OpenEXR file's first part (scanlines, channels R, G and B)
 * into *rgb (malloc'd, w x h x 3 floats, rows from the top); refused with
 * RAYD_E_LIMIT over max_pixels, RAYD_E_INVALID when it is not such a file,
 * the message saying why. */
enum rayd_status exr_read_rgb(const void *buf, size_t len, long max_pixels, float **rgb, int *w,
                              int *h, struct rayd_error *err);

/* The size exr_read_rgb would decode (the first part's data window),
 * read from the header alone, so a caller can count the memory before
 * the pixels are decoded; RAYD_E_INVALID (err saying why) when the
 * header is not readable. */
enum rayd_status exr_read_size(const void *buf, size_t len, long *w, long *h, double *scratch,
                               struct rayd_error *err);

#endif
