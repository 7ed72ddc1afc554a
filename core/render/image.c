/* image.c -- the rayd_image handle: 8-bit sRGB RGB pixels, rows packed.
 *
 * 8-bit output is the contract (the PNG is 8-bit sRGB), and storing the
 * encoded bytes is what makes "same bytes whatever the tiling" checkable
 * by memcmp.
 *
 * Windows.  rayd-render draws a frame only to deflate it: the PNG stream
 * reads each band of rows once, as soon as the render has drawn it
 * (png_encode.c), and never again.  A window image (rayd_image_new_window)
 * holds only the rows in flight -- row y at y % rows -- instead of the
 * whole frame: for a 1080p frame 364 rows on one 2 MiB huge page where the
 * whole took three, each paid for when the host backs it anew.  The
 * render sizes the window when it starts (image_window_open): the rows
 * the stream may hold (image_window_keep) plus its tiles in flight.  Before
 * drawing a row of tiles a thread waits until the stream has released the
 * rows that room held (image_rows_wait).  It cannot wait for ever: the
 * earliest waiting thread's rows of tiles above are all drawn and their
 * bands deflated, so all but the stream's kept rows are released, and
 * the window holds those plus its own row of tiles.  A render that stops
 * early gives up the window (image_rows_give_up), which turns every
 * waiter away.
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

/* w x h pixels: a size an image can have. */
static enum rayd_status size_check(int w, int h, struct rayd_error *err) {
    if (w <= 0 || h <= 0) return err_set(err, RAYD_E_ARG, NULL, "image size must be > 0");
    if ((size_t)w > SIZE_MAX / 3 / (size_t)h)
        return err_set(err, RAYD_E_LIMIT, NULL, "image of %d x %d pixels is too large", w, h);
    return RAYD_OK;
}

enum rayd_status rayd_image_new(int w, int h, rayd_image **out, struct rayd_error *err) {
    enum rayd_status st = size_check(w, h, err);
    if (st != RAYD_OK) return st;
    rayd_image *img = calloc(1, sizeof *img);
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

enum rayd_status rayd_image_new_window(int w, int h, rayd_image **out, struct rayd_error *err) {
    enum rayd_status st = size_check(w, h, err);
    if (st != RAYD_OK) return st;
    rayd_image *img = calloc(1, sizeof *img);
    struct image_window *win = calloc(1, sizeof *win);
    if (!img || !win) {
        free(img);
        free(win);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for a %d x %d image", w, h);
    }
    pthread_mutex_init(&win->lock, NULL);
    pthread_cond_init(&win->moved, NULL);
    img->w = w, img->h = h, img->win = win;
    *out = img;
    return RAYD_OK;
}

/* The bytes of img's pixels: all its rows, or its window's. */
static size_t image_bytes(const rayd_image *img) {
    size_t rows = img->win ? (size_t)img->win->rows : (size_t)img->h;
    return rows * (size_t)img->w * 3;
}

void rayd_image_free(rayd_image *img) {
    if (!img) return;
    huge_free_if(img->huge, img->px, image_bytes(img));
    if (img->win) {
        pthread_mutex_destroy(&img->win->lock);
        pthread_cond_destroy(&img->win->moved);
        free(img->win);
    }
    free(img);
}

bool image_window_tight;

void image_window_keep(const rayd_image *img, int rows) {
    if (img->win) img->win->keep = rows;
}

enum rayd_status image_window_open(rayd_image *img, size_t ahead, struct rayd_error *err) {
    struct image_window *win = img->win;
    if (!win) return RAYD_OK;
    if (img->px) return err_set(err, RAYD_E_ARG, NULL, "a window image takes one render");
    size_t stride = (size_t)img->w * 3;
    size_t keep = (size_t)(win->keep > 0 ? win->keep : img->h), h = (size_t)img->h;
    size_t rows = ahead < h && keep < h - ahead ? keep + ahead : h;
    img->huge = rows * stride >= IMAGE_HUGE_MIN;
    if (img->huge && !image_window_tight) { /* the rest of its huge pages: no more memory */
        size_t room = huge_pages_room(rows * stride) / stride;
        if (room > rows) rows = room < h ? room : h;
    }
    img->px = img->huge ? huge_calloc_pages(rows * stride) : calloc(rows * stride, 1);
    if (!img->px)
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for a %d x %zu window", img->w,
                       rows);
    win->rows = (int)rows;
    return RAYD_OK;
}

bool image_rows_wait(const rayd_image *img, int end) {
    struct image_window *win = img->win;
    if (!win || end <= win->rows) return true; /* the first rows have room of their own */
    pthread_mutex_lock(&win->lock);
    while (!win->given_up && end - win->rows > win->released)
        pthread_cond_wait(&win->moved, &win->lock);
    bool ok = !win->given_up;
    pthread_mutex_unlock(&win->lock);
    return ok;
}

void image_rows_release(const rayd_image *img, int rows) {
    struct image_window *win = img->win;
    if (!win) return;
    pthread_mutex_lock(&win->lock);
    if (rows > win->released) {
        win->released = rows;
        pthread_cond_broadcast(&win->moved);
    }
    pthread_mutex_unlock(&win->lock);
}

void image_rows_give_up(const rayd_image *img) {
    struct image_window *win = img->win;
    if (!win) return;
    pthread_mutex_lock(&win->lock);
    win->given_up = true;
    pthread_cond_broadcast(&win->moved);
    pthread_mutex_unlock(&win->lock);
}

int rayd_image_width(const rayd_image *img) { return img->w; }
int rayd_image_height(const rayd_image *img) { return img->h; }
uint8_t *rayd_image_pixels(rayd_image *img) { return img->win ? NULL : img->px; }
const uint8_t *rayd_image_pixels_const(const rayd_image *img) { return img->win ? NULL : img->px; }

enum rayd_status rayd_image_blit(rayd_image *dst, const rayd_image *src, int x, int y,
                                 struct rayd_error *err) {
    if (dst->win || src->win)
        return err_set(err, RAYD_E_ARG, NULL, "a window image has no whole frame to copy");
    if (x < 0 || y < 0 || x > dst->w - src->w || y > dst->h - src->h)
        return err_set(err, RAYD_E_ARG, NULL, "a %d x %d image at (%d, %d) does not fit in %d x %d",
                       src->w, src->h, x, y, dst->w, dst->h);
    for (int row = 0; row < src->h; row++)
        memcpy(dst->px + ((size_t)(y + row) * (size_t)dst->w + (size_t)x) * 3,
               src->px + (size_t)row * (size_t)src->w * 3, (size_t)src->w * 3);
    return RAYD_OK;
}

void rayd_free(void *p) { free(p); }
