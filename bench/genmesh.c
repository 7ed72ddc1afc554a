/* genmesh -- deterministic benchmark meshes, written as binary PLY.
 *
 *   genmesh LEVEL OUT.ply
 *
 * An icosahedron subdivided LEVEL times (20 * 4^LEVEL triangles: level 4
 * is 5,120, level 8 is 1,310,720) with every vertex pushed in or out by a
 * sum of sines of its direction: a closed, lumpy, asteroid-like surface
 * whose triangles vary in size and orientation the way a scanned mesh's
 * do.  Same LEVEL, same bytes, on every machine.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct edge_map { /* midpoint cache: key (a, b) with a < b -> vertex */
    uint64_t *keys;
    uint32_t *vals;
    size_t cap;
};

static uint32_t midpoint(struct edge_map *m, float **pos, uint32_t *nv, uint32_t a, uint32_t b) {
    if (a > b) {
        uint32_t t = a;
        a = b;
        b = t;
    }
    uint64_t key = ((uint64_t)a << 32) | b;
    size_t h = (size_t)((key * 0x9e3779b97f4a7c15ULL) >> 20) & (m->cap - 1);
    while (m->keys[h] != UINT64_MAX) {
        if (m->keys[h] == key) return m->vals[h];
        h = (h + 1) & (m->cap - 1);
    }
    float *p = *pos;
    float x = p[3 * a] + p[3 * b], y = p[3 * a + 1] + p[3 * b + 1], z = p[3 * a + 2] + p[3 * b + 2];
    float l = sqrtf(x * x + y * y + z * z);
    uint32_t v = (*nv)++;
    p[3 * v] = x / l;
    p[3 * v + 1] = y / l;
    p[3 * v + 2] = z / l;
    m->keys[h] = key;
    m->vals[h] = v;
    return v;
}

int main(int argc, char **argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: genmesh LEVEL OUT.ply\n");
        return 2;
    }
    int level = atoi(argv[1]);
    if (level < 0 || level > 9) return fprintf(stderr, "genmesh: LEVEL is 0..9\n"), 2;
    size_t ntri = 20;
    for (int i = 0; i < level; i++) ntri *= 4;
    size_t maxv = ntri / 2 + 2;
    float *pos = malloc(sizeof *pos * 3 * maxv);
    uint32_t *tri = malloc(sizeof *tri * 3 * ntri), *next = malloc(sizeof *next * 3 * ntri);
    const double t = (1 + sqrt(5.0)) / 2;
    const double v0[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                              {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                              {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    const uint32_t f0[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    uint32_t nv = 12;
    for (int i = 0; i < 12; i++) {
        double l = sqrt(v0[i][0] * v0[i][0] + v0[i][1] * v0[i][1] + v0[i][2] * v0[i][2]);
        for (int k = 0; k < 3; k++) pos[3 * i + k] = (float)(v0[i][k] / l);
    }
    memcpy(tri, f0, sizeof f0);
    size_t nt = 20;
    struct edge_map em;
    em.cap = 1;
    while (em.cap < maxv * 2) em.cap <<= 1;
    em.keys = malloc(sizeof *em.keys * em.cap);
    em.vals = malloc(sizeof *em.vals * em.cap);
    for (int l = 0; l < level; l++) {
        memset(em.keys, 0xff, sizeof *em.keys * em.cap);
        for (size_t i = 0; i < nt; i++) {
            uint32_t a = tri[3 * i], b = tri[3 * i + 1], c = tri[3 * i + 2];
            uint32_t ab = midpoint(&em, &pos, &nv, a, b), bc = midpoint(&em, &pos, &nv, b, c),
                     ca = midpoint(&em, &pos, &nv, c, a);
            uint32_t quad[4][3] = {{a, ab, ca}, {b, bc, ab}, {c, ca, bc}, {ab, bc, ca}};
            memcpy(next + 12 * i, quad, sizeof quad);
        }
        uint32_t *swap = tri;
        tri = next;
        next = swap;
        nt *= 4;
    }
    for (uint32_t i = 0; i < nv; i++) { /* lumps */
        float *p = pos + 3 * i;
        double d = 1 + 0.12 * sin(5 * p[0] + 1) * sin(4 * p[1]) + 0.05 * sin(17 * p[2] + 3 * p[0]) +
                   0.02 * sin(41 * p[1] + 29 * p[2]);
        for (int k = 0; k < 3; k++) p[k] = (float)(p[k] * d);
    }
    FILE *f = fopen(argv[2], "wb");
    if (!f) return perror(argv[2]), 1;
    fprintf(f,
            "ply\nformat binary_little_endian 1.0\ncomment rayd genmesh level %d\n"
            "element vertex %u\nproperty float x\nproperty float y\nproperty float z\n"
            "element face %zu\nproperty list uchar uint vertex_indices\nend_header\n",
            level, nv, nt);
    fwrite(pos, sizeof *pos * 3, nv, f); /* x86-64 is little endian, as the header says */
    for (size_t i = 0; i < nt; i++) {
        unsigned char three = 3;
        fwrite(&three, 1, 1, f);
        fwrite(tri + 3 * i, sizeof *tri, 3, f);
    }
    int rc = fclose(f) == 0 ? 0 : 1;
    free(pos);
    free(tri);
    free(next);
    free(em.keys);
    free(em.vals);
    return rc;
}
