/* test_scene_inline.c -- inline mesh arrays read from the text give what
 * cJSON's path gives: the same mesh bytes or the same error, for generated
 * scenes (numbers in every spelling, counts, indices, limits, keys in any
 * order, non-mesh objects with mesh keys) and for random edits of them. */
#include <stdlib.h>

#include "check.h"
#include "format/json_numbers.h"
#include "scene_compare.h"

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static bool odd_values; /* this scene has odd numbers and elements; else all valid */

static unsigned rnd(unsigned n) {
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (unsigned)(rng_state % n);
}

/* A growing text. */
struct buf {
    char *s;
    size_t n, cap;
};

static void put(struct buf *b, const char *s) {
    size_t k = strlen(s);
    if (b->n + k + 1 > b->cap) {
        b->cap = 2 * (b->n + k + 1);
        b->s = realloc(b->s, b->cap);
    }
    memcpy(b->s + b->n, s, k + 1);
    b->n += k;
}

static const char *const specials[] = {
    "-0",
    "0.0",
    "-0.0e5",
    "1e30",
    "1e31",
    "-1e30",
    "1.0000000000000001e30",
    "1e400",
    "-1e400",
    "1e-400",
    "4.9e-324",
    "2.2250738585072011e-308",
    "9007199254740993",
    "9007199254740992.5",
    "123456789012345678901234567890",
    "0.1",
    "0.30000000000000004",
    "1E+2",
    "1e-0",
    "3.4028235e38",
    "3.4028236e38",
    "1.17549435e-38",
    "1.4e-45",
    "0.000000000000000000000000001",
    "100e-2",
    "1.0000000000000000000000000000000000000000000000000000000000001",  /* 63 characters */
    "1.00000000000000000000000000000000000000000000000000000000000001", /* 64 */
};

static void num(char *out, size_t cap) {
    double x = (rnd(20001) - 10000.0) / (1 + rnd(1000));
    switch (rnd(8)) {
    case 0: snprintf(out, cap, "%d", (int)rnd(41) - 20); break;
    case 1: snprintf(out, cap, "%.*f", (int)rnd(10), x); break;
    case 2: snprintf(out, cap, "%.17g", x * pow(10, (int)rnd(40) - 20)); break;
    case 3:
        snprintf(out, cap, "%s%u%s%s%u", rnd(2) ? "-" : "", rnd(100000), rnd(2) ? "e" : "E",
                 (const char *const[]){"", "+", "-"}[rnd(3)], odd_values ? rnd(331) : rnd(20));
        break;
    case 4:
        snprintf(out, cap, "%u%u%u.%u", rnd(100000) + 1, rnd(1000000), rnd(1000000), rnd(1000000));
        break;
    case 5:
        if (odd_values) {
            snprintf(out, cap, "%s", specials[rnd(sizeof specials / sizeof *specials)]);
            break;
        }
        /* fall through */
    default: snprintf(out, cap, "%.7g", x); break;
    }
}

static void index_text(char *out, size_t cap, int nv) {
    static const char *const odd[] = {"-1",  "1.5",        "2e0",   "0.0",  "-0",
                                      "1e1", "4294967296", "1e300", "0.5e1"};
    if (odd_values && rnd(40) == 0)
        snprintf(out, cap, "%s", odd[rnd(9)]);
    else if (odd_values && rnd(60) == 0)
        snprintf(out, cap, "%d", nv);
    else
        snprintf(out, cap, "%u", rnd((unsigned)nv));
}

static void ws(struct buf *b) {
    static const char *const w[] = {"", "", "", " ", "\n", "\t", "\r\n  "};
    put(b, w[rnd(7)]);
}

/* An array of n numbers (kind 0: coordinates, 1: indices below nv). */
static void array(struct buf *b, int n, int kind, int nv) {
    static const char *const other[] = {"\"x\"", "null", "[1]", "{}", "true"};
    char t[96];
    put(b, "[");
    for (int i = 0; i < n; i++) {
        ws(b);
        if (odd_values && rnd(200) == 0)
            snprintf(t, sizeof t, "%s", other[rnd(5)]);
        else if (kind)
            index_text(t, sizeof t, nv);
        else
            num(t, sizeof t);
        put(b, t);
        ws(b);
        if (i + 1 < n) put(b, ",");
    }
    put(b, "]");
}

