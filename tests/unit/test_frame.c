/* test_frame.c -- camera.frame: the framed camera's place, checked against
 * the closed formula, and a rendered framed sphere measured in pixels. */
#include <string.h>

#include "geom/camera_frame.h"
#include "scene/scene.h"
#include "check.h"
#include "scene_util.h"

/* A sphere of radius r at c framed "front": the eye is c + (0, 0, d) with
 * d = r / sin(fov/2) * margin, looking at c (fov the smaller field, here
 * fov_y of a landscape image). */
static void test_front_distance_is_analytic(void) {
    const char *json =
        "{\"render\": {\"width\": 80, \"height\": 60},"
        " \"camera\": {\"frame\": \"all\", \"view\": \"front\", \"fov_y\": 40},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [1, 2, -3], \"radius\": 0.5}]}";
    rayd_scene *s = scene_from(json);
    CHECK(s != NULL, "parse");
    if (!s) return;
    double r = 0.5, d = r / sin(20 * M_PI / 180) * FRAME_MARGIN;
    CHECK_NEAR(s->cam.pos.x, 1, 1e-9);
    CHECK_NEAR(s->cam.pos.y, 2, 1e-9);
    CHECK_NEAR(s->cam.pos.z, -3 + d, 1e-9);
    CHECK_NEAR(s->cam.w.z, -1, 1e-12);
    CHECK_NEAR(s->cam.v.y, 1, 1e-12);
    rayd_scene_free(s);
}

/* The geometry on its own: the radius given is the one framed. */
static void test_cam_frame_sphere_views(void) {
    struct camera c;
    double d = 2 / sin(30 * M_PI / 180) * FRAME_MARGIN; /* fov_y 60 of a wide image */
    double az, el;
    cam_frame_view_angles(VIEW_SIDE, &az, &el);
    CHECK(cam_frame_sphere(&c, v3(0, 0, 0), 2, az, el, 0, 60, 200, 100, NULL) == RAYD_OK, "side");
    CHECK_NEAR(c.pos.x, d, 1e-9);
    CHECK_NEAR(c.pos.y, 0, 1e-12);
    cam_frame_view_angles(VIEW_TOP, &az, &el);
    CHECK(cam_frame_sphere(&c, v3(0, 0, 0), 2, az, el, 0, 60, 200, 100, NULL) == RAYD_OK, "top");
    CHECK_NEAR(c.pos.y, d, 1e-9);
    CHECK_NEAR(c.v.z, -1, 1e-12);
    cam_frame_view_angles(VIEW_THREE_QUARTER, &az, &el);
    CHECK(cam_frame_sphere(&c, v3(0, 0, 0), 2, az, el, 0, 60, 200, 100, NULL) == RAYD_OK,
          "three-quarter");
    CHECK_NEAR(v3_len(c.pos), d, 1e-9);
    CHECK_NEAR(c.pos.y / d, 0.5, 1e-12); /* 30 degrees up */
    CHECK_NEAR(c.pos.x, c.pos.z, 1e-12); /* azimuth 45 degrees */
    CHECK(c.pos.x > 0, "from +X+Z");
}

/* Rows and columns of the image that hold a lit pixel. */
static void lit_extent(const rayd_image *img, int *cols, int *rows, bool *edge) {
    int w = rayd_image_width(img), h = rayd_image_height(img);
    const uint8_t *px = rayd_image_pixels_const(img);
    int x0 = w, x1 = -1, y0 = h, y1 = -1;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const uint8_t *p = px + 3 * ((size_t)y * w + x);
            if (p[0] + p[1] + p[2] == 0) continue;
            x0 = x < x0 ? x : x0, x1 = x > x1 ? x : x1;
            y0 = y < y0 ? y : y0, y1 = y > y1 ? y : y1;
        }
    *cols = x1 - x0 + 1;
    *rows = y1 - y0 + 1;
    *edge = x0 == 0 || y0 == 0 || x1 == w - 1 || y1 == h - 1;
}

