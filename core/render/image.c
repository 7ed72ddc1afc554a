/* image.c -- the rayd_image handle: 8-bit sRGB RGB pixels, rows packed.
 *
 * 8-bit output is the contract (the PNG is 8-bit sRGB), and storing the
 * encoded bytes is what makes "same bytes whatever the tiling" checkable
 * by memcmp.
 */
#include "render/image.h"

#include <stdlib.h>
#include <string.h>

#include "base/error.h"
#include "base/hugemem.h"

/* Images of this many bytes on 2 MiB huge pages: a 640 x 480 frame's 0.9 MB
 * on 4 KiB pages took 225 page faults, some 3 ms of a 25 ms render on a
 * virtual machine, where a fault costs about 14 us.  Given back with
 * huge_free_pages, a server's next frame of the size finds them warm.
 * A fresh frame is black untouched (huge_calloc_pages): its pages are first
 * written by the render's threads, in parallel, where a memset here had
 * the calling thread pay for all of them before the render began -- up to
 * 16 ms of the 1080p sphere frame's 0.1 s when the host had to back them. */
#define IMAGE_HUGE_MIN ((size_t)256 << 10)

enum rayd_status rayd_image_new(int w, int h, rayd_image **out, struct rayd_error *err) {
    if (w <= 0 || h <= 0) return err_set(err, RAYD_E_ARG, NULL, "image size must be > 0");
    if ((size_t)w > SIZE_MAX / 3 / (size_t)h)
        return err_set(err, RAYD_E_LIMIT, NULL, "image of %d x %d pixels is too large", w, h);
    rayd_image *img = malloc(sizeof *img);
    size_t bytes = (size_t)w * (size_t)h * 3;
    bool huge = bytes >= IMAGE_HUGE_MIN;
    uint8_t *px = huge ? huge_calloc_pages(bytes) : calloc(bytes, 1);
    if (!img || !px) {
        free(img);
        huge_free_if(huge, px, bytes);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for a %d x %d image", w, h);
    }
    img->w = w;
    img->h = h;
    img->px = px;
    img->huge = huge;
    *out = img;
    return RAYD_OK;
}

void rayd_image_free(rayd_image *img) {
    if (!img) return;
    huge_free_if(img->huge, img->px, (size_t)img->w * (size_t)img->h * 3);
    free(img);
}

int rayd_image_width(const rayd_image *img) { return img->w; }
int rayd_image_height(const rayd_image *img) { return img->h; }
uint8_t *rayd_image_pixels(rayd_image *img) { return img->px; }
const uint8_t *rayd_image_pixels_const(const rayd_image *img) { return img->px; }

enum rayd_status rayd_image_blit(rayd_image *dst, const rayd_image *src, int x, int y,
                                 struct rayd_error *err) {
    if (x < 0 || y < 0 || x > dst->w - src->w || y > dst->h - src->h)
        return err_set(err, RAYD_E_ARG, NULL,
                       "a %d x %d image at (%d, %d) does not fit in %d x %d", src->w, src->h, x,
                       y, dst->w, dst->h);
    for (int row = 0; row < src->h; row++)
        memcpy(dst->px + ((size_t)(y + row) * (size_t)dst->w + (size_t)x) * 3,
               src->px + (size_t)row * (size_t)src->w * 3, (size_t)src->w * 3);
    return RAYD_OK;
}

void rayd_free(void *p) { free(p); }
