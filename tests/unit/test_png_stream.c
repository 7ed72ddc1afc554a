/* test_png_stream.c -- encoding while rendering: a render's rows callback
 * (opts.rows) only ever names rows that are final, reaching the height; a
 * PNG stream fed by it, or by rows told from many threads in any order,
 * writes the very bytes rayd_png_encode writes afterwards, for odd sizes
 * and every thread count; a stream dropped half way leaks nothing.  A
 * window image, which holds only the rows in flight, gives the same PNG,
 * serves one render, and a canceled render of one returns. */
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "render/image.h"
#include "rayd/rayd.h"
#include "scene_util.h"

/* What a rows callback saw: the rows as they were when first named final. */
struct seen {
    pthread_mutex_t lock;
    const rayd_image *img;
    uint8_t *snap; /* rows [0, top) copied when named */
    int top, calls, bad, full;
    rayd_png_stream *stream; /* told too, when not NULL */
};

static void on_rows(void *user, int rows) {
    struct seen *v = user;
    pthread_mutex_lock(&v->lock);
    v->calls++;
    v->full += rows == v->img->h;
    if (rows <= 0 || rows > v->img->h) v->bad++;
    size_t rowb = (size_t)v->img->w * 3;
    if (rows > v->top) {
        memcpy(v->snap + (size_t)v->top * rowb, v->img->px + (size_t)v->top * rowb,
               (size_t)(rows - v->top) * rowb);
        v->top = rows;
    }
    pthread_mutex_unlock(&v->lock);
    if (v->stream) rayd_png_stream_rows(v->stream, rows);
}

static void test_rows_named_are_final(void) {
    rayd_scene *s = whitted_sized(300, 70);
    if (!s) return;
    const int threads[] = {1, 2, 3}, tiles[] = {7, 32, 500};
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            rayd_image *img = NULL;
            CHECK(rayd_image_new(300, 70, &img, NULL) == RAYD_OK, "image");
            if (!img) continue;
            struct seen v = {
                PTHREAD_MUTEX_INITIALIZER, img, malloc(300 * 70 * 3), 0, 0, 0, 0, NULL};
            struct rayd_render_opts o = {
                .threads = threads[i], .tile = tiles[k], .rows = on_rows, .rows_user = &v};
            CHECK(rayd_render_image(s, &o, img, NULL) == RAYD_OK, "render");
            int rows_of_tiles = (70 + tiles[k] - 1) / tiles[k];
            CHECK(v.bad == 0 && v.top == 70, "%d threads, tile %d: rows reach %d (bad %d)",
                  threads[i], tiles[k], v.top, v.bad);
            CHECK(v.calls >= 1 && v.calls <= rows_of_tiles && v.full == 1,
                  "%d threads, tile %d: %d calls (%d naming the height) for %d rows of tiles",
                  threads[i], tiles[k], v.calls, v.full, rows_of_tiles);
            CHECK(threads[i] > 1 || v.calls == rows_of_tiles,
                  "one thread, tile %d: %d calls, not one a row of tiles (%d)", tiles[k], v.calls,
                  rows_of_tiles);
            CHECK(v.snap && !memcmp(v.snap, img->px, (size_t)300 * 70 * 3),
                  "%d threads, tile %d: a row named final changed afterwards", threads[i],
                  tiles[k]);
            free(v.snap);
            rayd_image_free(img);
        }
    rayd_image *small = NULL;
    CHECK(rayd_image_new(10, 10, &small, NULL) == RAYD_OK, "image");
    struct rayd_render_opts o = {.threads = 1};
    struct rayd_error err = {0};
    CHECK(rayd_render_image(s, &o, small, &err) == RAYD_E_ARG, "an image not the region's size");
    rayd_image_free(small);
    rayd_scene_free(s);
}

/* The encode of img at level, one thread: what every stream must match. */
static void *reference(const rayd_image *img, int level, size_t *len) {
    void *buf = NULL;
    if (rayd_png_encode_threads(img, level, 1, &buf, len, NULL) != RAYD_OK) return NULL;
    return buf;
}

