/* mesh_check.h -- what the mesh decoder tests share (test_mesh_obj.c,
 * test_mesh_ply.c, test_base64.c).
 *
 * Every input is copied into a malloc'd buffer of exactly its length (no
 * NUL after it), so under ASan a decoder reading one byte too far fails;
 * and every mesh is decoded on several thread counts too, which must give
 * the same answer as one thread.
 */
#ifndef MESH_CHECK_H
#define MESH_CHECK_H

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "format/mesh_io.h"

static inline bool same_floats(const float *a, const float *b, size_t n) {
    return (!a && !b) || (a && b && !memcmp(a, b, n * sizeof *a));
}

/* Decodes data with 2, 3 and 8 threads too and checks that every count
 * gives what one thread gave: the same status and message, or the same
 * mesh (the threaded decoders must be invisible).  An OBJ is read once
 * more with the fast path for plain lines off (mesh_obj_fast_path), which
 * must be invisible too: threads 0 below. */
static inline void same_on_threads(bool is_obj, const void *data, size_t len,
                                   const struct mesh_limits *lim, enum rayd_status st,
                                   const struct mesh_data *m, const struct rayd_error *e) {
    static const int threads[] = {2, 3, 8, 0};
    for (size_t k = 0; k < sizeof threads / sizeof threads[0] - !is_obj; k++) {
        struct mesh_data t = {0};
        struct rayd_error te = {0};
        mesh_obj_fast_path(threads[k] != 0);
        enum rayd_status ts =
            is_obj ? mesh_parse_obj_threads(data, len, lim, threads[k] ? threads[k] : 1, &t, &te)
                   : mesh_parse_ply_threads(data, len, lim, threads[k], &t, &te);
        mesh_obj_fast_path(true);
        bool same = ts == st;
        if (same && st != RAYD_OK) same = e && !strcmp(te.message, e->message);
        if (same && st == RAYD_OK)
            same = t.nverts == m->nverts && t.ntris == m->ntris &&
                   same_floats(t.pos, m->pos, 3 * (size_t)m->nverts) &&
                   same_floats(t.normal, m->normal, 3 * (size_t)m->nverts) &&
                   same_floats(t.uv, m->uv, 2 * (size_t)m->nverts) &&
                   !memcmp(t.index, m->index, sizeof *t.index * 3 * m->ntris);
        CHECK(same, "%s on %d threads: status %d '%s', one thread: %d '%s'", is_obj ? "OBJ" : "PLY",
              threads[k], (int)ts, te.message, (int)st, e ? e->message : "");
        if (ts == RAYD_OK) mesh_data_free(&t);
    }
}

static inline enum rayd_status obj_n(const char *text, size_t len, const struct mesh_limits *lim,
                                     struct mesh_data *m, struct rayd_error *e) {
    char *copy = malloc(len ? len : 1);
    memcpy(copy, text, len);
    enum rayd_status st = mesh_parse_obj(copy, len, lim, m, e);
    same_on_threads(true, copy, len, lim, st, m, e);
    free(copy);
    return st;
}

static inline enum rayd_status obj(const char *text, struct mesh_data *m, struct rayd_error *e) {
    return obj_n(text, strlen(text), NULL, m, e);
}

static inline enum rayd_status ply_n(const void *data, size_t len, const struct mesh_limits *lim,
                                     struct mesh_data *m, struct rayd_error *e) {
    void *copy = malloc(len ? len : 1);
    memcpy(copy, data, len);
    enum rayd_status st = mesh_parse_ply(copy, len, lim, m, e);
    same_on_threads(false, copy, len, lim, st, m, e);
    free(copy);
    return st;
}

static inline enum rayd_status ply(const char *text, struct mesh_data *m, struct rayd_error *e) {
    return ply_n(text, strlen(text), NULL, m, e);
}

/* Expects failure with `code` and a message containing `want`; checks
 * that *m was not written. */
#define CHECK_FAILS(call, code, want)                                                              \
    do {                                                                                           \
        struct mesh_data m_ = {0};                                                                 \
        struct rayd_error e_ = {0};                                                                \
        enum rayd_status st_ = call(&m_, &e_);                                                     \
        CHECK(st_ == (code), "status %d, want %d (%s)", (int)st_, (int)(code), e_.message);        \
        CHECK(strstr(e_.message, want) != NULL, "message '%s' lacks '%s'", e_.message, want);      \
        CHECK(m_.pos == NULL && m_.index == NULL && m_.nverts == 0, "out written on error");       \
        mesh_data_free(&m_);                                                                       \
    } while (0)

static inline bool tri_is(const struct mesh_data *m, uint32_t t, uint32_t a, uint32_t b,
                          uint32_t c) {
    return m->index && t < m->ntris && m->index[t * 3] == a && m->index[t * 3 + 1] == b &&
           m->index[t * 3 + 2] == c;
}

static inline bool pos_is(const struct mesh_data *m, uint32_t v, float x, float y, float z) {
    return m->pos && v < m->nverts && m->pos[v * 3] == x && m->pos[v * 3 + 1] == y &&
           m->pos[v * 3 + 2] == z;
}

/* The position of corner k of triangle t. */
static inline const float *corner_pos(const struct mesh_data *m, uint32_t t, int k) {
    return m->pos + (size_t)m->index[t * 3 + (uint32_t)k] * 3;
}

static inline void check_indices_in_range(const struct mesh_data *m) {
    for (uint32_t i = 0; i < m->ntris * 3; i++)
        if (m->index[i] >= m->nverts) {
            CHECK(0, "index %u = %u >= nverts %u", i, m->index[i], m->nverts);
            return;
        }
}

/* ---- fuzz-style: truncate and corrupt at every offset ------------------- */

/* 1 when st is an answer a decoder may give (OK with every index in
 * range; an error with a message and nothing written), else 0. */
static inline int mesh_answer_ok(enum rayd_status st, struct mesh_data *m,
                                 const struct rayd_error *e) {
    if (st == RAYD_OK) {
        for (uint32_t i = 0; i < m->ntris * 3; i++)
            if (m->index[i] >= m->nverts) st = RAYD_E_INTERNAL;
    } else if (m->pos || e->message[0] == 0) {
        st = RAYD_E_INTERNAL; /* out written, or no message */
    }
    mesh_data_free(m);
    return st == RAYD_OK || st == RAYD_E_INVALID || st == RAYD_E_LIMIT;
}

/* Runs run (1: a good answer) on src cut at every length, with each byte
 * set to a few telling values, and with bits flipped at a stride. */
static inline void fuzz_one(int (*run)(const unsigned char *, size_t), const unsigned char *src,
                            size_t n, const char *name) {
    static const unsigned char vals[] = {0, 0xff, '\n', ' ', '/', '-', '9', '0', '=', 'e', 0x80};
    unsigned char *buf = malloc(n);
    int bad = 0, runs = 0;
    for (size_t cut = 0; cut <= n; cut++, runs++) bad += !run(src, cut);
    for (size_t i = 0; i < n; i++)
        for (size_t k = 0; k < sizeof vals; k++) {
            memcpy(buf, src, n);
            buf[i] = vals[k];
            bad += !run(buf, n);
            runs++;
        }
    /* Bit flips at a stride, to reach into binary counts. */
    for (size_t i = 0; i < n; i += 3)
        for (int bit = 0; bit < 8; bit++) {
            memcpy(buf, src, n);
            buf[i] ^= (unsigned char)(1u << bit);
            bad += !run(buf, n);
            runs++;
        }
    free(buf);
    CHECK(bad == 0, "%s: %d of %d runs gave an unexpected status", name, bad, runs);
}

#endif
