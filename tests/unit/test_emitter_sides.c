/* test_emitter_sides.c -- "emission_sides": "front" makes a flat emitter
 * shine from the side its geometric normal points to only (glTF's and most
 * renderers' default; scene format v1's default, "both", is kept).  The
 * scene is a lamp quad over a white floor, seen from above:
 *   - facing the floor, a one-sided lamp lights it exactly as a two-sided
 *     one does: the floor's bytes are the same (the path tracer; Whitted's
 *     emission lights nothing else);
 *   - turned away, the floor gets no light at all: every pixel is black in
 *     the path tracer, though both NEE and bounced paths could reach it;
 *   - seen from behind by the camera, the lamp is black, from the front its
 *     emission shows, in the Whitted integrator, its 16-ray packet path
 *     (spheres and planes) and the path tracer. */
#include <stdbool.h>

#include "check.h"
#include "scene_util.h"

/* The floor at y = 0 and a lamp quad at y = 2 whose normal points down
 * (e1 x e2 = -y) or up; the camera above the lamp looks down through a
 * hole: the lamp covers the middle of the view, the floor shows around. */
static rayd_scene *lamp_scene(const char *integ, const char *sides, bool down) {
    char json[2048];
    snprintf(json, sizeof json,
             "{\"camera\": {\"position\": [0, 6, 0.01], \"look_at\": [0, 0, 0], \"fov_x\": 60},"
             " \"render\": {\"width\": 16, \"height\": 16, \"samples\": 8, \"max_depth\": 3,"
             "  \"integrator\": \"%s\"},"
             " \"materials\": {\"white\": {\"color\": [0.8, 0.8, 0.8], \"diffuse\": 1,"
             "  \"ambient\": 0},"
             "  \"lamp\": {\"color\": [0, 0, 0], \"emission\": [2, 2, 2], \"ambient\": 0,"
             "   \"diffuse\": 0, \"emission_sides\": \"%s\"}},"
             " \"objects\": ["
             "  {\"type\": \"quad\", \"corner\": [-9, 0, -9], \"edge1\": [0, 0, 18],"
             "   \"edge2\": [18, 0, 0], \"material\": \"white\"},"
             "  {\"type\": \"quad\", \"corner\": [-1, 2, -1], \"edge1\": %s, \"edge2\": %s,"
             "   \"material\": \"lamp\"}]}",
             integ, sides, down ? "[2, 0, 0]" : "[0, 0, 2]", down ? "[0, 0, 2]" : "[2, 0, 0]");
    return scene_from(json);
}

static rayd_image *render_of(rayd_scene *s) {
    rayd_image *img = s ? render_all(s, 1) : NULL;
    CHECK(img != NULL, "render");
    rayd_scene_free(s);
    return img;
}

/* The sum of the red and green bytes of the pixels inside (in) or outside
 * the square [lo, hi)^2 of the 16 x 16 view.  The lamp covers about the
 * middle 7 x 7 pixels: its middle is [7, 9), the floor outside [4, 12). */
static long bytes_sum(rayd_image *img, int lo, int hi, bool in) {
    const uint8_t *px = rayd_image_pixels_const(img);
    long sum = 0;
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 16; x++) {
            bool mid = x >= lo && x < hi && y >= lo && y < hi;
            if (mid == in) sum += px[3 * (y * 16 + x)] + px[3 * (y * 16 + x) + 1];
        }
    return sum;
}
#define LAMP(img) bytes_sum(img, 7, 9, true)
#define FLOOR(img) bytes_sum(img, 4, 12, false)

/* Whether the floor's pixels (outside [4, 12)^2) have the same bytes. */
static bool same_floor(rayd_image *a, rayd_image *b) {
    if (!a || !b) return false;
    const uint8_t *pa = rayd_image_pixels_const(a), *pb = rayd_image_pixels_const(b);
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 16; x++)
            if ((x < 4 || x >= 12 || y < 4 || y >= 12) &&
                memcmp(pa + 3 * (y * 16 + x), pb + 3 * (y * 16 + x), 3))
                return false;
    return FLOOR(a) > 0;
}