static void test_render_stream_equals_encode(void) {
    rayd_scene *s = whitted_sized(1500, 140); /* 58 rows a band: 3 bands */
    if (!s) return;
    const int threads[] = {1, 2, 4}, tiles[] = {16, 57};
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 2; k++) {
            rayd_image *img = NULL;
            rayd_png_stream *ps = NULL;
            CHECK(rayd_image_new(1500, 140, &img, NULL) == RAYD_OK, "image");
            if (!img) continue;
            CHECK(rayd_png_stream_new(img, -1, &ps, NULL) == RAYD_OK, "stream");
            struct rayd_render_opts o = {.threads = threads[i],
                                         .tile = tiles[k],
                                         .rows = rayd_png_stream_rows,
                                         .rows_user = ps};
            CHECK(rayd_render_image(s, &o, img, NULL) == RAYD_OK, "render");
            void *buf = NULL, *ref;
            size_t len = 0, rlen = 0;
            struct rayd_png_stats st = {0};
            CHECK(rayd_png_stream_finish(ps, threads[i], &buf, &len, &st, NULL) == RAYD_OK,
                  "finish");
            ref = reference(img, -1, &rlen);
            CHECK(buf && ref && len == rlen && !memcmp(buf, ref, len),
                  "%d threads, tile %d: the stream's PNG differs from the encoder's", threads[i],
                  tiles[k]);
            CHECK(st.bands == 3 && st.bands_early == 3 && st.band_seconds > 0,
                  "%d threads, tile %d: %d bands, %d during the render", threads[i], tiles[k],
                  st.bands, st.bands_early);
            rayd_free(buf);
            rayd_free(ref);
            rayd_image_free(img);
        }
    rayd_scene_free(s);
}

/* A w x h image of gradients and noise. */
static rayd_image *pattern(int w, int h, unsigned seed) {
    rayd_image *img = NULL;
    if (rayd_image_new(w, h, &img, NULL) != RAYD_OK) return NULL;
    uint32_t r = seed * 2654435761u + 1;
    for (size_t i = 0; i < (size_t)w * (size_t)h * 3; i++) {
        r = r * 1664525u + 1013904223u;
        img->px[i] = (uint8_t)(i % 3 == 2 ? r >> 24 : (i / 3 % (size_t)w) * 255 / (size_t)w);
    }
    return img;
}

/* rayd_png_encoder names what makes the bytes: levels of one name write
 * the same bytes, and the default (any level out of 0-9) is named apart
 * from every level the caller can ask for, since its bytes are its own. */
static void test_encoder_names_the_bytes(void) {
    rayd_image *img = pattern(300, 90, 7);
    CHECK(img != NULL, "image");
    if (!img) return;
    void *png[12] = {0};
    size_t len[12] = {0};
    for (int l = -1; l <= 10; l++) png[l + 1] = reference(img, l, &len[l + 1]);
    for (int a = -1; a <= 10; a++)
        for (int b = -1; b <= 10; b++) {
            bool same_name = !strcmp(rayd_png_encoder(a), rayd_png_encoder(b));
            bool same_bytes = png[a + 1] && png[b + 1] && len[a + 1] == len[b + 1] &&
                              !memcmp(png[a + 1], png[b + 1], len[a + 1]);
            CHECK(!same_name || same_bytes, "levels %d and %d: one name (%s), other bytes", a, b,
                  rayd_png_encoder(a));
        }
    for (int l = 0; l <= 9; l++)
        CHECK(strcmp(rayd_png_encoder(-1), rayd_png_encoder(l)) != 0,
              "the default is named as level %d: %s", l, rayd_png_encoder(l));
    CHECK(!strcmp(rayd_png_encoder(-1), rayd_png_encoder(10)), "10 is not the default");
    for (int l = 0; l < 12; l++) rayd_free(png[l]);
    rayd_image_free(img);
}

struct teller {
    rayd_png_stream *ps;
    int h;
    unsigned seed;
};

/* Tells the stream rows in a random order, growing and shrinking. */
static void *tell_rows(void *arg) {
    struct teller *t = arg;
    uint32_t r = t->seed;
    for (int k = 0; k < 40; k++) {
        r = r * 1664525u + 1013904223u;
        rayd_png_stream_rows(t->ps, (int)((r >> 8) % (uint32_t)(t->h + 1)));
    }
    return NULL;
}

