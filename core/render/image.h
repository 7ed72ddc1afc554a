/* image.h -- internal view of rayd_image. */
#ifndef IMAGE_H
#define IMAGE_H

#include <stdbool.h>
#include <stdint.h>

#include "rayd/rayd.h"

struct rayd_image {
    int w, h;
    uint8_t *px; /* w * h * 3 bytes */
    bool huge;   /* px from huge_alloc_pages (else malloc) */
};

#endif
