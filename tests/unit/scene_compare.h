/* scene_compare.h -- one scene text through the loader twice: large inline
 * mesh arrays read from the text (every array of numbers at a mesh key,
 * inline_min 1) and all through cJSON (inline_min 0).  Both must give the
 * same scene, mesh bytes included, or the same error: status, message,
 * JSON Pointer, line and column.  Used by test_scene_inline.c and the
 * fuzz_scene target. */
#ifndef SCENE_COMPARE_H
#define SCENE_COMPARE_H

#pragma GCC diagnostic ignored "-Wformat-truncation" /* why is cut to fit: fine */

#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "load/scene_json.h"
#include "scene/scene.h"

static bool same_bytes(const void *a, const void *b, size_t n) {
    if (!a || !b) return a == b;
    return memcmp(a, b, n) == 0;
}

static bool same_mesh(const struct mesh *a, const struct mesh *b) {
    return a->nverts == b->nverts && a->ntris == b->ntris && a->nblocks == b->nblocks &&
           same_bytes(a->blocks, b->blocks, a->nblocks * sizeof *a->blocks) &&
           same_bytes(a->pos, b->pos, 3 * (size_t)a->nverts * sizeof(float)) &&
           same_bytes(a->normal, b->normal, 3 * (size_t)a->nverts * sizeof(float)) &&
           same_bytes(a->uv, b->uv, 2 * (size_t)a->nverts * sizeof(float)) &&
           same_bytes(a->index, b->index, 3 * (size_t)a->ntris * sizeof(uint32_t)) &&
           memcmp(&a->lo, &b->lo, sizeof a->lo) == 0 && memcmp(&a->hi, &b->hi, sizeof a->hi) == 0;
}

/* NULL when both ways agree, else what differs (in why).  *fast_ok: the
 * scene loaded. */
static const char *scene_compare(const char *text, size_t len, const struct rayd_limits *lim,
                                 char *why, size_t cap, bool *loaded) {
    rayd_scene *a = NULL, *b = NULL;
    struct rayd_error ea, eb;
    memset(&ea, 0, sizeof ea);
    memset(&eb, 0, sizeof eb);
    enum rayd_status sa = scene_json_parse(text, len, lim, 1, &a, &ea);
    enum rayd_status sb = scene_json_parse(text, len, lim, 0, &b, &eb);
    const char *res = NULL;
    if (sa != sb || strcmp(ea.message, eb.message) || strcmp(ea.path, eb.path) ||
        ea.line != eb.line || ea.column != eb.column) {
        snprintf(why, cap, "fast: %d %s '%s' %d:%d; cJSON: %d %s '%s' %d:%d", (int)sa, ea.path,
                 ea.message, ea.line, ea.column, (int)sb, eb.path, eb.message, eb.line, eb.column);
        res = why;
    } else if (sa == RAYD_OK && (a->nmeshes != b->nmeshes || a->nobjs != b->nobjs)) {
        snprintf(why, cap, "meshes %u/%u, objects %d/%d", a->nmeshes, b->nmeshes, (int)a->nobjs,
                 (int)b->nobjs);
        res = why;
    }
    for (uint32_t i = 0; !res && sa == RAYD_OK && i < a->nmeshes; i++)
        if (!same_mesh(&a->meshes[i], &b->meshes[i])) {
            snprintf(why, cap, "mesh %u differs", i);
            res = why;
        }
    *loaded = sa == RAYD_OK;
    rayd_scene_free(a);
    rayd_scene_free(b);
    return res;
}

#endif
