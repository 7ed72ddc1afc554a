/* test_anim.c -- keyframes: the curves (core/math/keyframe.c) and scenes
 * loaded at a frame (core/load/scene_json_anim.c, rayd_scene_parse_frame). */
#include <string.h>

#include "check.h"
#include "math/keyframe.h"
#include "scene/scene.h"
#include "scene_util.h"

static const double T[4] = {0, 4, 10, 12};
static const double V3[12] = {0, 0, 0, 4, -2, 1, 4, 8, -3, -1, 0, 2.5};

/* At every key the value is the key's, bit for bit, for every curve. */
static void test_exact_at_keys(void) {
    for (int how = KF_STEP; how <= KF_SMOOTH; how++)
        for (int i = 0; i < 4; i++) {
            double out[3];
            kf_eval(T, V3, 4, 3, (enum kf_interp)how, T[i], out);
            CHECK(!memcmp(out, V3 + 3 * i, sizeof out), "how %d key %d", how, i);
        }
    double out[3];
    kf_eval(T, V3, 4, 3, KF_SMOOTH, -5, out); /* before the first: the first */
    CHECK(!memcmp(out, V3, sizeof out), "before");
    kf_eval(T, V3, 4, 3, KF_LINEAR, 99, out); /* after the last: the last */
    CHECK(!memcmp(out, V3 + 9, sizeof out), "after");
}

static void test_linear_and_step_between(void) {
    double out[3];
    kf_eval(T, V3, 4, 3, KF_LINEAR, 2, out); /* halfway from key 0 to key 1 */
    CHECK_NEAR(out[0], 2, 1e-15);
    CHECK_NEAR(out[1], -1, 1e-15);
    CHECK_NEAR(out[2], 0.5, 1e-15);
    kf_eval(T, V3, 4, 3, KF_STEP, 9.99, out);
    CHECK(!memcmp(out, V3 + 3, sizeof out), "step holds key 1");
}

/* The smooth curve is continuous, with a continuous slope, across keys. */
static void test_smooth_continuity(void) {
    const double e = 1e-6;
    for (int i = 1; i < 3; i++)
        for (int c = 0; c < 3; c++) {
            double lo[3], hi[3], lo2[3], hi2[3], at[3];
            kf_eval(T, V3, 4, 3, KF_SMOOTH, T[i] - e, lo);
            kf_eval(T, V3, 4, 3, KF_SMOOTH, T[i] + e, hi);
            kf_eval(T, V3, 4, 3, KF_SMOOTH, T[i] - 2 * e, lo2);
            kf_eval(T, V3, 4, 3, KF_SMOOTH, T[i] + 2 * e, hi2);
            kf_eval(T, V3, 4, 3, KF_SMOOTH, T[i], at);
            CHECK_NEAR(lo[c], at[c], 1e-4);
            CHECK_NEAR(hi[c], at[c], 1e-4);
            double left = (lo[c] - lo2[c]) / e, right = (hi2[c] - hi[c]) / e;
            CHECK_NEAR(left, right, 1e-3);
        }
    /* Catmull-Rom: the slope at key 1 is the slope from key 0 to key 2 */
    double a[3], b[3];
    kf_eval(T, V3, 4, 3, KF_SMOOTH, T[1] - 1e-6, a);
    kf_eval(T, V3, 4, 3, KF_SMOOTH, T[1] + 1e-6, b);
    CHECK_NEAR((b[1] - a[1]) / 2e-6, (V3[7] - V3[1]) / (T[2] - T[0]), 1e-4);
}

static double qlen(const double *q) {
    return sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
}

