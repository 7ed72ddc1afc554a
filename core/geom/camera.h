/* camera.h -- the paper's pinhole camera, formulas (1)-(5). */
#ifndef CAMERA_H
#define CAMERA_H

#include <stdbool.h>

#include "rayd/rayd.h"
#include "math/vec.h"

struct camera {
    vec3 pos;        /* the eye C */
    vec3 u, v, w;    /* right, up, forward: an orthonormal basis */
    double tan_x;    /* tan(fov_x / 2) */
    double tan_y;    /* tan(fov_y / 2) */
    int n, m;        /* image width and height in pixels */
    bool ortho;      /* orthographic: parallel rays, tan_x/tan_y hold half the view size */
    double aperture; /* thin lens radius; 0 is the paper's pinhole */
    double focus;    /* distance along w that is sharp */
};

/* Builds the basis w = normalize(look_at - pos), u = normalize(w x up),
 * v = u x w.  fov_x_deg / fov_y_deg are degrees; pass 0 for one of them to
 * derive it from the aspect ratio: tan(fov_y/2) = tan(fov_x/2) * m / n.
 * Errors name /camera/look_at or /camera/up. */
enum rayd_status cam_init(struct camera *cam, vec3 pos, vec3 look_at, vec3 up, double fov_x_deg,
                          double fov_y_deg, int n, int m, struct rayd_error *err);

/* The unit direction through image point (px, py), in pixels from the
 * top-left corner: the centre of pixel (i, j) is (i + 0.5, j + 0.5).
 * alpha = tan_x * (px - n/2) / (n/2); beta = tan_y * (m/2 - py) / (m/2);
 * d = normalize(w + alpha u + beta v). */
static inline vec3 cam_dir(const struct camera *cam, double px, double py) {
    double hn = cam->n * 0.5, hm = cam->m * 0.5;
    double alpha = cam->tan_x * (px - hn) / hn;
    double beta = cam->tan_y * (hm - py) / hm;
    vec3 d = v3_madd(v3_madd(cam->w, cam->u, alpha), cam->v, beta);
    return v3_norm(d);
}

/* The pinhole camera's rays through the centres of the 4x4 pixels whose
 * top-left one is (x, y), 16 at once: ray q for pixel (x + q % 4,
 * y + q / 4), from the eye along cam_dir, the same bits. */
void cam_block_rays(const struct camera *cam, int x, int y, struct ray16 *r);

/* The primary ray through image point (px, py), with lens sample (lu, lv)
 * in [0, 1)^2 used only when the aperture is open.  Pinhole: the paper's
 * ray from the eye.  Orthographic: parallel rays along w from the image
 * plane.  Thin lens: from a point on the lens disc through the point of
 * the pinhole ray at the focus distance. */
ray cam_ray(const struct camera *cam, double px, double py, double lu, double lv);

#endif