static void test_facing_floor_same_light(void) {
    rayd_image *one = render_of(lamp_scene("path", "front", true));
    rayd_image *two = render_of(lamp_scene("path", "both", true));
    CHECK(same_floor(one, two), "a one-sided lamp facing the floor lights it as a two-sided one");
    rayd_image_free(one);
    rayd_image_free(two);
}

static void test_turned_away_no_light(void) {
    rayd_image *one = render_of(lamp_scene("path", "front", false));
    rayd_image *two = render_of(lamp_scene("path", "both", false));
    if (!one || !two) goto out;
    CHECK(FLOOR(one) == 0, "the floor under a lamp turned away: %ld, expected 0", FLOOR(one));
    CHECK(FLOOR(two) > 0, "a two-sided lamp lights the floor either way");
out:
    rayd_image_free(one);
    rayd_image_free(two);
}

/* The camera above sees the lamp's top: its back when it faces down. */
static void test_back_is_black(void) {
    const char *integ[] = {"path", "whitted"};
    for (int i = 0; i < 2; i++) {
        rayd_image *back = render_of(lamp_scene(integ[i], "front", true));
        rayd_image *front = render_of(lamp_scene(integ[i], "front", false));
        if (back && front) {
            CHECK(LAMP(back) == 0, "%s: the back of a one-sided lamp: %ld", integ[i], LAMP(back));
            CHECK(LAMP(front) == 2 * 2 * 2 * 255, "%s: its front shows its emission: %ld", integ[i],
                  LAMP(front));
        }
        rayd_image_free(back);
        rayd_image_free(front);
    }
}

/* Whitted's packet path (spheres and planes, simple lights): a one-sided
 * emissive plane seen from behind is black, from the front bright. */
static void test_packet_path(void) {
    char text[1024];
    for (int sign = -1; sign <= 1; sign += 2) {
        snprintf(text, sizeof text,
                 "{\"camera\": {\"position\": [0, 0, 5], \"look_at\": [0, 0, 0]},"
                 " \"render\": {\"width\": 16, \"height\": 16},"
                 " \"lights\": [{\"type\": \"point\", \"position\": [0, 0, 4]}],"
                 " \"materials\": {\"lamp\": {\"color\": [0, 0, 0], \"emission\": [1, 1, 1],"
                 "  \"ambient\": 0, \"diffuse\": 0, \"specular\": 0,"
                 "  \"emission_sides\": \"front\"}},"
                 " \"objects\": [{\"type\": \"plane\", \"point\": [0, 0, 0],"
                 "  \"normal\": [0, 0, %d], \"material\": \"lamp\"}]}",
                 sign);
        rayd_image *img = render_of(scene_from(text));
        if (!img) continue;
        long sum = bytes_sum(img, 0, 16, true);
        long want = sign > 0 ? 16L * 16 * 2 * 255 : 0;
        CHECK(sum == want, "plane facing %s: %ld, expected %ld", sign > 0 ? "the camera" : "away",
              sum, want);
        rayd_image_free(img);
    }
}

static void test_bad_value(void) {
    const char *json = "{\"materials\": {\"m\": {\"emission_sides\": \"back\"}}}";
    rayd_scene *s = NULL;
    struct rayd_error err = {0};
    CHECK(rayd_scene_parse(json, strlen(json), NULL, &s, &err) != RAYD_OK, "refused");
    CHECK(!strcmp(err.path, "/materials/m/emission_sides"), "path %s", err.path);
    CHECK(strstr(err.message, "front") != NULL, "message names the choices: %s", err.message);
    rayd_scene_free(s);
}

int main(void) {
    RUN(test_facing_floor_same_light);
    RUN(test_turned_away_no_light);
    RUN(test_back_is_black);
    RUN(test_packet_path);
    RUN(test_bad_value);
    CHECK_EXIT();
}