static void test_rows_in_any_order_any_threads(void) {
    const int sizes[][2] = {{1, 1}, {1, 10000}, {4097, 3}, {300, 2000}};
    const int levels[] = {-1, 1, 9, 0}; /* the default, ISA-L, libdeflate's best, stored */
    for (int i = 0; i < 4; i++) {
        int w = sizes[i][0], h = sizes[i][1], level = levels[i];
        rayd_image *img = pattern(w, h, (unsigned)i + 1);
        CHECK(img != NULL, "image");
        if (!img) continue;
        size_t rlen = 0;
        void *ref = reference(img, level, &rlen);
        for (int threads = 1; threads <= 4; threads++) {
            rayd_png_stream *ps = NULL;
            CHECK(rayd_png_stream_new(img, level, &ps, NULL) == RAYD_OK, "stream");
            pthread_t tid[3];
            struct teller tl[3];
            for (int k = 0; k < 3; k++) {
                tl[k] = (struct teller){ps, h, (unsigned)(7 * threads + k)};
                pthread_create(&tid[k], NULL, tell_rows, &tl[k]);
            }
            for (int k = 0; k < 3; k++) pthread_join(tid[k], NULL);
            void *buf = NULL;
            size_t len = 0;
            CHECK(rayd_png_stream_finish(ps, threads, &buf, &len, NULL, NULL) == RAYD_OK, "finish");
            CHECK(ref && buf && len == rlen && !memcmp(buf, ref, len),
                  "%dx%d level %d, %d threads: the stream's PNG differs from the encoder's", w, h,
                  level, threads);
            rayd_free(buf);
        }
        rayd_free(ref);
        rayd_image_free(img);
    }
}

/* A sink into memory that says no after `room` bytes. */
struct mem_sink {
    unsigned char *buf;
    size_t len, room;
    int refused, after; /* refusals, and calls after the first */
};

static int mem_put(void *user, const void *data, size_t n) {
    struct mem_sink *m = user;
    m->after += m->refused > 0;
    if (m->len + n > m->room) return ++m->refused, -1;
    memcpy(m->buf + m->len, data, n);
    m->len += n;
    return 0;
}

static void test_finish_to_a_sink(void) {
    rayd_image *img = pattern(700, 1500, 4);
    CHECK(img != NULL, "image");
    if (!img) return;
    size_t rlen = 0;
    void *ref = reference(img, -1, &rlen);
    struct mem_sink m = {malloc(rlen + 1), 0, rlen + 1, 0, 0};
    rayd_png_stream *ps = NULL;
    CHECK(rayd_png_stream_new(img, -1, &ps, NULL) == RAYD_OK, "stream");
    rayd_png_stream_rows(ps, 700); /* some bands before finish */
    struct rayd_png_stats st = {0};
    CHECK(rayd_png_stream_finish_to(ps, 2, mem_put, &m, &st, NULL) == RAYD_OK, "finish_to");
    CHECK(ref && m.len == rlen && !memcmp(m.buf, ref, rlen),
          "the sink's bytes (%zu) differ from the encoder's (%zu)", m.len, rlen);
    CHECK(st.bands > 1 && st.bands_early > 0 && st.bands_early < st.bands,
          "%d bands, %d before finish", st.bands, st.bands_early);
    struct mem_sink small = {m.buf, 0, rlen / 2, 0, 0};
    struct rayd_error err = {0};
    CHECK(rayd_png_stream_new(img, -1, &ps, NULL) == RAYD_OK, "stream");
    CHECK(rayd_png_stream_finish_to(ps, 1, mem_put, &small, NULL, &err) == RAYD_E_IO &&
              err.message[0],
          "a sink that says no: RAYD_E_IO with a message");
    CHECK(small.refused == 1 && small.after == 0, "%d calls after the refusal", small.after);
    free(m.buf);
    rayd_free(ref);
    rayd_image_free(img);
}

