/* test_text_encoding.c -- text_encoding.c and the readers that use it: a
 * scene, an OBJ or a PLY saved as UTF-16 or UTF-32 (as Windows tools
 * often do) is refused with its encoding named, not "OBJ has no faces" or
 * "malformed JSON: expected a value"; UTF-8 text, with or without
 * letters beyond ASCII, is not taken for UTF-16. */
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "format/json_check.h"
#include "format/mesh_io.h"
#include "format/text_encoding.h"

/* s (ASCII) as UTF-16: little- or big-endian, with a byte order mark or
 * not, into buf; its length. */
static size_t utf16(const char *s, bool big, bool bom, unsigned char *buf) {
    size_t n = 0;
    if (bom) {
        buf[n++] = big ? 0xFE : 0xFF;
        buf[n++] = big ? 0xFF : 0xFE;
    }
    for (; *s; s++) {
        buf[n++] = big ? 0 : (unsigned char)*s;
        buf[n++] = big ? (unsigned char)*s : 0;
    }
    return n;
}

static void test_names(void) {
    unsigned char buf[256];
    const char *obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    const char *got = text_foreign_encoding(buf, utf16(obj, false, true, buf));
    CHECK(got && strcmp(got, "UTF-16 (little-endian)") == 0, "got %s", got ? got : "NULL");
    got = text_foreign_encoding(buf, utf16(obj, true, true, buf));
    CHECK(got && strcmp(got, "UTF-16 (big-endian)") == 0, "got %s", got ? got : "NULL");
    got = text_foreign_encoding(buf, utf16(obj, false, false, buf));
    CHECK(got && strstr(got, "UTF-16 (little-endian, no byte order mark)"), "got %s",
          got ? got : "NULL");
    got = text_foreign_encoding(buf, utf16(obj, true, false, buf));
    CHECK(got && strstr(got, "big-endian, no byte order mark"), "got %s", got ? got : "NULL");
    got = text_foreign_encoding("\xFF\xFE\0\0{\0\0\0", 8);
    CHECK(got && strcmp(got, "UTF-32 (little-endian)") == 0, "got %s", got ? got : "NULL");
    /* UTF-8, ASCII, binary PLY after its ASCII header, a short file: not foreign */
    CHECK(!text_foreign_encoding(obj, strlen(obj)), "ASCII taken for foreign");
    const char *utf8 = "# caf\xc3\xa9 \xe6\x97\xa5\xe6\x9c\xac\nv 0 0 0\n";
    CHECK(!text_foreign_encoding(utf8, strlen(utf8)), "UTF-8 taken for foreign");
    const char ply[] = "ply\nformat binary_little_endian 1.0\nelement vertex 3\n\0\0\0\0\0\0";
    CHECK(!text_foreign_encoding(ply, sizeof ply - 1), "binary PLY taken for foreign");
    CHECK(!text_foreign_encoding("a\0", 2), "two bytes taken for foreign");
}

static void test_readers_name_it(void) {
    unsigned char buf[512];
    struct mesh_data m;
    struct rayd_error err = {0};
    size_t n = utf16("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", false, true, buf);
    CHECK(mesh_parse_obj((const char *)buf, n, NULL, &m, &err) == RAYD_E_INVALID, "OBJ read");
    CHECK(strstr(err.message, "the OBJ file is UTF-16 (little-endian) text; save it as UTF-8"),
          "got %s", err.message);
    n = utf16("ply\nformat ascii 1.0\nelement vertex 0\nend_header\n", true, false, buf);
    CHECK(mesh_parse_ply(buf, n, NULL, &m, &err) == RAYD_E_INVALID, "PLY read");
    CHECK(strstr(err.message, "the PLY file is UTF-16 (big-endian, no byte order mark) text"),
          "got %s", err.message);
    n = utf16("{\"objects\": []}", false, true, buf);
    CHECK(json_check((const char *)buf, n, 64, &err) != RAYD_OK, "JSON read");
    CHECK(strstr(err.message, "malformed JSON: the text is UTF-16 (little-endian); save it as "
                              "UTF-8"),
          "got %s", err.message);
    /* the same OBJ as UTF-8 still reads */
    const char *obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    CHECK(mesh_parse_obj(obj, strlen(obj), NULL, &m, &err) == RAYD_OK, "%s", err.message);
    mesh_data_free(&m);
}

int main(void) {
    RUN(test_names);
    RUN(test_readers_name_it);
    CHECK_EXIT();
}