static void test_slerp(void) {
    double a[4], b[4], q[4];
    kf_quat_axis(v3(0, 1, 0), 0, a);
    kf_quat_axis(v3(0, 1, 0), 90, b);
    for (int i = 0; i <= 16; i++) {
        kf_slerp(a, b, i / 16.0, q);
        CHECK_NEAR(qlen(q), 1, 1e-12);
        /* a steady turn: the angle is u x 90 degrees */
        CHECK_NEAR(2 * acos(fmin(1, q[3])) * 180 / M_PI, 90.0 * i / 16, 1e-9);
    }
    kf_slerp(a, b, 0, q);
    CHECK(!memcmp(q, a, sizeof q), "u = 0 is a");
    kf_slerp(a, b, 1, q);
    CHECK(!memcmp(q, b, sizeof q), "u = 1 is b");
    /* the short way: -b is the same rotation */
    double nb[4] = {-b[0], -b[1], -b[2], -b[3]};
    kf_slerp(a, nb, 0.5, q);
    CHECK_NEAR(2 * acos(fabs(q[3])) * 180 / M_PI, 45, 1e-9);
}

static void test_quat_curves(void) {
    double t[3] = {0, 5, 10}, q[12], out[4];
    kf_quat_euler(v3(0, 0, 0), q);
    kf_quat_euler(v3(0, 120, 0), q + 4);
    kf_quat_euler(v3(30, 240, 10), q + 8);
    for (int how = KF_STEP; how <= KF_SMOOTH; how++) {
        for (int i = 0; i < 3; i++) {
            kf_eval_quat(t, q, 3, (enum kf_interp)how, t[i], out);
            CHECK(!memcmp(out, q + 4 * i, sizeof out), "how %d key %d", how, i);
        }
        for (double f = 0; f <= 10; f += 0.25) {
            kf_eval_quat(t, q, 3, (enum kf_interp)how, f, out);
            CHECK_NEAR(qlen(out), 1, 1e-12);
        }
    }
    /* the quaternion of an Euler rotation is the same rotation */
    vec3 e = v3(20, -35, 70);
    kf_quat_euler(e, out);
    struct xform a = kf_quat_xform(out), b = xform_rotate_euler(e);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) CHECK_NEAR(a.m[i][j], b.m[i][j], 1e-12);
}

/* ---- scenes at a frame ---------------------------------------------------- */

static rayd_scene *at_frame(const char *json, long frame, struct rayd_error *err) {
    rayd_scene *s = NULL;
    memset(err, 0, sizeof *err);
    if (rayd_scene_parse_frame(json, strlen(json), NULL, frame, &s, err) != RAYD_OK) return NULL;
    return s;
}

static const char *ANIM =
    "{\"animation\": {\"start\": 2, \"end\": 12, \"fps\": 25},"
    " \"render\": {\"width\": 40, \"height\": 30},"
    " \"camera\": {\"look_at\": [0, 0.5, 0], \"keyframes\": ["
    "   {\"frame\": 2, \"position\": [0, 1, 5]}, {\"frame\": 12, \"position\": [10, 1, 5], "
    "\"fov_x\": 50}]},"
    " \"lights\": [{\"type\": \"point\", \"interpolation\": \"step\", \"keyframes\": ["
    "   {\"frame\": 2, \"position\": [5, 5, 5]}, {\"frame\": 7, \"position\": [-5, 5, 5], "
    "\"intensity\": 0.5}]}],"
    " \"objects\": [{\"type\": \"plane\"},"
    "   {\"type\": \"sphere\", \"radius\": 0.5, \"transform\": {\"scale\": 2},"
    "    \"keyframes\": [{\"frame\": 2, \"translate\": [0, 0, 0]}, {\"frame\": 12, \"translate\": "
    "[0, 2, 0]}]}]}";

/* The same scene, still, as frame 7 should be. */
static const char *STILL7 =
    "{\"render\": {\"width\": 40, \"height\": 30},"
    " \"camera\": {\"look_at\": [0, 0.5, 0], \"position\": [5, 1, 5], \"fov_x\": 50},"
    " \"lights\": [{\"type\": \"point\", \"position\": [-5, 5, 5], \"intensity\": 0.5}],"
    " \"objects\": [{\"type\": \"plane\"},"
    "   {\"type\": \"sphere\", \"radius\": 0.5, \"transform\": [{\"scale\": 2}, {\"translate\": "
    "[0, 1, 0]}]}]}";

