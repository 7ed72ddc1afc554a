/* test_light_buffer.c -- the light buffer (light_buffer.c) stands in for
 * the BVH walk of shadow packets toward a point light: every lane must get
 * exactly the one-ray answer, wherever the light sits among the objects,
 * and the buffer must be built where it is sound and left out where not. */
#include <stdint.h>
#include <stdlib.h>

#include "accel/bvh16.h"
#include "check.h"
#include "render/integrate.h"
#include "accel/light_buffer.h"
#include "scene_util.h"

static double unit_rand(uint64_t *x) {
    *x = *x * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*x >> 11) * 0x1p-53;
}

/* A cloud of n small spheres and boxes in [-4, 4]^3 over a floor, with the
 * point lights given (JSON), as text in buf. */
static void cloud_scene(char *buf, size_t size, int n, const char *lights) {
    uint64_t x = 99;
    size_t at = (size_t)snprintf(buf, size,
                                 "{\"camera\": {\"position\": [0,2,12], \"look_at\": [0,0,0]},"
                                 " \"render\": {\"width\": 16, \"height\": 16},"
                                 " \"lights\": [%s], \"objects\": ["
                                 "{\"type\": \"plane\", \"point\": [0,-5,0], \"normal\": [0,1,0]}",
                                 lights);
    for (int k = 0; k < n && at < size; k++) {
        double c[3], r = 0.1 + 0.3 * unit_rand(&x);
        for (int i = 0; i < 3; i++) c[i] = -4 + 8 * unit_rand(&x);
        if (k % 4 == 3)
            at += (size_t)snprintf(buf + at, size - at,
                                   ",{\"type\": \"box\", \"min\": [%.3f,%.3f,%.3f],"
                                   " \"max\": [%.3f,%.3f,%.3f]}",
                                   c[0] - r, c[1] - r, c[2] - r, c[0] + r, c[1] + r, c[2] + r);
        else
            at += (size_t)snprintf(buf + at, size - at,
                                   ",{\"type\": \"sphere\", \"center\": [%.3f,%.3f,%.3f],"
                                   " \"radius\": %.3f}",
                                   c[0], c[1], c[2], r);
    }
    if (at < size) snprintf(buf + at, size - at, "]}");
}

/* Shadow rays toward light l as the wide shader makes them: from just off
 * surface point p[i] (normal nrm[i]), along the unit vector from p[i] to
 * the light, for p[i]'s distance. */
static void shadow_rays(const struct light *l, const vec3 p[16], const vec3 nrm[16],
                        double o[3][16], double d[3][16], double dist[16]) {
    for (int i = 0; i < 16; i++) {
        vec3 v = v3_sub(l->position, p[i]);
        double len = v3_len(v), off = integrate_offset(p[i], false);
        vec3 up = v3_madd(p[i], nrm[i], off), w = v3_scale(v, 1 / len);
        o[0][i] = up.x, o[1][i] = up.y, o[2][i] = up.z;
        d[0][i] = w.x, d[1][i] = w.y, d[2][i] = w.z;
        dist[i] = len;
    }
}

/* n packets of points near random centres (spread: how far apart the
 * lanes are) against light li: the lanes that differ from the one-ray
 * answer, and in *blocked how many were in shadow. */
static int packets_differ(const rayd_scene *s, int li, int n, double spread, uint64_t *x,
                          int *blocked) {
    int differ = 0;
    for (int k = 0; k < n; k++) {
        vec3 c = v3(-6 + 12 * unit_rand(x), -5 + 10 * unit_rand(x), -6 + 12 * unit_rand(x));
        vec3 p[16], nrm[16];
        for (int i = 0; i < 16; i++) {
            vec3 j = v3(unit_rand(x) - 0.5, unit_rand(x) - 0.5, unit_rand(x) - 0.5);
            p[i] = v3_madd(c, j, spread);
            nrm[i] = v3_norm(v3(unit_rand(x) - 0.5, 1, unit_rand(x) - 0.5));
        }
        double o[3][16], d[3][16], dist[16], out[3][16];
        shadow_rays(&s->lights[li], p, nrm, o, d, dist);
        uint32_t active = k % 7 ? 0xffffu : (uint32_t)(unit_rand(x) * 65535) + 1;
        scene_transmittance16_soa(s, li, (const double(*)[16])o, (const double(*)[16])d, dist,
                                  active, out);
        for (int i = 0; i < 16; i++) {
            if (!(active >> i & 1)) continue;
            ray r = {v3(o[0][i], o[1][i], o[2][i]), v3(d[0][i], d[1][i], d[2][i])};
            vec3 t = scene_transmittance(s, &r, dist[i]);
            differ += t.x != out[0][i] || t.y != out[1][i] || t.z != out[2][i];
            *blocked += t.x == 0;
        }
    }
    return differ;
}