static void test_dropped_stream_frees_all(void) {
    rayd_image *img = pattern(600, 900, 5);
    CHECK(img != NULL, "image");
    if (!img) return;
    rayd_png_stream *ps = NULL;
    CHECK(rayd_png_stream_new(img, 6, &ps, NULL) == RAYD_OK, "stream");
    rayd_png_stream_rows(ps, 450); /* some bands encoded, the rest never */
    rayd_png_stream_free(ps);
    rayd_png_stream_free(NULL);
    rayd_image_free(img);
}

/* The PNG of a render of s into a window image (rayd_image_new_window),
 * streamed as it is drawn; NULL on failure.  *rows: the rows it held. */
static void *window_png(const rayd_scene *s, int w, int h, int threads, int tile, size_t *len,
                        int *rows) {
    rayd_image *img = NULL;
    rayd_png_stream *ps = NULL;
    void *buf = NULL;
    if (rayd_image_new_window(w, h, &img, NULL) != RAYD_OK) return NULL;
    if (rayd_png_stream_new(img, -1, &ps, NULL) == RAYD_OK) {
        struct rayd_render_opts o = {
            .threads = threads, .tile = tile, .rows = rayd_png_stream_rows, .rows_user = ps};
        if (rayd_render_image(s, &o, img, NULL) == RAYD_OK)
            rayd_png_stream_finish(ps, threads, &buf, len, NULL, NULL);
        else
            rayd_png_stream_free(ps);
    }
    *rows = img->win->rows;
    CHECK(rayd_image_pixels(img) == NULL, "a window image's pixels were handed out");
    rayd_image_free(img);
    return buf;
}

/* A w x h frame of a few spheres on a plane, quick to draw big. */
static rayd_scene *spheres_sized(int w, int h) {
    char json[600];
    snprintf(json, sizeof json,
             "{\"camera\": {\"position\": [0, 2, 6], \"look_at\": [0, 0.5, 0], \"fov_x\": 60},"
             " \"render\": {\"width\": %d, \"height\": %d, \"background\": [0.3, 0.5, 0.8]},"
             " \"lights\": [{\"type\": \"point\", \"position\": [-4, 6, 5]}],"
             " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, 0], \"normal\": [0, 1, 0]},"
             " {\"type\": \"sphere\", \"center\": [-1, 0.8, 0], \"radius\": 0.8},"
             " {\"type\": \"sphere\", \"center\": [1.2, 0.5, 0.5], \"radius\": 0.5}]}",
             w, h);
    return scene_from(json);
}

/* A render streamed from a window image writes the bytes of the whole
 * frame's PNG, for odd sizes, thread counts and tile sizes, holding fewer
 * rows than the frame when it is tall (the window cannot take all). */
static void test_window_image_same_png(void) {
    /* the last frame, 2.3 MB, is more than a window's huge page holds */
    const int sizes[][2] = {{1, 1}, {1, 9999}, {4097, 3}, {1100, 700}};
    const int threads[] = {1, 2, 3, 5}, tiles[] = {1, 7, 32};
    for (int i = 0; i < 4; i++) {
        int w = sizes[i][0], h = sizes[i][1];
        rayd_scene *s = w * h < 100000 ? whitted_sized(w, h) : spheres_sized(w, h);
        rayd_image *whole = NULL;
        CHECK(s && rayd_render(s, NULL, &whole, NULL) == RAYD_OK, "%dx%d: the whole frame", w, h);
        size_t rlen = 0;
        void *ref = whole ? reference(whole, -1, &rlen) : NULL;
        for (int t = 0; ref && t < 4; t++)
            for (int k = 0; k < 3; k++)
                for (int tight = 0; tight < 2; tight++) {
                    bool big = w * h > 20000;
                    if (big ? tiles[k] == 1 || threads[t] == 1 || threads[t] == 5 : tight)
                        continue; /* slow, or the same: a small frame's window holds it all */
                    image_window_tight = tight;
                    size_t len = 0;
                    int rows = 0;
                    void *buf = window_png(s, w, h, threads[t], tiles[k], &len, &rows);
                    CHECK(buf && len == rlen && !memcmp(buf, ref, len),
                          "%dx%d, %d threads, tile %d%s: the window's PNG differs from the frame's",
                          w, h, threads[t], tiles[k], tight ? ", tight" : "");
                    CHECK(!big || rows < (tight ? h / 3 : h),
                          "%dx%d, tile %d%s: the window held %d of %d rows", w, h, tiles[k],
                          tight ? ", tight" : "", rows, h);
                    rayd_free(buf);
                }
        rayd_free(ref);
        rayd_image_free(whole);
        rayd_scene_free(s);
    }
    image_window_tight = false;
}

