/* test_scene_json.c -- scene format v1: defaults, strict validation, and
 * errors that name the JSON Pointer or the line and column. */
#include <stdlib.h>

#include "check.h"
#include "scene/scene.h"
#include "scene_util.h"

static enum rayd_status parse(const char *json, struct rayd_error *err) {
    rayd_scene *s = NULL;
    memset(err, 0, sizeof *err);
    enum rayd_status st = rayd_scene_parse(json, strlen(json), NULL, &s, err);
    CHECK((st == RAYD_OK) == (s != NULL), "scene returned only on success");
    rayd_scene_free(s);
    return st;
}

static void expect(const char *json, enum rayd_status code, const char *path, const char *msg) {
    struct rayd_error err;
    enum rayd_status st = parse(json, &err);
    CHECK(st == code, "%s: status %s, want %s", json, rayd_status_name(st), rayd_status_name(code));
    CHECK(strcmp(err.path, path) == 0, "%s: path '%s', want '%s'", json, err.path, path);
    CHECK(strstr(err.message, msg) != NULL, "%s: message '%s' lacks '%s'", json, err.message, msg);
}

static void test_defaults(void) {
    rayd_scene *s = scene_from("{}");
    CHECK(s != NULL, "empty object is a valid scene");
    if (!s) return;
    CHECK(s->rs.width == 640 && s->rs.height == 480, "640x480");
    CHECK(s->rs.samples == 1 && s->rs.max_depth == 5 && s->rs.seed == 0, "samples, depth, seed");
    CHECK_NEAR(s->cam.tan_x, tan(M_PI / 6), 1e-15);
    rayd_scene_free(s);
    s = scene_from("{\"objects\": [{\"type\": \"sphere\"}]}");
    CHECK(s && s->nobjs == 1, "sphere");
    if (!s) return;
    const struct material *m = &s->mats[s->objs[0].material];
    CHECK(m->color.x == 0.8 && m->ambient == 0.1 && m->diffuse == 0.9 && m->specular == 0 &&
              m->shininess == 32 && m->reflectivity == 0 && m->transparency == 0 && m->ior == 1.5 &&
              m->emission.x == 0,
          "material defaults");
    CHECK(s->objs[0].u.sphere.radius == 1, "radius default 1");
    rayd_scene_free(s);
}

static void test_design_example_parses(void) {
    const char *json =
        "{\"camera\":  {\"position\": [0, 1, 6], \"look_at\": [0, 1, 0], \"up\": [0, 1, 0], "
        "\"fov_x\": 60},"
        " \"render\":  {\"width\": 640, \"height\": 480, \"samples\": 1, \"max_depth\": 5,"
        "   \"background\": [0.05, 0.05, 0.08], \"seed\": 0},"
        " \"materials\": {"
        "   \"red\":    {\"color\": [0.9, 0.1, 0.1], \"diffuse\": 0.9, \"specular\": 0.5, "
        "\"shininess\": 64},"
        "   \"mirror\": {\"color\": [1, 1, 1], \"diffuse\": 0.1, \"reflectivity\": 0.9}},"
        " \"lights\":  [{\"type\": \"point\", \"position\": [5, 8, 5], \"color\": [1, 1, 1], "
        "\"intensity\": 1.0}],"
        " \"objects\": ["
        "   {\"type\": \"plane\",  \"point\": [0, 0, 0], \"normal\": [0, 1, 0], \"material\": "
        "\"mirror\"},"
        "   {\"type\": \"sphere\", \"center\": [0, 1, 0], \"radius\": 1, \"material\": \"red\"},"
        "   {\"type\": \"sphere\", \"center\": [2, 1, 0], \"radius\": 0.5,"
        "    \"material\": {\"color\": [0.2, 0.4, 1], \"emission\": [0, 0, 0]}}]}";
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "DESIGN.md example");
    if (!s) return;
    CHECK(s->nobjs == 2 && s->nplanes == 1 && s->nlights == 1, "counts");
    CHECK(s->mats[s->planes[0].material].reflectivity == 0.9, "named material resolved");
    rayd_scene_free(s);
}

