/* scene_json_frame.c -- "camera": {"frame": "all", "view": ...}.
 *
 * A framed camera is placed by the scene, not by the author: it looks at
 * the centre of a sphere around every bounded object (a sphere's own,
 * else the sphere through its box's corners; merged pairwise, in the
 * objects' order, each time into the smallest sphere holding both) from
 * the named view, whose azimuth and elevation "azimuth" and "elevation"
 * may replace one by one (a turntable is the same view at several
 * azimuths; camera_frame.c has the geometry).  The camera is read
 * before the objects, so reading only notes the request in the loader;
 * sj_frame_apply runs once the objects are loaded and sets the camera.
 * "frame" leaves the eye and its orientation to the view, so position,
 * look_at and up are refused beside it rather than silently ignored, as
 * is the orthographic projection (its view_width would need framing too).
 * A scene with nothing bounded (only planes and quadrics, or nothing) has
 * nothing to frame and is refused at /camera/frame.
 */
#include "load/scene_json_frame.h"

#include "scene/scene.h"

static enum rayd_status refuse_with_frame(struct loader *ld, const cJSON *c, const struct jp *at) {
    static const char *const fixed[] = {"position", "look_at", "up", NULL};
    for (int i = 0; fixed[i]; i++) {
        if (!cJSON_GetObjectItemCaseSensitive(c, fixed[i])) continue;
        struct jp p = jp_key(at, fixed[i]);
        return sj_fail(ld, RAYD_E_INVALID, &p,
                       "must not be given with /camera/frame (the view sets it)");
    }
    const cJSON *proj = cJSON_GetObjectItemCaseSensitive(c, "projection");
    if (cJSON_IsString(proj) && strcmp(proj->valuestring, "orthographic") == 0) {
        struct jp p = jp_key(at, "projection");
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be \"perspective\" with /camera/frame");
    }
    return RAYD_OK;
}

/* Without "frame", the keys that only mean something with it are refused. */
static enum rayd_status refuse_without_frame(struct loader *ld, const cJSON *c,
                                             const struct jp *at) {
    static const char *const framing[] = {"view", "azimuth", "elevation", NULL};
    for (int i = 0; framing[i]; i++) {
        if (!cJSON_GetObjectItemCaseSensitive(c, framing[i])) continue;
        struct jp p = jp_key(at, framing[i]);
        return sj_fail(ld, RAYD_E_INVALID, &p, "needs /camera/frame");
    }
    return RAYD_OK;
}

enum rayd_status sj_frame_read(struct loader *ld, const cJSON *c, const struct jp *at,
                               bool *framed) {
    static const char *const frames[] = {"all", NULL};
    static const char *const views[] = {"three-quarter", "front", "side", "top", NULL};
    int frame, view;
    *framed = false;
    TRY(sj_enum(ld, c, at, "frame", frames, &frame));
    TRY(sj_enum(ld, c, at, "view", views, &view));
    if (frame < 0) return refuse_without_frame(ld, c, at);
    TRY(refuse_with_frame(ld, c, at));
    double az, el;
    cam_frame_view_angles(view < 0 ? VIEW_THREE_QUARTER : (enum frame_view)view, &az, &el);
    TRY(sj_num(ld, c, at, "azimuth", az, -360, false, 360, &ld->frame_azimuth));
    TRY(sj_num(ld, c, at, "elevation", el, -90, false, 90, &ld->frame_elevation));
    *framed = true;
    ld->frame = true;
    ld->frame_focus = cJSON_GetObjectItemCaseSensitive(c, "focus_distance") != NULL;
    return RAYD_OK;
}

/* A sphere around one bounded object: a sphere's own (when it is not
 * transformed), else the sphere through the corners of its box. */
static void object_sphere(const struct object *o, const struct aabb *b, vec3 *c, double *r) {
    if (o->kind == SHAPE_SPHERE && o->xform < 0) {
        *c = o->u.sphere.center;
        *r = o->u.sphere.radius;
        return;
    }
    *c = v3_scale(v3_add(b->lo, b->hi), 0.5);
    *r = 0.5 * v3_len(v3_sub(b->hi, b->lo));
}

/* The smallest sphere holding spheres (c, r) and (c2, r2), into (c, r). */
static void sphere_union(vec3 *c, double *r, vec3 c2, double r2) {
    vec3 d = v3_sub(c2, *c);
    double dist = v3_len(d);
    if (dist + r2 <= *r) return; /* the second is inside the first */
    if (dist + *r <= r2) {       /* the first is inside the second */
        *c = c2;
        *r = r2;
        return;
    }
    double nr = 0.5 * (dist + *r + r2);
    *c = v3_madd(*c, d, (nr - *r) / dist);
    *r = nr;
}

/* A sphere around every bounded object, in the objects' order (so the
 * same scene gives the same sphere); false when there is none. */
static bool all_sphere(const rayd_scene *s, vec3 *c, double *r) {
    bool any = false;
    struct aabb b;
    for (int32_t i = 0; i < s->nobjs; i++) {
        const struct object *o = &s->objs[i];
        if (!scene_object_bounds(s, o, &b)) continue;
        vec3 oc;
        double orad;
        object_sphere(o, &b, &oc, &orad);
        if (any)
            sphere_union(c, r, oc, orad);
        else
            *c = oc, *r = orad;
        any = true;
    }
    return any;
}

enum rayd_status sj_frame_apply(struct loader *ld) {
    if (!ld->frame) return RAYD_OK;
    vec3 centre = v3(0, 0, 0);
    double radius = 0;
    struct jp at = {.s = "/camera/frame"};
    if (!all_sphere(ld->s, &centre, &radius))
        return sj_fail(
            ld, RAYD_E_INVALID, &at,
            "the scene has no bounded object to frame (planes and quadrics have no bounds)");
    struct camera *cam = &ld->s->cam;
    const struct render_settings *rs = &ld->s->rs;
    double aperture = cam->aperture, focus = cam->focus;
    TRY(cam_frame_sphere(cam, centre, radius, ld->frame_azimuth, ld->frame_elevation, ld->frame_fx,
                         ld->frame_fy, rs->width, rs->height, ld->err));
    cam->aperture = aperture;
    if (ld->frame_focus) cam->focus = focus;
    return RAYD_OK;
}
