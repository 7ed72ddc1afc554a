/* camera_frame.c -- a camera placed so that a bounding sphere fills the image.
 *
 * The scene loader gives the centre and radius of the sphere around every
 * bounded object (camera.frame = "all"); this file picks the eye.  The eye
 * lies in the direction of an azimuth about +Y (0 is +Z, 90 is +X) and an
 * elevation above the horizon.  Each named view is a pair of them (front:
 * 0, 0; side: 90, 0; top: 0, 90; three-quarter: 45, 30); "azimuth" and
 * "elevation" in the scene replace the view's.  Up is +Y, except within a
 * degree of the poles, where +Y and the view direction (nearly) coincide:
 * there up is the direction along the meridian toward the pole, the same
 * orientation as +Y gives elsewhere, so the top view (0, 90) has the
 * image's top toward -Z.  Sines and cosines of whole multiples of 90
 * degrees are exact (sin(pi / 2) in doubles is 1 but cos(pi / 2) is not
 * 0), so the named views keep their axis-aligned directions bit for bit.
 *
 * A sphere of radius r seen from distance d fills a cone of half-angle
 * asin(r / d), so it fits a field of view of half-angle a when
 * d = r / sin(a); the smaller of the two fields is used and the distance
 * is multiplied by FRAME_MARGIN so that the sphere's outline keeps a small
 * border.  Everything is a closed formula: deterministic.  Bounds so small
 * against their distance from the origin that the eye would stand on
 * their centre (a sphere of radius 1e-13 at x = 5) are refused at
 * /camera/frame, the key the scene gave.
 */
#include "geom/camera_frame.h"

#include "base/error.h"

void cam_frame_view_angles(enum frame_view view, double *azimuth, double *elevation) {
    static const double angles[][2] = {{45, 30}, {0, 0}, {90, 0}, {0, 90}};
    *azimuth = angles[view][0];
    *elevation = angles[view][1];
}

/* sin and cos of an angle in degrees, exact at whole multiples of 90. */
static void sin_cos_deg(double deg, double *s, double *c) {
    static const double quarter[4][2] = {{0, 1}, {1, 0}, {0, -1}, {-1, 0}};
    double q = deg / 90;
    if (q == floor(q) && fabs(q) < 1e6) {
        long k = ((long)q % 4 + 4) % 4;
        *s = quarter[k][0];
        *c = quarter[k][1];
        return;
    }
    *s = sin(deg * DEG2RAD);
    *c = cos(deg * DEG2RAD);
}

/* A product's zero made +0: a -0 would give a ray direction of -0 and an
 * inverse of -inf where the named views have always had +inf. */
static double plus_zero(double x) { return x == 0 ? 0 : x; }

/* The unit direction from the centre to the eye, and the view's up. */
static void view_dir(double azimuth, double elevation, vec3 *dir, vec3 *up) {
    double sa, ca, se, ce;
    sin_cos_deg(azimuth, &sa, &ca);
    sin_cos_deg(elevation, &se, &ce);
    *dir = v3(plus_zero(ce * sa), se, plus_zero(ce * ca));
    *up = v3(0, 1, 0);
    if (fabs(elevation) > 89) *up = v3(plus_zero(-se * sa), ce, plus_zero(-se * ca));
}

enum rayd_status cam_frame_sphere(struct camera *cam, vec3 centre, double radius, double azimuth,
                                  double elevation, double fov_x_deg, double fov_y_deg, int n,
                                  int m, struct rayd_error *err) {
    vec3 dir, up;
    view_dir(azimuth, elevation, &dir, &up);
    /* the fields of view, as cam_init derives them, from a provisional camera */
    enum rayd_status st =
        cam_init(cam, v3(0, 0, 0), v3(0, 0, -1), v3(0, 1, 0), fov_x_deg, fov_y_deg, n, m, err);
    if (st != RAYD_OK) return st;
    double half = atan(fmin(cam->tan_x, cam->tan_y));
    double r = radius > 0 ? radius : 1e-6 * (1.0 + v3_maxabs(centre));
    double d = r / sin(half) * FRAME_MARGIN;
    if (cam_init(cam, v3_madd(centre, dir, d), centre, up, fov_x_deg, fov_y_deg, n, m, NULL) ==
        RAYD_OK)
        return RAYD_OK;
    /* the eye is all but on the centre: the bounds are below what doubles
     * tell apart at their distance from the origin (the scene has no
     * look_at for cam_init's message to name) */
    return err_set(err, RAYD_E_INVALID, "/camera/frame",
                   "the scene's bounds (a sphere of radius %g around [%g, %g, %g]) are too small "
                   "to frame so far from the origin; scale the scene up",
                   radius, centre.x, centre.y, centre.z);
}