/* A framed sphere touches no edge of the image and fills most of its
 * smaller dimension (about 1 / margin of it; perspective shrinks it a
 * little). */
static void test_rendered_sphere_fills_the_frame(void) {
    const char *views[] = {"front", "side", "top", "three-quarter"};
    for (int i = 0; i < 4; i++) {
        char json[512];
        snprintf(json, sizeof json,
                 "{\"render\": {\"width\": 96, \"height\": 64, \"background\": [0, 0, 0]},"
                 " \"camera\": {\"frame\": \"all\", \"view\": \"%s\"},"
                 " \"materials\": {\"m\": {\"emission\": [1, 1, 1]}},"
                 " \"objects\": [{\"type\": \"sphere\", \"center\": [5, -1, 2], \"radius\": 3,"
                 " \"material\": \"m\"}]}",
                 views[i]);
        rayd_scene *s = scene_from(json);
        CHECK(s != NULL, "parse %s", views[i]);
        if (!s) continue;
        rayd_image *img = render_all(s, 1);
        CHECK(img != NULL, "render %s", views[i]);
        if (img) {
            int cols, rows;
            bool edge;
            lit_extent(img, &cols, &rows, &edge);
            CHECK(!edge, "%s: the sphere touches the image's edge", views[i]);
            CHECK(rows >= 64 * 3 / 4 && rows < 64, "%s: %d rows of 64 lit", views[i], rows);
            CHECK(cols == rows || cols == rows + 1 || cols == rows - 1, "%s: %d cols, %d rows",
                  views[i], cols, rows);
            rayd_image_free(img);
        }
        rayd_scene_free(s);
    }
}

/* The named views' cameras are exactly those framing had before azimuth
 * and elevation existed: the eye on the exact axis (or the 45/30 formula),
 * the same basis to the bit and the sign of every zero (a -0 in a ray
 * direction would flip an infinity in the box tests). */
static void test_named_views_are_exact(void) {
    double el = 30 * DEG2RAD, az = 45 * DEG2RAD;
    const vec3 dirs[] = {v3(cos(el) * sin(az), sin(el), cos(el) * cos(az)), v3(0, 0, 1),
                         v3(1, 0, 0), v3(0, 1, 0)};
    const vec3 ups[] = {v3(0, 1, 0), v3(0, 1, 0), v3(0, 1, 0), v3(0, 0, -1)};
    for (int run = 0; run < 8; run++) {
        int view = run % 4;
        vec3 centre = run < 4 ? v3(0, 0, 0) : v3(0.25, -3, 7);
        double a, e;
        cam_frame_view_angles((enum frame_view)view, &a, &e);
        struct camera got, want;
        CHECK(cam_frame_sphere(&got, centre, 2, a, e, 0, 50, 64, 48, NULL) == RAYD_OK, "view %d",
              view);
        double half = atan(fmin(got.tan_x, got.tan_y));
        double d = 2 / sin(half) * FRAME_MARGIN;
        CHECK(cam_init(&want, v3_madd(centre, dirs[view], d), centre, ups[view], 0, 50, 64, 48,
                       NULL) == RAYD_OK,
              "view %d: the reference camera", view);
        const vec3 *g = &got.pos, *w = &want.pos;
        for (int k = 0; k < 4; k++) {
            const double *gd = &g[k].x, *wd = &w[k].x;
            for (int i = 0; i < 3; i++)
                CHECK(gd[i] == wd[i] && signbit(gd[i]) == signbit(wd[i]),
                      "view %d, vector %d, component %d: %.17g, want %.17g", view, k, i, gd[i],
                      wd[i]);
        }
    }
}

/* A scene of a few objects (a box and spheres, so that no view is
 * symmetric) framed with the given camera keys, rendered; NULL when refused. */