/* Lights among the objects, beside them, far off; packets tight enough to
 * share a cell and loose enough not to: every lane as one ray. */
static void test_shadow_packets_match_one_ray(void) {
    static const char *lights[] = {
        "{\"type\": \"point\", \"position\": [-6,10,8]}",
        "{\"type\": \"point\", \"position\": [0.5,0.3,-0.2]}", /* inside the cloud */
        "{\"type\": \"point\", \"position\": [4.4,0,0]}",      /* on the cloud's edge */
        "{\"type\": \"point\", \"position\": [300,-200,100]}"};
    static char json[1 << 16];
    for (int l = 0; l < 4; l++) {
        cloud_scene(json, sizeof json, 240, lights[l]);
        rayd_scene *s = scene_from(json);
        CHECK(s != NULL, "scene %d parses", l);
        if (!s) continue;
        uint64_t x = 7 + (uint64_t)l;
        int differ = 0, blocked = 0;
        for (int way = CPU_WAY_BEST; way <= CPU_WAY_BASE; way++) {
            cpu_force((enum cpu_way)way);
            differ += packets_differ(s, 0, 400, 0.002, &x, &blocked);
            differ += packets_differ(s, 0, 200, 0.3, &x, &blocked);
            differ += packets_differ(s, 0, 100, 40, &x, &blocked);
        }
        cpu_force(CPU_WAY_BEST);
        CHECK(differ == 0, "light %d: %d shadow rays differ from the one-ray answer", l, differ);
        CHECK(blocked > 500, "light %d: only %d shadow rays blocked", l, blocked);
        rayd_scene_free(s);
    }
}

/* Whether the list of the 2 x 2 cells from (i, j) of face f holds each
 * object of those cells exactly once, and nothing else. */
static bool quad_is_its_cells(const struct light_face *f, int32_t i, int32_t j) {
    uint32_t q = (uint32_t)(j + 1) * (uint32_t)(f->nu + 1) + (uint32_t)(i + 1);
    const uint32_t *l = f->quad + f->qstart[q];
    uint32_t n = f->qstart[q + 1] - f->qstart[q], in_cells = 0;
    for (uint32_t a = 0; a < n; a++)
        for (uint32_t b = a + 1; b < n; b++)
            if (l[a] == l[b]) return false; /* listed twice */
    for (int32_t y = j; y <= j + 1; y++)
        for (int32_t x = i; x <= i + 1; x++) {
            if (x < 0 || y < 0 || x >= f->nu || y >= f->nv) continue;
            int32_t c = y * f->nu + x;
            for (uint32_t k = f->start[c]; k < f->start[c + 1]; k++) {
                bool found = false, before = false;
                for (uint32_t a = 0; a < n; a++) found |= l[a] == f->ids[k];
                for (int32_t yy = j; yy <= y; yy++) /* counted in an earlier cell? */
                    for (int32_t xx = i; xx <= i + 1 && !(yy == y && xx >= x); xx++) {
                        if (xx < 0 || yy < 0 || xx >= f->nu || yy >= f->nv) continue;
                        int32_t e = yy * f->nu + xx;
                        for (uint32_t m = f->start[e]; m < f->start[e + 1]; m++)
                            before |= f->ids[m] == f->ids[k];
                    }
                if (!found) return false;
                in_cells += !before;
            }
        }
    return in_cells == n;
}

/* The lists a packet reads (a face's 2 x 2 cells, light_buffer.h) are the
 * union of those cells' lists, each object once, on every face, including
 * the cells along the rectangle's edges. */
