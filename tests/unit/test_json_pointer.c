/* test_json_pointer.c -- json_pointer.c: the pointers every scene and glTF
 * error names its value by.  Keys are escaped as RFC 6901 says; a long key
 * is shown cut and the pointer goes on after it; a pointer too long for its
 * buffer ends in "..." at a character boundary and takes nothing more; no
 * key or depth ever writes past the buffer (ASan checks that in the
 * sanitizer run).  A material name of 300 characters with a bad color once
 * wrote past the buffer and crashed the loader. */
#include <stdbool.h>
#include <string.h>

#include "check.h"
#include "format/json_pointer.h"

static bool ends_with(const char *s, const char *tail) {
    size_t n = strlen(s), t = strlen(tail);
    return n >= t && strcmp(s + n - t, tail) == 0;
}

/* True when s is whole UTF-8: no sequence cut short. */
static bool utf8_whole(const char *s) {
    for (const unsigned char *p = (const unsigned char *)s; *p;) {
        int len = *p < 0x80 ? 1 : *p >= 0xF0 ? 4 : *p >= 0xE0 ? 3 : *p >= 0xC0 ? 2 : 0;
        if (!len) return false;
        for (int k = 1; k < len; k++)
            if ((p[k] & 0xC0) != 0x80) return false;
        p += len;
    }
    return true;
}

static void test_escapes(void) {
    struct jp root = {.s = ""}, m = jp_key(&root, "materials");
    struct jp k = jp_key(&m, "a/b~c"), i = jp_index(&k, 12);
    CHECK(strcmp(k.s, "/materials/a~1b~0c") == 0, "got %s", k.s);
    CHECK(strcmp(i.s, "/materials/a~1b~0c/12") == 0, "got %s", i.s);
    struct jp ctl = jp_key(&m, "x\ny");
    CHECK(strcmp(ctl.s, "/materials/x\\u000ay") == 0, "got %s", ctl.s);
    struct jp empty = jp_key(&root, "");
    CHECK(strcmp(empty.s, "/") == 0, "got %s", empty.s);
}

static void test_long_key(void) {
    char name[301];
    memset(name, 'm', 300);
    name[300] = '\0';
    struct jp root = {.s = "/materials"}, k = jp_key(&root, name);
    struct jp c = jp_key(&k, "color"), i = jp_index(&c, 2);
    CHECK(ends_with(i.s, ".../color/2"), "got %s", i.s);
    CHECK(strncmp(i.s, "/materials/mmm", 14) == 0, "got %s", i.s);
    CHECK(!i.cut, "a long key alone does not cut the pointer");
    CHECK(strlen(i.s) < 120, "the key is shown cut: %zu bytes", strlen(i.s));
}

/* Deep pointers of every key length, with multi-byte characters: the
 * pointer stays inside its buffer, whole UTF-8, and once cut ends in
 * "..." whatever is appended. */
static void test_deep(void) {
    const char *keys[] = {"a", "operands", "\xc3\xa9\xc3\xa9\xc3\xa9", "k/~",
                          "\xe2\x82\xac\xe2\x82\xac\xe2\x82\xac\xe2\x82\xac\xe2\x82\xac"
                          "\xe2\x82\xac\xe2\x82\xac\xe2\x82\xac\xe2\x82\xac\xe2\x82\xac"};
    for (int kind = 0; kind < 5; kind++) {
        struct jp p = {.s = ""};
        bool was_cut = false;
        for (int depth = 0; depth < 200; depth++) {
            p = depth % 3 == 2 ? jp_index(&p, 1234567L * depth) : jp_key(&p, keys[kind]);
            CHECK(strlen(p.s) < sizeof p.s, "kind %d depth %d", kind, depth);
            CHECK(utf8_whole(p.s), "kind %d depth %d: %s", kind, depth, p.s);
            if (was_cut) CHECK(p.cut && ends_with(p.s, "..."), "kind %d depth %d", kind, depth);
            was_cut = p.cut;
        }
        CHECK(was_cut && ends_with(p.s, "..."), "kind %d: %s", kind, p.s);
    }
}

static void test_quote(void) {
    char q[16];
    CHECK(strcmp(jp_quote(q, sizeof q, "a\"b\\c"), "a\\\"b\\\\c") == 0, "got %s", q);
    CHECK(strcmp(jp_quote(q, sizeof q, "abcdefghijklmnopqrstuvwxyz"), "abcdefghijk...") == 0,
          "got %s", q);
    CHECK(strcmp(jp_quote(q, sizeof q, "\xc3\xa9\xc3\xa9\xc3\xa9\xc3\xa9\xc3\xa9\xc3\xa9"),
                 "\xc3\xa9\xc3\xa9\xc3\xa9\xc3\xa9\xc3\xa9...") == 0,
          "got %s", q);
}

int main(void) {
    RUN(test_escapes);
    RUN(test_long_key);
    RUN(test_deep);
    RUN(test_quote);
    CHECK_EXIT();
}