/* A window image serves one streamed render: no second render, no second
 * stream (before the render or after it), no encoding before its render,
 * no blit, no render into it at an offset. */
static void test_window_image_once(void) {
    rayd_scene *s = whitted_sized(64, 48);
    rayd_image *img = NULL, *other = NULL;
    rayd_png_stream *ps = NULL;
    CHECK(s && rayd_image_new_window(64, 48, &img, NULL) == RAYD_OK, "window image");
    CHECK(rayd_image_new(64, 48, &other, NULL) == RAYD_OK, "image");
    if (!s || !img || !other) return;
    struct rayd_error err = {0};
    CHECK(rayd_image_blit(other, img, 0, 0, &err) == RAYD_E_ARG, "blit from a window image");
    CHECK(rayd_render_into(s, NULL, img, 0, 0, NULL, NULL, &err) == RAYD_E_ARG,
          "render_into a window image");
    void *buf = NULL;
    size_t len = 0;
    CHECK(rayd_png_encode(img, -1, &buf, &len, &err) == RAYD_E_ARG && !buf,
          "a window image encoded before its render: %s", err.message);
    CHECK(rayd_png_stream_new(img, -1, &ps, NULL) == RAYD_OK, "stream");
    rayd_png_stream *ps2 = NULL;
    CHECK(rayd_png_stream_new(img, -1, &ps2, &err) == RAYD_E_ARG && !ps2,
          "a second stream before the render: %s", err.message);
    struct rayd_render_opts o = {.threads = 2, .rows = rayd_png_stream_rows, .rows_user = ps};
    CHECK(rayd_render_image(s, &o, img, NULL) == RAYD_OK, "render");
    rayd_png_stream_free(ps);
    ps = NULL;
    o.rows = NULL, o.rows_user = NULL;
    CHECK(rayd_render_image(s, &o, img, &err) == RAYD_E_ARG && strstr(err.message, "one render"),
          "a second render: %s", err.message);
    CHECK(rayd_png_stream_new(img, -1, &ps, &err) == RAYD_E_ARG && !ps, "a second stream: %s",
          err.message);
    rayd_image_free(other);
    rayd_image_free(img);
    rayd_scene_free(s);
}

/* A window image whose render is given no rows callback holds the whole
 * frame (nothing would release its rows): the render returns, and the
 * stream finished afterwards writes the frame's PNG. */
static void test_window_without_rows_callback(void) {
    rayd_scene *s = spheres_sized(1100, 700);
    rayd_image *img = NULL, *whole = NULL;
    rayd_png_stream *ps = NULL;
    CHECK(s && rayd_render(s, NULL, &whole, NULL) == RAYD_OK, "the whole frame");
    CHECK(rayd_image_new_window(1100, 700, &img, NULL) == RAYD_OK, "window image");
    CHECK(img && rayd_png_stream_new(img, -1, &ps, NULL) == RAYD_OK, "stream");
    if (!s || !whole || !ps) return;
    struct rayd_render_opts o = {.threads = 3, .tile = 16};
    CHECK(rayd_render_image(s, &o, img, NULL) == RAYD_OK, "render");
    CHECK(img->win->rows == 700, "the window held %d of 700 rows", img->win->rows);
    void *buf = NULL, *ref;
    size_t len = 0, rlen = 0;
    CHECK(rayd_png_stream_finish(ps, 2, &buf, &len, NULL, NULL) == RAYD_OK, "finish");
    ref = reference(whole, -1, &rlen);
    CHECK(buf && ref && len == rlen && !memcmp(buf, ref, len), "the PNG differs from the frame's");
    rayd_free(buf);
    rayd_free(ref);
    rayd_image_free(whole);
    rayd_image_free(img);
    rayd_scene_free(s);
}

/* A stream of a window image finished with no render says so (there
 * are no rows to encode) and frees itself. */