static void test_scene_frames(void) {
    struct rayd_error err;
    rayd_scene *s = at_frame(ANIM, 7, &err);
    CHECK(s != NULL, "frame 7: %s %s", err.path, err.message);
    if (!s) return;
    struct rayd_animation an;
    rayd_scene_animation(s, &an);
    CHECK(an.animated == 1 && an.start == 2 && an.end == 12 && an.fps == 25 && an.frame == 7,
          "animation %d %ld %ld %g %ld", an.animated, an.start, an.end, an.fps, an.frame);
    CHECK_NEAR(s->cam.pos.x, 5, 1e-15);
    CHECK(s->lights[0].position.x == -5 && s->lights[0].intensity == 0.5, "step light");
    rayd_scene *still = scene_from(STILL7);
    rayd_image *a = render_all(s, 2), *b = still ? render_all(still, 1) : NULL;
    CHECK(a && b && !memcmp(rayd_image_pixels(a), rayd_image_pixels(b), 40 * 30 * 3),
          "frame 7 is the still scene, byte for byte");
    rayd_image_free(a);
    rayd_image_free(b);
    rayd_scene_free(still);
    rayd_scene_free(s);

    /* rayd_scene_parse is the first frame */
    s = scene_from(ANIM);
    if (s) {
        rayd_scene_animation(s, &an);
        CHECK(an.frame == 2 && s->cam.pos.x == 0, "first frame %ld", an.frame);
    }
    rayd_scene_free(s);
    /* frames outside the range; a still scene's one frame */
    CHECK(!at_frame(ANIM, 13, &err) && err.code == RAYD_E_ARG && !strcmp(err.path, "/animation"),
          "13: %d %s", err.code, err.path);
    CHECK(!at_frame(ANIM, 1, &err) && err.code == RAYD_E_ARG, "1");
    CHECK(!at_frame(STILL7, 1, &err) && err.code == RAYD_E_ARG, "still 1");
    s = at_frame(STILL7, 0, &err);
    CHECK(s != NULL, "still 0");
    if (s) {
        rayd_scene_animation(s, &an);
        CHECK(an.animated == 0 && an.start == 0 && an.end == 0 && an.frame == 0, "still");
    }
    rayd_scene_free(s);
}

/* A frame is the same bytes whatever the threads or the tiles. */
static void test_frame_determinism(void) {
    struct rayd_error err;
    rayd_scene *s1 = at_frame(ANIM, 9, &err), *s2 = at_frame(ANIM, 9, &err);
    CHECK(s1 && s2, "parse");
    if (!s1 || !s2) return;
    rayd_image *a = render_all(s1, 1);
    struct rayd_render_opts o = {.threads = 3, .tile = 7};
    rayd_image *b = NULL;
    CHECK(rayd_render(s2, &o, &b, NULL) == RAYD_OK, "render");
    CHECK(a && b && !memcmp(rayd_image_pixels(a), rayd_image_pixels(b), 40 * 30 * 3), "same");
    rayd_image_free(a);
    rayd_image_free(b);
    rayd_scene_free(s1);
    rayd_scene_free(s2);
}

/* A value that only the curve between keys makes wrong is named by the
 * keyframes, with the frame. */
static void test_interpolated_error(void) {
    const char *j = "{\"animation\": {\"end\": 20},"
                    " \"camera\": {\"interpolation\": \"smooth\", \"keyframes\": ["
                    "   {\"frame\": 0, \"fov_x\": 170}, {\"frame\": 10, \"fov_x\": 179}, "
                    "{\"frame\": 20, \"fov_x\": 20}]}}";
    struct rayd_error err;
    rayd_scene *s = at_frame(j, 0, &err);
    CHECK(s != NULL, "frame 0 is fine");
    rayd_scene_free(s);
    s = at_frame(j, 7, &err); /* the curve overshoots 179 before frame 10 */
    CHECK(!s && !strcmp(err.path, "/camera/keyframes") && strstr(err.message, "at frame 7, fov_x"),
          "%s: %s", err.path, err.message);
    rayd_scene_free(s);
}

