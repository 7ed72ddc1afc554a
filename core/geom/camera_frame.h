/* camera_frame.h -- automatic framing: a camera that shows a whole sphere. */
#ifndef CAMERA_FRAME_H
#define CAMERA_FRAME_H

#include "geom/camera.h"

/* The views of "camera": {"frame": "all", "view": ...}, in the order of
 * their names in the scene format. */
enum frame_view { VIEW_THREE_QUARTER, VIEW_FRONT, VIEW_SIDE, VIEW_TOP };

/* The margin by which the framed sphere is kept inside the image. */
#define FRAME_MARGIN 1.1

/* Sets *cam to look at centre from direction view, at the distance where
 * a sphere of the given radius fits the smaller field of view with
 * FRAME_MARGIN: d = radius / sin(half the smaller fov) * FRAME_MARGIN.
 * fov_x_deg / fov_y_deg as in cam_init (0 = follow the aspect ratio). */
enum rayd_status cam_frame_sphere(struct camera *cam, vec3 centre, double radius,
                                  enum frame_view view, double fov_x_deg, double fov_y_deg, int n,
                                  int m, struct rayd_error *err);

#endif
