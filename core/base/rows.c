/* rows.c -- which rows at the top of an image drawn tile by tile are
 * complete (rayd_rows, include/rayd/rayd.h).
 *
 * One count per row of tiles: the tiles of it not yet drawn, decremented
 * atomically by whichever thread drew one, so a tile that does not finish
 * its row costs one atomic and no lock.  The thread whose tile finishes a
 * row takes the tracker's mutex and walks down from the first row not yet
 * known complete; the mutex makes the top a single number that only grows,
 * so each advance is reported once, by the thread that made it.  The render
 * (render/render.c) and the server's workers (server/sched.c) both stream a
 * PNG band by band with it.
 */
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>

#include "rayd/rayd.h"

struct rayd_rows {
    int tiles_y, tile, height;
    int top; /* rows of tiles at the top all drawn (under lock) */
    pthread_mutex_t lock;
    atomic_int left[]; /* tiles not yet drawn in each row of tiles */
};

rayd_rows *rayd_rows_new(int tiles_x, int tiles_y, int tile, int height) {
    if (tiles_x < 1 || tiles_y < 1 || tile < 1 || height < 1) return NULL;
    rayd_rows *r = malloc(sizeof *r + (size_t)tiles_y * sizeof r->left[0]);
    if (!r) return NULL;
    r->tiles_y = tiles_y;
    r->tile = tile;
    r->height = height;
    r->top = 0;
    pthread_mutex_init(&r->lock, NULL);
    for (int i = 0; i < tiles_y; i++) atomic_init(&r->left[i], tiles_x);
    return r;
}

int rayd_rows_tile_done(rayd_rows *r, int ty) {
    if (atomic_fetch_sub(&r->left[ty], 1) != 1) return 0;
    pthread_mutex_lock(&r->lock);
    int top = r->top;
    while (r->top < r->tiles_y && atomic_load(&r->left[r->top]) == 0) r->top++;
    int rows = r->top > top ? (r->top * r->tile < r->height ? r->top * r->tile : r->height) : 0;
    pthread_mutex_unlock(&r->lock);
    return rows;
}

void rayd_rows_free(rayd_rows *r) {
    if (!r) return;
    pthread_mutex_destroy(&r->lock);
    free(r);
}