static rayd_image *render_framed(const char *camera_keys) {
    char json[1024];
    snprintf(json, sizeof json,
             "{\"render\": {\"width\": 40, \"height\": 30, \"samples\": 2},"
             " \"camera\": {\"frame\": \"all\", %s},"
             " \"lights\": [{\"type\": \"point\", \"position\": [4, 6, 5]}],"
             " \"objects\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1},"
             " {\"type\": \"sphere\", \"center\": [2, 0.5, 0], \"radius\": 0.5},"
             " {\"type\": \"box\", \"min\": [-0.5, -1, 1], \"max\": [0.5, 0, 1.8]}]}",
             camera_keys);
    rayd_scene *s = scene_from(json);
    if (!s) return NULL;
    rayd_image *img = render_all(s, 1);
    rayd_scene_free(s);
    return img;
}

/* Whether two framings render to the same bytes. */
static bool same_image(const char *a, const char *b) {
    rayd_image *ia = render_framed(a), *ib = render_framed(b);
    bool same = ia && ib && rayd_image_width(ia) == rayd_image_width(ib) &&
                memcmp(rayd_image_pixels_const(ia), rayd_image_pixels_const(ib),
                       (size_t)3 * rayd_image_width(ia) * rayd_image_height(ia)) == 0;
    if (ia) rayd_image_free(ia);
    if (ib) rayd_image_free(ib);
    return same;
}

/* azimuth and elevation reproduce each named view bit for bit, replace
 * the view's angles one at a time, and turn the eye. */
static void test_angles_equal_the_named_views(void) {
    CHECK(same_image("\"view\": \"front\"", "\"azimuth\": 0, \"elevation\": 0"), "front = 0, 0");
    CHECK(same_image("\"view\": \"side\"", "\"azimuth\": 90, \"elevation\": 0"), "side = 90, 0");
    CHECK(same_image("\"view\": \"side\"", "\"azimuth\": -270, \"elevation\": 0"),
          "side = -270, 0");
    CHECK(same_image("\"view\": \"top\"", "\"azimuth\": 0, \"elevation\": 90"), "top = 0, 90");
    CHECK(same_image("\"view\": \"three-quarter\"", "\"azimuth\": 45"), "three-quarter = 45");
    CHECK(same_image("\"view\": \"three-quarter\"", "\"elevation\": 30"), "three-quarter = el 30");
    CHECK(same_image("\"view\": \"front\"", "\"view\": \"side\", \"azimuth\": 0"),
          "side with azimuth 0 = front");
    CHECK(same_image("\"view\": \"top\"", "\"view\": \"front\", \"elevation\": 90"),
          "front with elevation 90 = top");
    CHECK(!same_image("\"azimuth\": 0", "\"azimuth\": 90"), "azimuths 0 and 90 differ");
    CHECK(!same_image("\"azimuth\": 10", "\"azimuth\": 10.5"), "azimuths 10 and 10.5 differ");
    CHECK(!same_image("\"elevation\": 90", "\"elevation\": -90"), "above and below differ");
}

/* Every angle in range gives a camera, even at and next to the poles,
 * where +Y is (nearly) the view direction; the eye is where the angles say. */
static void test_angles_place_the_eye(void) {
    const char *keys[] = {"\"elevation\": 90",         "\"elevation\": -90",
                          "\"elevation\": 89.9999999", "\"elevation\": -89.5, \"azimuth\": 33",
                          "\"azimuth\": 360",          "\"azimuth\": -360"};
    for (int i = 0; i < 6; i++) {
        rayd_image *img = render_framed(keys[i]);
        CHECK(img != NULL, "%s: refused", keys[i]);
        if (img) rayd_image_free(img);
    }
    struct camera c;
    double d = 1 / sin(30 * M_PI / 180) * FRAME_MARGIN;
    CHECK(cam_frame_sphere(&c, v3(0, 0, 0), 1, 180, 0, 0, 60, 200, 100, NULL) == RAYD_OK, "180");
    CHECK_NEAR(c.pos.z, -d, 1e-9);
    CHECK(cam_frame_sphere(&c, v3(0, 0, 0), 1, 270, -60, 0, 60, 200, 100, NULL) == RAYD_OK, "270");
    CHECK_NEAR(c.pos.x, -d * 0.5, 1e-9);
    CHECK_NEAR(c.pos.y, -d * sin(60 * M_PI / 180), 1e-9);
    CHECK_NEAR(c.v.y, 0.5, 1e-9); /* the image's up still leans toward +Y */
}

