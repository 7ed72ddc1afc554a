/* camera_frame.c -- a camera placed so that a bounding sphere fills the image.
 *
 * The scene loader gives the centre and radius of the sphere around every
 * bounded object (camera.frame = "all"); this file picks the eye.  The eye
 * lies on a fixed direction from the centre, one per view (front: +Z,
 * side: +X, top: +Y, three-quarter: azimuth 45 degrees from +Z toward +X
 * and 30 degrees up), with up = +Y (top: -Z, so the image's top is the
 * scene's back).  A sphere of radius r seen from distance d fills a cone
 * of half-angle asin(r / d), so it fits a field of view of half-angle a
 * when d = r / sin(a); the smaller of the two fields is used and the
 * distance is multiplied by FRAME_MARGIN so that the sphere's outline
 * keeps a small border.  Everything is a closed formula: deterministic.
 */
#include "geom/camera_frame.h"

#include "base/error.h"

/* The unit direction from the centre to the eye, and the view's up. */
static void view_dir(enum frame_view view, vec3 *dir, vec3 *up) {
    double el = 30 * DEG2RAD, az = 45 * DEG2RAD;
    *up = v3(0, 1, 0);
    switch (view) {
    case VIEW_FRONT: *dir = v3(0, 0, 1); break;
    case VIEW_SIDE: *dir = v3(1, 0, 0); break;
    case VIEW_TOP:
        *dir = v3(0, 1, 0);
        *up = v3(0, 0, -1);
        break;
    default: *dir = v3(cos(el) * sin(az), sin(el), cos(el) * cos(az)); break;
    }
}

enum rayd_status cam_frame_sphere(struct camera *cam, vec3 centre, double radius,
                                  enum frame_view view, double fov_x_deg, double fov_y_deg, int n,
                                  int m, struct rayd_error *err) {
    vec3 dir, up;
    view_dir(view, &dir, &up);
    /* the fields of view, as cam_init derives them, from a provisional camera */
    enum rayd_status st = cam_init(cam, v3(0, 0, 0), v3(0, 0, -1), v3(0, 1, 0), fov_x_deg, fov_y_deg,
                                   n, m, err);
    if (st != RAYD_OK) return st;
    double half = atan(fmin(cam->tan_x, cam->tan_y));
    double r = radius > 0 ? radius : 1e-6 * (1.0 + v3_maxabs(centre));
    double d = r / sin(half) * FRAME_MARGIN;
    return cam_init(cam, v3_madd(centre, dir, d), centre, up, fov_x_deg, fov_y_deg, n, m, err);
}