/* rayd_scene_check_frames finds the first frame whose values fail, with
 * the error its parse gives, at every frame of a range and nowhere else:
 * the camera's, a light's, an object's keyframed scale, and a look_at the
 * keyframed position passes through (a check between two keys' values). */
static void test_check_frames(void) {
    const char *fov = "{\"animation\": {\"end\": 20},"
                      " \"camera\": {\"interpolation\": \"smooth\", \"keyframes\": ["
                      "   {\"frame\": 0, \"fov_x\": 170}, {\"frame\": 10, \"fov_x\": 179}, "
                      "{\"frame\": 20, \"fov_x\": 20}]}}";
    struct rayd_error err;
    char first_bad[sizeof err.message] = "";
    for (long k = 0; k <= 20; k++) { /* each frame alone: as its own parse says */
        rayd_scene *s = at_frame(fov, k, &err);
        char parse[sizeof err.message];
        snprintf(parse, sizeof parse, "%s", s ? "" : err.message);
        if (!s && !first_bad[0]) snprintf(first_bad, sizeof first_bad, "%s", parse);
        rayd_scene_free(s);
        memset(&err, 0, sizeof err);
        enum rayd_status st = rayd_scene_check_frames(fov, strlen(fov), NULL, k, k, &err);
        CHECK((st == RAYD_OK) == (parse[0] == 0) && !strcmp(st ? err.message : "", parse),
              "frame %ld: check %s, parse %s", k, st ? err.message : "ok", parse);
    }
    enum rayd_status st = rayd_scene_check_frames(fov, strlen(fov), NULL, 0, 20, &err);
    CHECK(st == RAYD_E_INVALID && !strcmp(err.path, "/camera/keyframes") && first_bad[0] &&
              !strcmp(err.message, first_bad),
          "%s: %s, the first frame's parse: %s", err.path, err.message, first_bad);
    CHECK(rayd_scene_check_frames(fov, strlen(fov), NULL, 12, 40, &err) == RAYD_OK,
          "frames 12-20 pass: %s", err.message);
    const char *scale = "{\"animation\": {\"end\": 4}, \"objects\": [{\"type\": \"sphere\", "
                        "\"keyframes\": [{\"frame\": 0, \"scale\": 1}, {\"frame\": 4, "
                        "\"scale\": -1}]}]}";
    st = rayd_scene_check_frames(scale, strlen(scale), NULL, 0, 4, &err);
    CHECK(st == RAYD_E_INVALID && !strcmp(err.path, "/objects/0/keyframes") &&
              strstr(err.message, "at frame 2"),
          "%s: %s", err.path, err.message);
    const char *light = "{\"animation\": {\"end\": 4}, \"lights\": [{\"type\": \"spot\", "
                        "\"keyframes\": [{\"frame\": 0, \"direction\": [0, -1, 0]}, "
                        "{\"frame\": 4, \"direction\": [0, 1, 0]}]}]}";
    st = rayd_scene_check_frames(light, strlen(light), NULL, 0, 4, &err);
    CHECK(st == RAYD_E_INVALID && !strcmp(err.path, "/lights/0/keyframes") &&
              strstr(err.message, "at frame 2, direction"),
          "%s: %s", err.path, err.message);
    /* the keyframed position meets the still look_at: named by the keyframes too (before:
     * "/camera/look_at: must differ from /camera/position", no frame) */
    const char *meet = "{\"animation\": {\"end\": 4}, \"camera\": {\"look_at\": [0, 0, 0], "
                       "\"keyframes\": [{\"frame\": 0, \"position\": [0, 0, -1]}, "
                       "{\"frame\": 2, \"position\": [0, 0, 1]}]}}";
    st = rayd_scene_check_frames(meet, strlen(meet), NULL, 0, 4, &err);
    CHECK(st == RAYD_E_INVALID && !strcmp(err.path, "/camera/keyframes") &&
              strstr(err.message, "at frame 1, look_at: must differ from /camera/position"),
          "%s: %s", err.path, err.message);
    rayd_scene *s = at_frame(meet, 1, &err);
    CHECK(!s && !strcmp(err.path, "/camera/keyframes") &&
              strstr(err.message, "at frame 1, look_at"),
          "frame 1's parse: %s: %s", err.path, err.message);
    rayd_scene_free(s);
    /* a still value's own error in an owner with keyframes keeps its own pointer */
    const char *own = "{\"animation\": {\"end\": 4}, \"lights\": [{\"type\": \"point\", "
                      "\"intensity\": -1, \"keyframes\": [{\"frame\": 0, \"position\": [0, 1, 0]}, "
                      "{\"frame\": 4, \"position\": [1, 1, 0]}]}]}";
    s = at_frame(own, 0, &err);
    CHECK(!s && !strcmp(err.path, "/lights/0/intensity") && !strstr(err.message, "at frame"),
          "%s: %s", err.path, err.message);
    rayd_scene_free(s);
    const char *still = "{\"objects\": [{\"type\": \"sphere\"}]}";
    CHECK(rayd_scene_check_frames(still, strlen(still), NULL, 0, 1000, &err) == RAYD_OK,
          "a still scene: %s", err.message);
    atomic_int stop = 1;
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.cancel = &stop;
    CHECK(rayd_scene_check_frames(fov, strlen(fov), &lim, 0, 20, &err) == RAYD_E_CANCELED,
          "the flag stops it: %s", err.message);
}