static void test_window_finish_without_render(void) {
    rayd_image *img = NULL;
    rayd_png_stream *ps = NULL;
    CHECK(rayd_image_new_window(300, 200, &img, NULL) == RAYD_OK, "window image");
    CHECK(img && rayd_png_stream_new(img, -1, &ps, NULL) == RAYD_OK, "stream");
    if (!ps) return;
    struct rayd_error err = {0};
    void *buf = NULL;
    size_t len = 0;
    CHECK(rayd_png_stream_finish(ps, 2, &buf, &len, NULL, &err) == RAYD_E_ARG && !buf,
          "finished with no render: %s", err.message);
    rayd_image_free(img);
}

/* The window's waits: a thread waiting for rows past the window returns
 * true once they are released, false once the render gives up; rows
 * inside the first window never wait. */
struct waiter {
    rayd_image *img;
    int end;
    bool ok;
};

static void *wait_rows(void *arg) {
    struct waiter *w = arg;
    w->ok = image_rows_wait(w->img, w->end);
    return NULL;
}

static void test_window_waits(void) {
    rayd_image *img = NULL;
    CHECK(rayd_image_new_window(10, 1000, &img, NULL) == RAYD_OK, "window image");
    if (!img) return;
    image_window_keep(img, 50);
    CHECK(image_window_open(img, 50, NULL) == RAYD_OK && img->win->rows == 100, "rows %d",
          img ? img->win->rows : -1);
    CHECK(image_rows_wait(img, 100), "the first window's rows waited");
    struct waiter a = {img, 250, false}, b = {img, 900, true};
    pthread_t ta, tb;
    pthread_create(&ta, NULL, wait_rows, &a);
    pthread_create(&tb, NULL, wait_rows, &b);
    image_rows_release(img, 150); /* room for rows up to 250: a goes on */
    pthread_join(ta, NULL);
    CHECK(a.ok, "rows [0, 250) after 150 released");
    image_rows_give_up(img); /* b, waiting for 800 released, is turned away */
    pthread_join(tb, NULL);
    CHECK(!b.ok, "a waiter went on after the render gave up");
    rayd_image_free(img);
}

/* A render canceled half way, threads waiting for the window's room,
 * returns canceled (it does not hang): the cancel flag is raised from the
 * rows callback after its first call, on a frame far taller than its
 * window, with more threads than tiles in a row. */
struct cancel_after {
    rayd_png_stream *ps;
    atomic_int cancel;
};

static void rows_then_cancel(void *user, int rows) {
    struct cancel_after *c = user;
    rayd_png_stream_rows(c->ps, rows);
    atomic_store(&c->cancel, 1);
}

static void test_window_cancel_does_not_hang(void) {
    rayd_scene *s = whitted_sized(40, 3000);
    for (int threads = 2; s && threads <= 6; threads += 2) {
        rayd_image *img = NULL;
        struct cancel_after c = {NULL, 0};
        CHECK(rayd_image_new_window(40, 3000, &img, NULL) == RAYD_OK, "window image");
        CHECK(img && rayd_png_stream_new(img, -1, &c.ps, NULL) == RAYD_OK, "stream");
        if (!c.ps) break;
        struct rayd_render_opts o = {.threads = threads,
                                     .tile = 4,
                                     .rows = rows_then_cancel,
                                     .rows_user = &c,
                                     .cancel = &c.cancel};
        CHECK(rayd_render_image(s, &o, img, NULL) == RAYD_E_CANCELED, "%d threads: not canceled",
              threads);
        rayd_png_stream_free(c.ps);
        rayd_image_free(img);
    }
    rayd_scene_free(s);
}

int main(void) {
    RUN(test_rows_named_are_final);
    RUN(test_render_stream_equals_encode);
    RUN(test_rows_in_any_order_any_threads);
    RUN(test_finish_to_a_sink);
    RUN(test_dropped_stream_frees_all);
    RUN(test_window_image_same_png);
    RUN(test_window_image_once);
    RUN(test_window_without_rows_callback);
    RUN(test_window_finish_without_render);
    RUN(test_window_waits);
    RUN(test_window_cancel_does_not_hang);
    RUN(test_encoder_names_the_bytes);
    CHECK_EXIT();
}
