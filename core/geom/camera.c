/* camera.c -- the camera basis and field of view.
 *
 * Formulas are the reference paper's: w points from the eye to look_at,
 * u = w x up is the image's right, v = u x w its up.  Rays leave the eye
 * through pixel centres (cam_dir in camera.h is inline because it runs once
 * per primary ray).  A degenerate setup -- look_at on the eye, or up parallel
 * to the view direction -- has no basis and is refused with the JSON Pointer
 * of the value to change.
 */
#include "geom/camera.h"

#include "base/cpu.h"
#include "base/error.h"
#include "math/turn.h"

enum rayd_status cam_init(struct camera *cam, vec3 pos, vec3 look_at, vec3 up, double fov_x_deg,
                          double fov_y_deg, int n, int m, struct rayd_error *err) {
    vec3 fwd = v3_sub(look_at, pos);
    double flen = v3_len(fwd);
    if (!(flen > 1e-12 * (1.0 + v3_maxabs(pos))))
        return err_set(err, RAYD_E_INVALID, "/camera/look_at", "must differ from /camera/position");
    vec3 w = v3_scale(fwd, 1.0 / flen);
    double ulen = v3_len(up);
    if (!(ulen > 0))
        return err_set(err, RAYD_E_INVALID, "/camera/up", "must not be a zero-length vector");
    vec3 side = v3_cross(w, v3_scale(up, 1.0 / ulen));
    if (!(v3_len(side) > 1e-9))
        return err_set(err, RAYD_E_INVALID, "/camera/up",
                       "must not be parallel to the view direction (look_at - position)");
    cam->pos = pos;
    cam->w = w;
    cam->u = v3_norm(side);
    cam->v = v3_cross(cam->u, w);
    cam->n = n;
    cam->m = m;
    cam->ortho = false;
    cam->aperture = 0;
    cam->focus = flen;
    if (fov_x_deg > 0 && fov_y_deg > 0) {
        cam->tan_x = tan(fov_x_deg * 0.5 * DEG2RAD);
        cam->tan_y = tan(fov_y_deg * 0.5 * DEG2RAD);
    } else if (fov_y_deg > 0) {
        cam->tan_y = tan(fov_y_deg * 0.5 * DEG2RAD);
        cam->tan_x = cam->tan_y * n / m;
    } else {
        cam->tan_x = tan((fov_x_deg > 0 ? fov_x_deg : 60.0) * 0.5 * DEG2RAD);
        cam->tan_y = cam->tan_x * m / n;
    }
    return RAYD_OK;
}

ray cam_ray(const struct camera *cam, double px, double py, double lu, double lv) {
    ray r;
    if (cam->ortho) {
        double hn = cam->n * 0.5, hm = cam->m * 0.5;
        double a = cam->tan_x * (px - hn) / hn, b = cam->tan_y * (hm - py) / hm;
        r.o = v3_madd(v3_madd(cam->pos, cam->u, a), cam->v, b);
        r.d = cam->w;
        return r;
    }
    r.o = cam->pos;
    r.d = cam_dir(cam, px, py);
    if (cam->aperture <= 0) return r;
    /* the focus plane is perpendicular to w at distance focus */
    vec3 f = v3_madd(cam->pos, r.d, cam->focus / v3_dot(r.d, cam->w));
    double rad = cam->aperture * sqrt(lu), sp, cp;
    turn_sincos(lv, &sp, &cp);
    r.o = v3_madd(v3_madd(cam->pos, cam->u, rad * cp), cam->v, rad * sp);
    r.d = v3_norm(v3_sub(f, r.o));
    return r;
}

/* Plain loops over the 16 lanes, which the vectoriser takes (camera.o is
 * built with CFLAGS_VEC), in an AVX-512 copy too where the packets run
 * with AVX-512 (both give the same bits): the 4x4 blocks' camera rays are
 * a tenth of a simple scene's time when made one at a time.  A block has
 * four columns and four rows: four alphas and four betas. */
__attribute__((always_inline)) static inline void block_rays(const struct camera *cam, int x, int y,
                                                             struct ray16 *r) {
    const struct camera c = *cam; /* a copy: the stores to r cannot change it */
    double hn = c.n * 0.5, hm = c.m * 0.5, a[16], b[16];
    for (int k = 0; k < 4; k++) {
        a[k] = c.tan_x * ((x + k) + 0.5 - hn) / hn;
        b[4 * k] = c.tan_y * (hm - ((y + k) + 0.5)) / hm;
    }
    for (int q = 4; q < 16; q++) a[q] = a[q % 4];
    for (int q = 0; q < 16; q++) b[q] = b[q & ~3];
    for (int q = 0; q < 16; q++) {
        double alpha = a[q], beta = b[q];
        double ax = c.w.x + c.u.x * alpha, ay = c.w.y + c.u.y * alpha, az = c.w.z + c.u.z * alpha;
        double bx = ax + c.v.x * beta, by = ay + c.v.y * beta, bz = az + c.v.z * beta;
        double inv = 1.0 / sqrt(bx * bx + by * by + bz * bz);
        r->d[0][q] = bx * inv, r->d[1][q] = by * inv, r->d[2][q] = bz * inv;
        r->o[0][q] = c.pos.x, r->o[1][q] = c.pos.y, r->o[2][q] = c.pos.z;
    }
}

#ifdef CPU_AVX512
CPU_AVX512_FN void block_rays_avx512(const struct camera *cam, int x, int y, struct ray16 *r) {
    block_rays(cam, x, y, r); /* inlined, so compiled and vectorised for AVX-512 */
}
#endif

void cam_block_rays(const struct camera *cam, int x, int y, struct ray16 *r) {
#ifdef CPU_AVX512
    if (cpu_avx512()) {
        block_rays_avx512(cam, x, y, r);
        return;
    }
#endif
    block_rays(cam, x, y, r);
}