static void expect_error(const char *json, const char *path) {
    rayd_scene *s = NULL;
    struct rayd_error err = {0};
    enum rayd_status st = rayd_scene_parse(json, strlen(json), NULL, &s, &err);
    CHECK(st != RAYD_OK, "%s: must be refused", json);
    CHECK(strcmp(err.path, path) == 0, "%s: pointer %s, want %s (%s)", json, err.path, path,
          err.message);
    if (s) rayd_scene_free(s);
}

static void test_errors_name_the_key(void) {
    expect_error("{\"camera\": {\"frame\": \"all\"}}", "/camera/frame");
    expect_error("{\"camera\": {\"frame\": \"all\"}, \"objects\": [{\"type\": \"plane\"}]}",
                 "/camera/frame");
    /* bounds too small to stand the eye apart from: the key given, not look_at */
    expect_error(
        "{\"camera\": {\"frame\": \"all\"},"
        " \"objects\": [{\"type\": \"sphere\", \"center\": [5, 0, 0], \"radius\": 1e-13}]}",
        "/camera/frame");
    expect_error("{\"camera\": {\"frame\": \"all\"}, \"objects\": [{\"type\": \"mesh\","
                 " \"vertices\": [0, 0, 0, 1e-20, 0, 0, 0, 1e-20, 0], \"indices\": [0, 1, 2]}]}",
                 "/camera/frame");
    expect_error("{\"camera\": {\"frame\": \"some\"}}", "/camera/frame");
    expect_error("{\"camera\": {\"frame\": \"all\", \"view\": \"back\"}}", "/camera/view");
    expect_error("{\"camera\": {\"view\": \"front\"}}", "/camera/view");
    expect_error("{\"camera\": {\"azimuth\": 30}}", "/camera/azimuth");
    expect_error("{\"camera\": {\"elevation\": 30}}", "/camera/elevation");
    expect_error("{\"camera\": {\"frame\": \"all\", \"azimuth\": 360.5},"
                 " \"objects\": [{\"type\": \"sphere\"}]}",
                 "/camera/azimuth");
    expect_error("{\"camera\": {\"frame\": \"all\", \"azimuth\": \"north\"},"
                 " \"objects\": [{\"type\": \"sphere\"}]}",
                 "/camera/azimuth");
    expect_error("{\"camera\": {\"frame\": \"all\", \"elevation\": -91},"
                 " \"objects\": [{\"type\": \"sphere\"}]}",
                 "/camera/elevation");
    expect_error("{\"camera\": {\"frame\": \"all\", \"position\": [0, 0, 5]},"
                 " \"objects\": [{\"type\": \"sphere\"}]}",
                 "/camera/position");
    expect_error("{\"camera\": {\"frame\": \"all\", \"projection\": \"orthographic\"},"
                 " \"objects\": [{\"type\": \"sphere\"}]}",
                 "/camera/projection");
}

int main(void) {
    RUN(test_front_distance_is_analytic);
    RUN(test_cam_frame_sphere_views);
    RUN(test_rendered_sphere_fills_the_frame);
    RUN(test_named_views_are_exact);
    RUN(test_angles_equal_the_named_views);
    RUN(test_angles_place_the_eye);
    RUN(test_errors_name_the_key);
    CHECK_EXIT();
}