static void member(struct buf *b, int key, int nv, int ntris) {
    static const char *const types[] = {"\"mesh\"",     "\"mesh\"",       "\"mesh\"",   "\"mesh\"",
                                        "\"triangle\"", "\"m\\u0065sh\"", "\"sphere\"", "3"};
    int off = odd_values && rnd(12) == 0 ? (int)rnd(3) - 1 : 0; /* counts off by one now and then */
    switch (key) {
    case 0:
        put(b, "\"type\": ");
        put(b, types[odd_values ? rnd(8) : rnd(4)]);
        break;
    case 1:
        put(b, "\"vertices\":");
        array(b, 3 * nv + off, 0, nv);
        break;
    case 2:
        put(b, "\"indices\": ");
        array(b, 3 * ntris + off, 1, nv);
        break;
    case 3:
        put(b, "\"normals\" :");
        array(b, 3 * nv + off, 0, nv);
        break;
    case 4:
        put(b, "\"uvs\":");
        array(b, 2 * nv + off, 0, nv);
        break;
    case 5: put(b, rnd(2) ? "\"smooth\": false" : "\"smooth\": true"); break;
    default:
        put(b, "\"source\": {\"format\": \"obj\", \"text\": \"v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nf 1 2 "
               "3\\n\"}");
        break;
    }
}

/* A mesh object with its keys in random order (some left out, some twice). */
static void mesh_object(struct buf *b) {
    int keys[8], n = 0, nv = 1 + (int)rnd(12), ntris = 1 + (int)rnd(10);
    keys[n++] = 0;
    keys[n++] = 1;
    keys[n++] = 2;
    if (rnd(3) == 0) keys[n++] = 3;
    if (rnd(3) == 0) keys[n++] = 4;
    if (rnd(4) == 0) keys[n++] = 5;
    if (odd_values && rnd(30) == 0) keys[n++] = 6;
    if (odd_values && rnd(30) == 0) keys[n++] = (int)rnd(5);
    if (odd_values && rnd(30) == 0) { /* one key dropped */
        n--;
        keys[rnd((unsigned)n + 1) % (unsigned)n] = keys[n];
    }
    for (int i = n - 1; i > 0; i--) {
        int j = (int)rnd((unsigned)i + 1), t = keys[i];
        keys[i] = keys[j];
        keys[j] = t;
    }
    put(b, "{");
    for (int i = 0; i < n; i++) {
        if (i) put(b, ", ");
        member(b, keys[i], nv, ntris);
    }
    put(b, "}");
}

static void scene(struct buf *b) {
    b->n = 0;
    odd_values = rnd(2);
    put(b, "{\"objects\": [");
    int n = 1 + (int)rnd(3);
    for (int i = 0; i < n; i++) {
        if (i) put(b, ",\n");
        if (rnd(15) == 0) {
            put(b, "{\"type\": \"csg\", \"op\": \"union\", \"operands\": [");
            mesh_object(b);
            put(b, ", {\"type\": \"sphere\"}]}");
        } else if (odd_values && rnd(15) == 0) {
            put(b, "{\"type\": \"instance\", \"group\": \"g\"}");
        } else {
            mesh_object(b);
        }
    }
    put(b, "]");
    if (rnd(4) == 0) {
        put(b, ", \"groups\": {\"g\": [");
        mesh_object(b);
        put(b, "]}");
    }
    put(b, "}");
}

static void limits(struct rayd_limits *lim) {
    rayd_limits_default(lim);
    if (rnd(8) == 0) lim->max_vertices = 1 + rnd(12);
    if (rnd(8) == 0) lim->max_triangles = 1 + rnd(10);
    if (rnd(10) == 0) lim->max_nesting = 2 + (int)rnd(3);
}

static void mutate(struct buf *b) {
    static const char alphabet[] = "0123456789-+.eE,[]{}\" \n:x";
    for (int k = 1 + (int)rnd(3); k > 0 && b->n > 1; k--) {
        size_t at = rnd((unsigned)b->n);
        switch (rnd(3)) {
        case 0:
            memmove(b->s + at, b->s + at + 1, b->n - at);
            b->n--;
            break;
        case 1: b->s[at] = alphabet[rnd(sizeof alphabet - 1)]; break;
        default: {
            char c[2] = {alphabet[rnd(sizeof alphabet - 1)], 0};
            put(b, c); /* grow by one, then shift the tail */
            memmove(b->s + at + 1, b->s + at, b->n - at - 1);
            b->s[at] = c[0];
        }
        }
    }
}

static int compare(const struct buf *b, const struct rayd_limits *lim, int *loaded) {
    char why[1024];
    bool ok;
    const char *diff = scene_compare(b->s, b->n, lim, why, sizeof why, &ok);
    CHECK(diff == NULL, "%s\n  for: %.400s", diff, b->s);
    *loaded += ok;
    return diff != NULL;
}