/* Keyframed rotation turns the object: a quarter turn at the last key is
 * the still scene's rotate. */
static void test_object_rotation(void) {
    const char *j = "{\"animation\": {\"end\": 4}, \"render\": {\"width\": 32, \"height\": 24},"
                    " \"camera\": {\"position\": [3, 3, 3], \"look_at\": [0, 0, 0]},"
                    " \"lights\": [{\"type\": \"point\", \"position\": [2, 5, 1]}],"
                    " \"objects\": [{\"type\": \"box\", \"max\": [1, 0.5, 0.2], \"keyframes\": ["
                    "   {\"frame\": 0, \"rotate\": [0, 0, 0]}, {\"frame\": 4, \"rotate\": "
                    "{\"axis\": [0, 1, 0], \"angle\": 90}}]}]}";
    const char *mid = "{\"render\": {\"width\": 32, \"height\": 24},"
                      " \"camera\": {\"position\": [3, 3, 3], \"look_at\": [0, 0, 0]},"
                      " \"lights\": [{\"type\": \"point\", \"position\": [2, 5, 1]}],"
                      " \"objects\": [{\"type\": \"box\", \"max\": [1, 0.5, 0.2], \"transform\": "
                      "{\"rotate\": [0, 45, 0]}}]}";
    struct rayd_error err;
    rayd_scene *s = at_frame(j, 2, &err), *m = scene_from(mid);
    CHECK(s && m, "parse: %s %s", err.path, err.message);
    if (s && m) {
        rayd_image *a = render_all(s, 1), *b = render_all(m, 1);
        /* slerp's halfway is 45 degrees: the same image up to rounding */
        int diff = 0;
        for (int i = 0; a && b && i < 32 * 24 * 3; i++)
            diff += abs(rayd_image_pixels(a)[i] - rayd_image_pixels(b)[i]) > 1;
        CHECK(a && b && diff == 0, "%d bytes differ", diff);
        rayd_image_free(a);
        rayd_image_free(b);
    }
    rayd_scene_free(s);
    rayd_scene_free(m);
}

int main(void) {
    RUN(test_exact_at_keys);
    RUN(test_linear_and_step_between);
    RUN(test_smooth_continuity);
    RUN(test_slerp);
    RUN(test_quat_curves);
    RUN(test_scene_frames);
    RUN(test_frame_determinism);
    RUN(test_interpolated_error);
    RUN(test_check_frames);
    RUN(test_object_rotation);
    CHECK_EXIT();
}
