/* test_scene_charge.c -- rayd_limits.charge: the loader tells its caller
 * the bytes each texture and mesh will hold before it decodes or builds
 * them, gives back what it frees, and stops where the caller refuses, with
 * the caller's status and message at the value's JSON Pointer (rayd counts
 * a parse in its memory budget this way, server/work/scenes.c). */
#include "check.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rayd/rayd.h"

/* The account a test keeps: what was charged and given back, and the
 * gross charge past which it refuses (0: never). */
struct account {
    long long net, gross, refuse_past;
    int calls;
};

static enum rayd_status charge(void *arg, long long bytes, char *why, size_t why_len) {
    struct account *a = arg;
    a->calls++;
    if (bytes > 0 && a->refuse_past && a->gross + bytes > a->refuse_past) {
        snprintf(why, why_len, "no room for %lld bytes", bytes);
        return RAYD_E_NOMEM;
    }
    a->net += bytes;
    if (bytes > 0) a->gross += bytes;
    return RAYD_OK;
}

static char *b64(const unsigned char *in, size_t n) {
    static const char al[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *out = malloc(4 * ((n + 2) / 3) + 1), *o = out;
    for (size_t i = 0; i < n; i += 3) {
        unsigned v = (unsigned)in[i] << 16 | (i + 1 < n ? (unsigned)in[i + 1] << 8 : 0) |
                     (i + 2 < n ? in[i + 2] : 0);
        *o++ = al[v >> 18 & 63];
        *o++ = al[v >> 12 & 63];
        *o++ = i + 1 < n ? al[v >> 6 & 63] : '=';
        *o++ = i + 2 < n ? al[v & 63] : '=';
    }
    *o = 0;
    return out;
}

/* A scene of a side x side PNG texture on a sphere and an inline mesh of
 * two triangles. */
static char *textured_scene(int side) {
    rayd_image *tex;
    rayd_image_new(side, side, &tex, NULL);
    void *png;
    size_t len;
    rayd_png_encode(tex, -1, &png, &len, NULL);
    rayd_image_free(tex);
    char *enc = b64(png, len);
    rayd_free(png);
    size_t cap = strlen(enc) + 1024;
    char *json = malloc(cap);
    snprintf(
        json, cap,
        "{\"materials\": {\"t\": {\"texture\": {\"type\": \"image\", \"png_base64\": \"%s\"}}},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, -5], \"material\": \"t\"},"
        " {\"type\": \"mesh\", \"vertices\": [0,0,-4, 1,0,-4, 0,1,-4, 1,1,-4],"
        " \"indices\": [0,1,2, 1,3,2]}]}",
        enc);
    free(enc);
    return json;
}

static rayd_scene *parse(const char *json, struct account *a, struct rayd_error *err,
                         enum rayd_status *st) {
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    CHECK(lim.charge == NULL, "no charge by default");
    lim.charge = charge;
    lim.charge_arg = a;
    rayd_scene *s = NULL;
    *st = rayd_scene_parse(json, strlen(json), &lim, &s, err);
    return s;
}

/* The texture is charged before it is decoded (its floats and 8-bit
 * pixels), the 8-bit pixels given back; the mesh charged before its build. */
static void test_charged_and_given_back(void) {
    char *json = textured_scene(256);
    struct account a = {0};
    struct rayd_error err = {0};
    enum rayd_status st;
    rayd_scene *s = parse(json, &a, &err, &st);
    CHECK(st == RAYD_OK && s, "parse: %s", err.message);
    CHECK(a.gross >= 256 * 256 * 16, "gross %lld: the texture's floats and 8-bit pixels", a.gross);
    CHECK(a.net < a.gross && a.net >= 256 * 256 * 12, "net %lld of gross %lld", a.net, a.gross);
    CHECK(a.calls >= 3, "%d calls: texture, its give-back, the mesh", a.calls);
    rayd_scene_free(s);
    free(json);
}

/* A refusal ends the parse with the caller's status and message, at the
 * value charged: the texture, or (with room for the texture) the mesh. */
static void test_refusal_stops_parse(void) {
    char *json = textured_scene(256);
    struct account a = {.refuse_past = 1000};
    struct rayd_error err = {0};
    enum rayd_status st;
    rayd_scene *s = parse(json, &a, &err, &st);
    CHECK(st == RAYD_E_NOMEM && !s, "status %d", st);
    CHECK(strcmp(err.path, "/materials/t/texture/png_base64") == 0, "path %s", err.path);
    CHECK(strstr(err.message, "no room for") != NULL, "message %s", err.message);
    struct account b = {.refuse_past = 256 * 256 * 16 + 16};
    s = parse(json, &b, &err, &st);
    CHECK(st == RAYD_E_NOMEM && !s, "status %d", st);
    CHECK(strcmp(err.path, "/objects/1/indices") == 0, "path %s", err.path);
    free(json);
}

int main(void) {
    RUN(test_charged_and_given_back);
    RUN(test_refusal_stops_parse);
    CHECK_EXIT();
}