static void test_errors_name_the_path(void) {
    expect("{\"objects\": [{\"type\": \"sphere\"}, {\"type\": \"sphere\", \"radius\": -1}]}",
           RAYD_E_INVALID, "/objects/1/radius", "must be > 0");
    expect("{\"objects\": [{\"type\": \"sphere\", \"radius\": \"2\"}]}", RAYD_E_INVALID,
           "/objects/0/radius", "must be a number, not a string");
    expect("{\"objects\": [{\"type\": \"sphere\", \"radius\": 1e999}]}", RAYD_E_INVALID,
           "/objects/0/radius", "finite");
    expect("{\"objects\": [{\"type\": \"sphere\", \"colour\": 1}]}", RAYD_E_INVALID,
           "/objects/0/colour", "unknown key");
    expect("{\"objects\": [{\"type\": \"cube\"}]}", RAYD_E_INVALID, "/objects/0/type",
           "unknown type \"cube\"");
    expect("{\"objects\": [{\"radius\": 1}]}", RAYD_E_INVALID, "/objects/0/type", "is required");
    expect("{\"objects\": [{\"type\": \"plane\", \"normal\": [0, 0, 0]}]}", RAYD_E_INVALID,
           "/objects/0/normal", "zero-length");
    expect("{\"objects\": [{\"type\": \"sphere\", \"center\": [0, 1]}]}", RAYD_E_INVALID,
           "/objects/0/center", "array of 3 numbers");
    expect("{\"objects\": [{\"type\": \"sphere\", \"center\": [0, null, 1]}]}", RAYD_E_INVALID,
           "/objects/0/center/1", "must be a number, not null");
    expect("{\"objects\": [{\"type\": \"sphere\", \"material\": \"gold\"}]}", RAYD_E_INVALID,
           "/objects/0/material", "unknown material \"gold\"");
    expect("{\"materials\": {\"a/b\": {\"diffuse\": 2}}}", RAYD_E_INVALID,
           "/materials/a~1b/diffuse", "must be <= 1");
    expect("{\"materials\": {\"m\": {\"color\": [1, -0.5, 0]}}}", RAYD_E_INVALID,
           "/materials/m/color/1", "must be >= 0");
    expect("{\"render\": {\"width\": 10.5}}", RAYD_E_INVALID, "/render/width", "integer");
    expect("{\"render\": {\"width\": 0}}", RAYD_E_INVALID, "/render/width", "must be >= 1");
    expect("{\"render\": {\"samples\": 100000}}", RAYD_E_LIMIT, "/render/samples", "<= 1024");
    expect("{\"render\": {\"width\": 16384, \"height\": 16384}}", RAYD_E_LIMIT, "/render",
           "over the limit");
    expect("{\"camera\": {\"look_at\": [0, 5, 0]}}", RAYD_E_INVALID, "/camera/up", "parallel");
    expect("{\"camera\": {\"fov_x\": 180}}", RAYD_E_INVALID, "/camera/fov_x", "must be <= 179");
    expect("{\"lights\": [{\"type\": \"directional\", \"position\": [1, 2, 3]}]}", RAYD_E_INVALID,
           "/lights/0/position", "unknown key");
    expect("{\"lights\": {}}", RAYD_E_INVALID, "/lights", "must be an array");
    expect("{\"render\": {\"width\": 10, \"width\": 20}}", RAYD_E_INVALID, "/render/width",
           "duplicate key");
    expect("[1, 2]", RAYD_E_INVALID, "", "must be a JSON object");
    expect("{\"version\": 2}", RAYD_E_INVALID, "/version", "must be 1");
}

static void test_malformed_json_has_line_and_column(void) {
    struct rayd_error err;
    CHECK(parse("{\n  \"render\": {\"width\": 10,,\n}", &err) == RAYD_E_PARSE, "parse error");
    CHECK(err.line == 2 && err.column == 26, "line %d column %d", err.line, err.column);
    CHECK(strstr(err.message, "expected a string key in quotes, found ','") != NULL, "%s",
          err.message);
    /* at the comma to delete, not at what follows it (on the next line) */
    CHECK(parse("{\"a\": [1, 2,]}", &err) == RAYD_E_PARSE && err.column == 12 &&
              strstr(err.message, "trailing comma before ']'"),
          "trailing comma: %s col %d", err.message, err.column);
    CHECK(parse("{\n  \"a\": 1,\n}", &err) == RAYD_E_PARSE && err.line == 2 && err.column == 9 &&
              strstr(err.message, "trailing comma before '}'"),
          "trailing comma: %s line %d col %d", err.message, err.line, err.column);
    CHECK(parse("{\"a\": 01}", &err) == RAYD_E_PARSE && err.column == 8, "leading zero col %d",
          err.column);
    CHECK(parse("{\"a\": \"\\ud800\"}", &err) == RAYD_E_PARSE && strstr(err.message, "surrogate"),
          "lone surrogate: %s", err.message);
    CHECK(parse("{\"a\": \"x\ty\"}", &err) == RAYD_E_PARSE && strstr(err.message, "control"),
          "raw tab in string: %s", err.message);
    CHECK(parse("{\"a\": 1", &err) == RAYD_E_PARSE && strstr(err.message, "end of input"),
          "truncated: %s", err.message);
    CHECK(parse("{} {}", &err) == RAYD_E_PARSE && err.column == 4, "trailing data col %d",
          err.column);
    CHECK(parse("", &err) == RAYD_E_PARSE, "empty text");
    CHECK(parse("{\"objects\": [\"\xc3\x28\"]}", &err) == RAYD_E_PARSE &&
              strstr(err.message, "UTF-8") && err.column == 15,
          "invalid UTF-8: %s col %d", err.message, err.column);
    char deep[400];
    memset(deep, '[', 200);
    memset(deep + 200, ']', 199);
    deep[399] = '\0';
    CHECK(parse(deep, &err) == RAYD_E_PARSE && strstr(err.message, "nesting"), "deep nesting: %s",
          err.message);
    char buf[300];
    parse("{\n\n   x}", &err);
    CHECK(strcmp(rayd_error_format(&err, buf, sizeof buf),
                 "line 3, column 4: malformed JSON: expected a string key in quotes, found 'x'") ==
              0,
          "formatted: %s", buf);
}

