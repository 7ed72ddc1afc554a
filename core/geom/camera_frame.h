/* camera_frame.h -- automatic framing: a camera that shows a whole sphere. */
#ifndef CAMERA_FRAME_H
#define CAMERA_FRAME_H

#include "geom/camera.h"

/* The views of "camera": {"frame": "all", "view": ...}, in the order of
 * their names in the scene format. */
enum frame_view { VIEW_THREE_QUARTER, VIEW_FRONT, VIEW_SIDE, VIEW_TOP };

/* The margin by which the framed sphere is kept inside the image. */
#define FRAME_MARGIN 1.1

/* A named view's angles in degrees: the azimuth about +Y (0 is +Z, 90 is
 * +X) and the elevation above the horizon (90 looks straight down). */
void cam_frame_view_angles(enum frame_view view, double *azimuth, double *elevation);

/* Sets *cam to look at centre from the direction at the given azimuth and
 * elevation (degrees, as cam_frame_view_angles gives them), at the
 * distance where a sphere of the given radius fits the smaller field of
 * view with FRAME_MARGIN: d = radius / sin(half the smaller fov) *
 * FRAME_MARGIN.  fov_x_deg / fov_y_deg as in cam_init (0 = follow the
 * aspect ratio). */
enum rayd_status cam_frame_sphere(struct camera *cam, vec3 centre, double radius, double azimuth,
                                  double elevation, double fov_x_deg, double fov_y_deg, int n,
                                  int m, struct rayd_error *err);

#endif
