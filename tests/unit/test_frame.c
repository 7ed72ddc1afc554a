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
    CHECK(cam_frame_sphere(&c, v3(0, 0, 0), 2, VIEW_SIDE, 0, 60, 200, 100, NULL) == RAYD_OK, "side");
    CHECK_NEAR(c.pos.x, d, 1e-9);
    CHECK_NEAR(c.pos.y, 0, 1e-12);
    CHECK(cam_frame_sphere(&c, v3(0, 0, 0), 2, VIEW_TOP, 0, 60, 200, 100, NULL) == RAYD_OK, "top");
    CHECK_NEAR(c.pos.y, d, 1e-9);
    CHECK_NEAR(c.v.z, -1, 1e-12);
    CHECK(cam_frame_sphere(&c, v3(0, 0, 0), 2, VIEW_THREE_QUARTER, 0, 60, 200, 100, NULL) == RAYD_OK,
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
    expect_error("{\"camera\": {\"frame\": \"some\"}}", "/camera/frame");
    expect_error("{\"camera\": {\"frame\": \"all\", \"view\": \"back\"}}", "/camera/view");
    expect_error("{\"camera\": {\"view\": \"front\"}}", "/camera/view");
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
    RUN(test_errors_name_the_key);
    CHECK_EXIT();
}