static void test_limits_are_configurable(void) {
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.max_objects = 2;
    lim.max_bytes = 1000;
    const char *three =
        "{\"objects\": [{\"type\": \"sphere\"}, {\"type\": \"sphere\"}, {\"type\": \"sphere\"}]}";
    rayd_scene *s = NULL;
    struct rayd_error err;
    CHECK(rayd_scene_parse(three, strlen(three), &lim, &s, &err) == RAYD_E_LIMIT &&
              strcmp(err.path, "/objects") == 0,
          "object limit: %s %s", err.path, err.message);
    char *big = calloc(1, 2001);
    memset(big, ' ', 2000);
    big[0] = '{';
    big[1999] = '}';
    CHECK(rayd_scene_parse(big, 2000, &lim, &s, &err) == RAYD_E_LIMIT, "byte limit");
    free(big);
    CHECK(s == NULL, "nothing returned");
}

/* Instances find their group by name among many (a sorted index: a scan
 * per instance made 40,000 instances of 40,000 groups a 10 s parse): each
 * takes the group it names, whatever the order of /groups, and a name
 * not there is an error at the instance's "group". */
static void test_instances_find_their_groups(void) {
    enum { G = 300 };
    size_t cap = 200 * G, n = 0;
    char *json = malloc(cap);
    n += (size_t)snprintf(json + n, cap - n, "{\"groups\": {");
    for (int i = 0; i < G; i++) /* names not in sorted order */
        n += (size_t)snprintf(json + n, cap - n, "%s\"g%d\": [{\"type\": \"sphere\"}]",
                              i ? ", " : "", (i * 7919) % G);
    n += (size_t)snprintf(json + n, cap - n, "}, \"objects\": [");
    for (int i = 0; i < G; i++)
        n += (size_t)snprintf(json + n, cap - n, "%s{\"type\": \"instance\", \"group\": \"g%d\"}",
                              i ? ", " : "", i);
    snprintf(json + n, cap - n, "]}");
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    for (int i = 0; s && i < G; i++) {
        int want = -1; /* group k of /groups is named g((k * 7919) % G) */
        for (int k = 0; k < G; k++)
            if ((k * 7919) % G == i) want = k;
        int got = i < s->nobjs && s->objs[i].kind == SHAPE_INSTANCE ? s->objs[i].u.inst.group : -2;
        CHECK(got == want, "instance %d: group %d, want %d", i, got, want);
    }
    rayd_scene_free(s);
    free(json);
    const char *bad = "{\"groups\": {\"a\": [{\"type\": \"sphere\"}]}, \"objects\": "
                      "[{\"type\": \"instance\", \"group\": \"a\"}, "
                      "{\"type\": \"instance\", \"group\": \"b\"}]}";
    rayd_scene *t = NULL;
    struct rayd_error err = {0};
    enum rayd_status st = rayd_scene_parse(bad, strlen(bad), NULL, &t, &err);
    CHECK(st == RAYD_E_INVALID && !t, "status %d", st);
    CHECK(strcmp(err.path, "/objects/1/group") == 0, "path %s", err.path);
    CHECK(strstr(err.message, "unknown group \"b\"") != NULL, "message %s", err.message);
}

int main(void) {
    RUN(test_instances_find_their_groups);
    RUN(test_defaults);
    RUN(test_design_example_parses);
    RUN(test_errors_name_the_path);
    RUN(test_malformed_json_has_line_and_column);
    RUN(test_limits_are_configurable);
    CHECK_EXIT();
}