static void test_generated_and_mutated(void) {
    struct buf b = {0};
    int loaded = 0, total = 0, failed = 0;
    for (int i = 0; i < 4000 && failed < 5; i++) {
        struct rayd_limits lim;
        limits(&lim);
        scene(&b);
        failed += compare(&b, &lim, &loaded);
        total++;
        for (int m = 0; m < 3 && failed < 5; m++) {
            struct buf c = {0};
            put(&c, b.s);
            mutate(&c);
            failed += compare(&c, &lim, &loaded);
            free(c.s);
            total++;
        }
    }
    printf("  %d scenes, %d loaded\n", total, loaded);
    CHECK(loaded > total / 20 && loaded < total, "both outcomes exercised: %d of %d loaded", loaded,
          total);
    free(b.s);
}

/* Non-mesh places for mesh keys keep their numbers in the tree. */
static void test_mesh_keys_elsewhere(void) {
    static const char *const scenes[] = {
        "{\"groups\": {\"type\": \"mesh\", \"vertices\": [1, 2, 3, 4]}}",
        "{\"objects\": [{\"type\": \"triangle\", \"vertices\": [1, 2, 3]}]}",
        "{\"objects\": [{\"vertices\": [1, 2, 3], \"type\": \"triangle\"}]}",
        "{\"materials\": {\"vertices\": [1, 2, 3]}}",
        "{\"objects\": [{\"type\": \"mesh\", \"vertices\": [0,0,0, 1,0,0, 0,1,0], \"indices\": "
        "[0,1,2],"
        " \"material\": {\"type\": \"mesh\", \"vertices\": [1]}}]}",
        "{\"objects\": [{\"type\": \"mesh\", \"vertices\": [0,0,0, 1,0,0, 0,1,0], \"indices\": "
        "[0,1,2]},"
        " {\"type\": \"mesh\", \"vertices\": [0,0,0, 1,0,0, 0,1,0e1], \"indices\": [0,1,3]}]}",
        "{\"objects\": [{\"type\": \"mesh\", \"vertices\": [0,0,0, 1,0,0, 0,1,0], \"indices\": "
        "[0,1,2],"
        " \"type\": \"mesh\"}]}",
    };
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    int loaded = 0;
    for (size_t i = 0; i < sizeof scenes / sizeof *scenes; i++) {
        struct buf b = {0};
        put(&b, scenes[i]);
        compare(&b, &lim, &loaded);
        free(b.s);
    }
}

/* Arrays of many blocks, read on several threads: the first bad number in
 * text order is the one named, wherever the blocks are cut. */
static void test_large_arrays(void) {
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    int loaded = 0;
    odd_values = false;
    for (int round = 0; round < 6; round++) {
        struct buf b = {0};
        int nv = 60000, ntris = 50000, bad1 = (int)rnd(3 * (unsigned)nv),
            bad2 = (int)rnd(3 * (unsigned)nv);
        char t[96];
        put(&b, "{\"objects\": [{\"type\": \"mesh\", \"vertices\": [");
        for (int i = 0; i < 3 * nv; i++) {
            num(t, sizeof t);
            if (round >= 1 && (i == bad1 || (round >= 2 && i == bad2)))
                snprintf(t, sizeof t, "%s", round & 1 ? "1e31" : "1e999");
            else if (!(fabs(strtod(t, NULL)) <= 1e30) || strlen(t) > 63)
                snprintf(t, sizeof t, "%u", rnd(1000));
            put(&b, t);
            put(&b, i + 1 < 3 * nv ? (rnd(5) ? "," : ",\n ") : "]");
        }
        put(&b, ", \"indices\": [");
        for (int i = 0; i < 3 * ntris; i++) {
            snprintf(t, sizeof t, "%u", round == 1 && i == bad1 ? (unsigned)nv : rnd((unsigned)nv));
            put(&b, t);
            put(&b, i + 1 < 3 * ntris ? ", " : "]}]}");
        }
        compare(&b, &lim, &loaded);
        free(b.s);
    }
    CHECK(loaded == 1, "only the clean round loads: %d", loaded);
}

/* json_number is strtod, bit for bit. */
static void test_numbers_are_strtod(void) {
    char t[96];
    odd_values = true;
    for (int i = 0; i < 200000; i++) {
        num(t, sizeof t);
        if (strlen(t) > 63) continue;
        const char *p = t;
        double a = json_number(&p, '.'), b = strtod(t, NULL);
        CHECK(memcmp(&a, &b, sizeof a) == 0 && *p == 0, "%s: %.17g, strtod %.17g", t, a, b);
        if (check_failures_ > 5) return;
    }
}

int main(void) {
    RUN(test_numbers_are_strtod);
    RUN(test_mesh_keys_elsewhere);
    RUN(test_large_arrays);
    RUN(test_generated_and_mutated);
    CHECK_EXIT();
}