static void test_quads_list_their_cells(void) {
    static char json[1 << 16];
    cloud_scene(json, sizeof json, 240, "{\"type\": \"point\", \"position\": [-6,10,8]}");
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL && s->light_buffers && s->light_buffers[0].ok, "a buffer is built");
    if (!s || !s->light_buffers) return;
    int faces = 0, quads = 0, wrong = 0;
    for (int fi = 0; fi < 6; fi++) {
        const struct light_face *f = &s->light_buffers[0].face[fi];
        if (!f->nu) continue;
        faces++;
        for (int32_t j = -1; j < f->nv; j++)
            for (int32_t i = -1; i < f->nu; i++, quads++) wrong += !quad_is_its_cells(f, i, j);
    }
    CHECK(faces >= 2 && quads > 500, "%d faces, %d lists checked", faces, quads);
    CHECK(wrong == 0, "%d of %d lists are not their cells' objects once each", wrong, quads);
    rayd_scene_free(s);
}

/* The buffer is there for a point light clear of every object, not for a
 * light inside an object's box nor for other kinds of light, and covers
 * only the faces objects show on, in cells as many as they need. */
static void test_buffer_built_where_sound(void) {
    static char json[1 << 16];
    cloud_scene(json, sizeof json, 40,
                "{\"type\": \"point\", \"position\": [0,30,0]},"
                "{\"type\": \"directional\", \"direction\": [0,-1,0]},"
                "{\"type\": \"point\", \"position\": [0,0,0]}");
    /* a box around the origin: the third light sits inside it */
    char *end = strrchr(json, ']');
    CHECK(end != NULL, "scene text");
    if (!end) return;
    snprintf(end, sizeof json - (size_t)(end - json),
             ",{\"type\": \"box\", \"min\": [-0.1,-0.1,-0.1], \"max\": [0.1,0.1,0.1]}]}");
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "scene parses");
    if (!s) return;
    CHECK(s->light_buffers != NULL, "the scene has light buffers");
    if (s->light_buffers) {
        const struct light_buffer *b = s->light_buffers;
        CHECK(b[0].ok, "a light above the cloud gets a buffer");
        CHECK(!b[1].ok, "a directional light gets none");
        CHECK(!b[2].ok, "a light inside a box gets none");
        /* from (0, 30, 0) every object is below: only the -y face is used */
        int faces = 0;
        for (int f = 0; f < 6; f++) faces += b[0].face[f].nu > 0;
        CHECK(faces == 1 && b[0].face[3].nu > 0, "%d faces in use, -y %s", faces,
              b[0].face[3].nu > 0 ? "among them" : "not");
        CHECK(b[0].reach > 1000, "reach %g", b[0].reach);
        /* its cells sized to the 41 objects it shows: about 20 an object,
         * not the 64 x 64 of a crowded face */
        int nu = b[0].face[3].nu, nv = b[0].face[3].nv;
        CHECK(nu == nv && nu * nv >= 20 * 41 && nu * nv < 25 * 41, "-y face %d x %d cells", nu, nv);
    }
    struct rayd_scene_info info;
    rayd_scene_info(s, &info);
    CHECK(info.bytes > sizeof(struct light_buffer) * 3, "scene bytes %zu", info.bytes);
    rayd_scene_free(s);
}

/* Buffers are bounded: at most 32 lights get one (the rest walk the BVH,
 * with the same answers). */
static void test_buffers_bounded(void) {
    static char lights[1 << 12], json[1 << 16];
    size_t at = 0;
    for (int i = 0; i < 40; i++)
        at += (size_t)snprintf(
            lights + at, sizeof lights - at,
            "%s{\"type\": \"point\", \"position\": [%d,20,%d], \"intensity\": 0.02}", i ? "," : "",
            i - 20, 20 - i);
    cloud_scene(json, sizeof json, 30, lights);
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "scene parses");
    if (!s) return;
    int ok = 0;
    for (int i = 0; s->light_buffers && i < s->nlights; i++) ok += s->light_buffers[i].ok;
    CHECK(ok == 32, "%d of 40 lights have a buffer", ok);
    uint64_t x = 3;
    int differ = 0, blocked = 0;
    for (int l = 30; l < 40; l += 9) differ += packets_differ(s, l, 300, 0.01, &x, &blocked);
    CHECK(differ == 0, "%d shadow rays differ from the one-ray answer", differ);
    rayd_scene_free(s);
}

int main(void) {
    RUN(test_shadow_packets_match_one_ray);
    RUN(test_quads_list_their_cells);
    RUN(test_buffer_built_where_sound);
    RUN(test_buffers_bounded);
    CHECK_EXIT();
}
