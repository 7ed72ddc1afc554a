/* image.h -- internal view of rayd_image, and the window of rows a
 * streamed render draws into (image.c, "Windows"). */
#ifndef IMAGE_H
#define IMAGE_H

#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rayd/rayd.h"

/* The rows of a window image in flight between the render that draws them
 * and the consumer that reads them. */
struct image_window {
    pthread_mutex_t lock;
    pthread_cond_t moved; /* released grew, or the render gave up */
    int rows;             /* rows held: row y lives at y % rows; 0 until opened */
    int keep;             /* its stream's band and the row above it; 0: no stream */
    int released;         /* rows [0, released) read for good: their room may be drawn over */
    bool given_up;        /* the render stopped: nobody waits any more */
};

struct rayd_image {
    int w, h;
    uint8_t *px;              /* w * h * 3 bytes, or a window's rows * w * 3 */
    bool huge;                /* px from huge_calloc_pages (else calloc) */
    struct image_window *win; /* NULL: every row held */
};

/* Row y's bytes. */
static inline uint8_t *image_row(const rayd_image *img, int y) {
    int r = img->win ? y % img->win->rows : y;
    return img->px + (size_t)r * (size_t)img->w * 3;
}

/* For a window image: its PNG stream deflates bands of at most rows - 1
 * rows, each read with the row above it, and releases the rows above the
 * first band it has not done but the one right above it (png_encode.c,
 * band_done).  Once every band whose rows are drawn is done, then, all
 * but the last `rows` rows drawn are released. */
void image_window_keep(const rayd_image *img, int rows);

/* For tests: a window of exactly the rows the render needs, without the
 * rest of its huge pages, so that it wraps round often. */
extern bool image_window_tight;

/* Sizes and allocates a window image's rows for a render that draws ahead
 * (at least 1) rows past the last released row (its tiles in flight); a
 * no-op for any other image. */
enum rayd_status image_window_open(rayd_image *img, size_t ahead, struct rayd_error *err);

/* Waits until rows [0, end) may all be drawn (their room is released);
 * false when the render has given up.  At once for an image that is not a
 * window. */
bool image_rows_wait(const rayd_image *img, int end);

/* The consumer is done with rows [0, rows). */
void image_rows_release(const rayd_image *img, int rows);

/* The render stopped early: wakes and turns away every waiter. */
void image_rows_give_up(const rayd_image *img);

#endif
