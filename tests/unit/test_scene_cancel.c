/* test_scene_cancel.c -- rayd_limits.cancel: a parse whose flag is raised
 * ends with RAYD_E_CANCELED at its next step (before an image is decoded,
 * a file read, a mesh decoded or built, and inside each BVH build): it
 * charges nothing more, and keeps nothing.  rayd raises it when
 * a frame-range job is deleted while its frame is parsed (compile.c). */
#include "check.h"

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/bvh.h"
#include "base/meter.h"
#include "rayd/rayd.h"
#include "scene_util.h"

/* The charges a parse made, and the call at which it raises the flag. */
struct account {
    int calls, raise_at; /* raise_at 0: never */
    int after;           /* bytes asked for once the flag was up */
    atomic_int *flag;
};

static enum rayd_status charge(void *arg, long long bytes, char *why, size_t why_len) {
    (void)why;
    (void)why_len;
    struct account *a = arg;
    if (bytes > 0 && atomic_load(a->flag)) a->after++;
    if (++a->calls == a->raise_at) atomic_store(a->flag, 1);
    return RAYD_OK;
}

/* A scene of a PNG texture on a sphere and an inline mesh of a strip of
 * ntris triangles (more than the BVH build's first look at the flag). */
static char *scene_text(int ntris) {
    rayd_image *tex;
    rayd_image_new(64, 64, &tex, NULL);
    char *enc = png_base64(tex);
    size_t cap = strlen(enc) + (size_t)ntris * 40 + 1024, n = 0;
    char *json = malloc(cap);
    n += (size_t)snprintf(json + n, cap - n,
                          "{\"materials\": {\"t\": {\"texture\": {\"type\": \"image\","
                          " \"png_base64\": \"%s\"}}}, \"objects\": [{\"type\": \"sphere\","
                          " \"center\": [0, 0, -5], \"material\": \"t\"}, {\"type\": \"mesh\","
                          " \"vertices\": [",
                          enc);
    for (int i = 0; i < ntris + 2; i++)
        n += (size_t)snprintf(json + n, cap - n, "%s%d,%d,-4", i ? "," : "", i, i % 2);
    n += (size_t)snprintf(json + n, cap - n, "], \"indices\": [");
    for (int i = 0; i < ntris; i++)
        n += (size_t)snprintf(json + n, cap - n, "%s%d,%d,%d", i ? "," : "", i, i + 1, i + 2);
    snprintf(json + n, cap - n, "]}]}");
    free(enc);
    return json;
}

static enum rayd_status parse(const char *json, struct account *a, rayd_scene **s,
                              struct rayd_error *err) {
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    CHECK(lim.cancel == NULL, "no flag by default");
    lim.charge = charge;
    lim.charge_arg = a;
    lim.cancel = a->flag;
    *s = NULL;
    return rayd_scene_parse(json, strlen(json), &lim, s, err);
}

/* A flag raised before the parse: refused at once, nothing charged. */
static void test_raised_before(void) {
    char *json = scene_text(100);
    atomic_int flag = 1;
    struct account a = {.flag = &flag};
    struct rayd_error err = {0};
    rayd_scene *s;
    enum rayd_status st = parse(json, &a, &s, &err);
    CHECK(st == RAYD_E_CANCELED && !s, "status %d", st);
    CHECK(strstr(err.message, "canceled") != NULL, "message %s", err.message);
    CHECK(a.calls == 0, "%d charges", a.calls);
    free(json);
}

/* The flag raised at each of the parse's charges in turn: the parse ends
 * canceled every time, asking for no more bytes after; with the flag down
 * it parses. */
static void test_raised_at_each_step(void) {
    char *json = scene_text(20000);
    atomic_int flag = 0;
    struct account whole = {.flag = &flag};
    struct rayd_error err = {0};
    rayd_scene *s;
    enum rayd_status st = parse(json, &whole, &s, &err);
    CHECK(st == RAYD_OK && s, "parse: %s", err.message);
    rayd_scene_free(s);
    CHECK(whole.calls >= 3, "%d charges: texture, its give-back, the mesh", whole.calls);
    for (int k = 1; k <= whole.calls; k++) {
        atomic_store(&flag, 0);
        struct account a = {.raise_at = k, .flag = &flag};
        st = parse(json, &a, &s, &err);
        CHECK(st == RAYD_E_CANCELED && !s, "raised at charge %d: status %d (%s)", k, st,
              err.message);
        CHECK(a.after == 0, "raised at charge %d: %d charges after", k, a.after);
    }
    free(json);
}

/* The BVH build looks at the flag of the meter bound to its thread: a
 * build of 50,000 boxes with it raised ends canceled, and builds with it
 * down (or no meter bound). */
static void test_build_sees_flag(void) {
    enum { N = 50000 };
    struct bbox *boxes = malloc(sizeof *boxes * N);
    uint32_t *order = malloc(sizeof *order * (N + 1));
    for (int i = 0; i < N; i++)
        for (int k = 0; k < 3; k++) {
            boxes[i].lo[k] = (float)((i * (k + 7)) % 1000);
            boxes[i].hi[k] = boxes[i].lo[k] + 1;
        }
    atomic_int flag = 0;
    struct meter m = meter_make(&flag, NULL);
    for (int raised = 0; raised < 2; raised++) {
        atomic_store(&flag, raised);
        meter_bind(&m);
        struct bvh4 bvh = {0};
        struct rayd_error err = {0};
        enum rayd_status st = bvh_build(&bvh, boxes, N, 4, order, 2, &err);
        meter_bind(NULL);
        CHECK(st == (raised ? RAYD_E_CANCELED : RAYD_OK), "raised %d: status %d (%s)", raised, st,
              err.message);
        CHECK(raised || bvh.nnodes > 1, "%u nodes", bvh.nnodes);
        bvh_free(&bvh);
    }
    free(boxes);
    free(order);
}

int main(void) {
    RUN(test_raised_before);
    RUN(test_raised_at_each_step);
    RUN(test_build_sees_flag);
    CHECK_EXIT();
}
