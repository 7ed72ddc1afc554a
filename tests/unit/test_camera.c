/* test_camera.c -- the paper's camera formulas (1)-(5), checked numerically. */
#include <string.h>

#include "geom/camera.h"
#include "check.h"

static void check_basis(const struct camera *c) {
    CHECK_NEAR(v3_len(c->u), 1, 1e-12);
    CHECK_NEAR(v3_len(c->v), 1, 1e-12);
    CHECK_NEAR(v3_len(c->w), 1, 1e-12);
    CHECK_NEAR(v3_dot(c->u, c->v), 0, 1e-12);
    CHECK_NEAR(v3_dot(c->u, c->w), 0, 1e-12);
    CHECK_NEAR(v3_dot(c->v, c->w), 0, 1e-12);
}

static void test_basis_orthonormal(void) {
    struct camera c;
    vec3 eyes[] = {{0, 0, 0}, {3, -2, 7}, {1e4, 5, -3e3}};
    vec3 looks[] = {{0, 0, -1}, {-1, 4, 0.5}, {0, 0, 0}};
    vec3 ups[] = {{0, 1, 0}, {0.2, 1, 0.1}, {0, 0, 1}};
    for (int i = 0; i < 3; i++) {
        CHECK(cam_init(&c, eyes[i], looks[i], ups[i], 60, 0, 64, 48, NULL) == RAYD_OK, "case %d",
              i);
        check_basis(&c);
        /* w points at look_at; u is w x up (to the right); v = u x w */
        vec3 w = v3_norm(v3_sub(looks[i], eyes[i]));
        CHECK_NEAR(v3_dot(c.w, w), 1, 1e-12);
        vec3 u = v3_norm(v3_cross(w, ups[i]));
        CHECK_NEAR(v3_dot(c.u, u), 1, 1e-12);
        vec3 v = v3_cross(c.u, c.w);
        CHECK_NEAR(v3_dot(c.v, v), 1, 1e-12);
        CHECK(v3_dot(c.v, ups[i]) > 0, "v must lean toward up");
    }
}

static void test_centre_of_odd_image_looks_along_w(void) {
    struct camera c;
    CHECK(cam_init(&c, v3(1, 2, 3), v3(4, 0, -2), v3(0, 1, 0), 70, 0, 101, 77, NULL) == RAYD_OK,
          "init");
    vec3 d = cam_dir(&c, 50 + 0.5, 38 + 0.5); /* pixel (50, 38) is the centre */
    CHECK_NEAR(d.x, c.w.x, 1e-15);
    CHECK_NEAR(d.y, c.w.y, 1e-15);
    CHECK_NEAR(d.z, c.w.z, 1e-15);
}

static void test_edge_directions_match_fov(void) {
    struct camera c;
    int n = 200, m = 100;
    double fx = 90, fy = 40;
    CHECK(cam_init(&c, v3(0, 0, 0), v3(0, 0, -1), v3(0, 1, 0), fx, fy, n, m, NULL) == RAYD_OK,
          "init");
    double tx = tan(fx / 2 * M_PI / 180), ty = tan(fy / 2 * M_PI / 180);
    /* The image's left edge (px = 0) on the middle row: alpha = -tan(fov_x/2). */
    vec3 d = cam_dir(&c, 0, m / 2.0);
    CHECK_NEAR(d.x / -d.z, -tx, 1e-12);
    d = cam_dir(&c, n, m / 2.0);
    CHECK_NEAR(d.x / -d.z, tx, 1e-12);
    d = cam_dir(&c, n / 2.0, 0); /* top edge: beta = +tan(fov_y/2) */
    CHECK_NEAR(d.y / -d.z, ty, 1e-12);
    d = cam_dir(&c, n / 2.0, m);
    CHECK_NEAR(d.y / -d.z, -ty, 1e-12);
    /* Pixel (0, 0) centre by the paper's (3), (4): */
    double alpha = tx * ((0 + 0.5) - n / 2.0) / (n / 2.0);
    double beta = ty * (m / 2.0 - (0 + 0.5)) / (m / 2.0);
    vec3 e = v3_norm(v3(alpha, beta, -1));
    d = cam_dir(&c, 0.5, 0.5);
    CHECK_NEAR(d.x, e.x, 1e-15);
    CHECK_NEAR(d.y, e.y, 1e-15);
    CHECK_NEAR(d.z, e.z, 1e-15);
}

static void test_missing_fov_follows_aspect(void) {
    struct camera c;
    CHECK(cam_init(&c, v3(0, 0, 0), v3(0, 0, -1), v3(0, 1, 0), 60, 0, 640, 480, NULL) == RAYD_OK,
          "init");
    CHECK_NEAR(c.tan_x, tan(M_PI / 6), 1e-15);
    CHECK_NEAR(c.tan_y, tan(M_PI / 6) * 480 / 640, 1e-15);
    CHECK(cam_init(&c, v3(0, 0, 0), v3(0, 0, -1), v3(0, 1, 0), 0, 45, 300, 200, NULL) == RAYD_OK,
          "init");
    CHECK_NEAR(c.tan_y, tan(M_PI / 8), 1e-15);
    CHECK_NEAR(c.tan_x, tan(M_PI / 8) * 300 / 200, 1e-15);
}

static void test_degenerate_setups_are_errors(void) {
    struct camera c;
    struct rayd_error err;
    CHECK(cam_init(&c, v3(0, 0, 0), v3(0, 5, 0), v3(0, 1, 0), 60, 0, 8, 8, &err) == RAYD_E_INVALID,
          "up parallel to w");
    CHECK(strcmp(err.path, "/camera/up") == 0, "path %s", err.path);
    CHECK(strstr(err.message, "parallel") != NULL, "message %s", err.message);
    CHECK(cam_init(&c, v3(0, 0, 0), v3(0, -5, 0), v3(0, 1, 0), 60, 0, 8, 8, &err) == RAYD_E_INVALID,
          "up anti-parallel to w");
    CHECK(cam_init(&c, v3(1, 1, 1), v3(1, 1, 1), v3(0, 1, 0), 60, 0, 8, 8, &err) == RAYD_E_INVALID,
          "look_at on the eye");
    CHECK(strcmp(err.path, "/camera/look_at") == 0, "path %s", err.path);
}

int main(void) {
    RUN(test_basis_orthonormal);
    RUN(test_centre_of_odd_image_looks_along_w);
    RUN(test_edge_directions_match_fov);
    RUN(test_missing_fov_follows_aspect);
    RUN(test_degenerate_setups_are_errors);
    CHECK_EXIT();
}
