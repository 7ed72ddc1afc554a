/* scene.h -- the frozen scene (internal view of rayd_scene). */
#ifndef SCENE_H
#define SCENE_H

#include <stdint.h>

#include "accel/bvh.h"
#include "geom/camera.h"
#include "shade/environment.h"
#include "shade/light.h"
#include "shade/material.h"
#include "geom/mesh.h"
#include "geom/shape.h"
#include "math/xform.h"

enum integrator { INTEGRATOR_WHITTED, INTEGRATOR_PATH };

struct render_settings {
    enum integrator integrator;
    int width, height;
    int samples;   /* rays per pixel */
    int max_depth; /* secondary bounces allowed */
    vec3 background;
    struct environment env; /* render.environment; kind ENV_NONE without one */
    uint64_t seed;
    unsigned aov; /* render.aov: the RAYD_AOV_ bits the scene asks for */
    bool denoise; /* render.denoise */
    /* render.clamp_indirect (the largest luminance of an indirect
     * contribution) and render.filter_glossy (the least roughness of a
     * glossy lobe after a non-delta bounce): biased, 0 = off
     * (integrate_path.c). */
    double clamp_indirect, filter_glossy;
    /* Tests only (no scene key): the path tracer without next-event
     * estimation, every light by the sampled paths alone -- the plain
     * estimator the NEE one must agree with (tests/unit/test_path_bias.c). */
    bool no_nee;
};

/* Objects drawn together and placed as a whole by instances. */
struct group {
    struct object *objs; /* in BVH order */
    int32_t nobjs;
    struct bvh4 bvh;
    struct aabb bounds;
};

struct texture;
struct scene_file;

struct rayd_scene {
    double decode_s, build_s;   /* loading: mesh files decoded, BVHs and light buffers built */
    double frame_work;          /* rayd_scene_info's: what each frame's parse redoes */
    long images_decoded;        /* loading: glTF images decoded (one per image, however shared) */
    struct rayd_animation anim; /* the frames of the scene and the one this is */
    struct camera cam;
    struct render_settings rs;
    struct material *mats;
    int nmats;
    struct light *lights;
    int nlights;
    struct object *objs; /* bounded objects, in top-level BVH order */
    int32_t nobjs;
    struct object *planes; /* unbounded objects (planes, quadrics), tested one by one */
    int32_t nplanes;
    struct object *planes_src; /* planes[i] as loaded, with its transform: the object
                                  space of the textures of a plane whose placement is baked */
    struct object *parts;      /* CSG operands: referred to by CSG nodes, not in any BVH */
    int32_t nparts;
    struct group *groups; /* referred to by instances */
    int32_t ngroups;
    struct texture *textures;
    int ntextures;
    struct mesh *meshes; /* geometry that objects refer to */
    uint32_t nmeshes;
    struct xform *xforms; /* placements that objects refer to */
    int32_t nxforms;
    int32_t *inst_ids; /* per placement: the id of the instance it places, else -1 */
    struct bvh4 tlas;  /* over objs */
    /* A scene of at most SCENE_FLAT_MAX objs: their boxes, four to a node
     * in objs' order (scene.c), which a one-ray query tests all at once
     * instead of walking tlas (scene_query.c); NULL for more. */
    struct bvh4_node *flat;
    uint32_t nflat;
    struct light_buffer *light_buffers; /* per light, objs by direction (light_buffer.c) */
    int32_t *emitters; /* path tracer: emissive spheres, discs, quads of objs to sample */
    int nemitters;
    /* Per objs: which a ray leaving it cannot meet again (scene_leave.c). */
    struct scene_leave *leave;
    bool opaque;              /* no material lets light through: shadows are 0 or 1 */
    bool simple_lights;       /* only point and directional lights (integrate_wide.c) */
    bool brute;               /* tests only: every query tests every primitive */
    double ray_tests;         /* scene_cost.c: a ray's primitive tests where the BVHs are worst */
    struct scene_file *files; /* the files read, as they were (scene_files.c) */
    int nfiles;
    size_t files_cap;
};

#define SCENE_FLAT_MAX 16

/* A CSG tree's point-in-solid tests (one an operand, at every run of
 * crossings) that cost about what one ray does: the unit in which the
 * query counts them on the render's meter (meter_work) and the estimate
 * prices them (scene_cost.c). */
#define SCENE_CSG_TESTS_A_RAY 16

/* A ray leaving objs[i] from integrate_offset off a point p cannot meet
 * it again (scene_leave.c) when scale <= 1e4 (1 + p's largest
 * coordinate): from either side when flat, else (a convex solid) when it
 * leaves outward.  scale is infinite for objects it may meet again. */
struct scene_leave {
    double scale;
    bool flat;
};

/* Fills s->leave (scene_freeze, once objs has its order). */
enum rayd_status scene_leave_freeze(rayd_scene *s, struct rayd_error *err);

struct hit {
    double t;
    const struct object *leaf; /* the primitive hit (for CSG, the operand) */
    const struct xform *outer; /* the instance's placement, or NULL */
    int part;                  /* which part of the primitive */
    int orient;                /* CSG: +1 the ray enters the result, -1 leaves it */
    struct mesh_hit mh;        /* set for meshes */
};

/* What the shader needs to know about a hit. */
struct surface {
    vec3 p;     /* world-space point */
    vec3 color; /* the material's colour, or its texture's at p */
    vec3 n;     /* unit shading normal, outward */
    vec3 ng;    /* unit geometric normal, outward */
    const struct material *m;
    bool thin;       /* no inside: what passes through goes straight on */
    bool float_geom; /* float geometry: larger offsets for secondary rays */
};

/* A scene under construction: objects are appended, then scene_freeze
 * splits bounded from unbounded objects and builds the top-level BVH.  The
 * scene owns all its arrays. */
enum rayd_status scene_alloc(rayd_scene **out, struct rayd_error *err);
enum rayd_status scene_freeze(rayd_scene *s, struct rayd_error *err);

/* World bounds of object o; false when it is unbounded. */
bool scene_object_bounds(const rayd_scene *s, const struct object *o, struct aabb *out);

/* Builds a BVH over objs[0..n) (reordering them); bounds gets their union. */
enum rayd_status scene_build_bvh(const rayd_scene *s, struct object **objs, int32_t n,
                                 struct bvh4 *bvh, struct aabb *bounds, struct rayd_error *err);

/* ---- the queries: one ray (scene_query.c), 16 rays (scene_packet.c) ---- */

/* Nearest hit with t in (0, tmax); false when the ray escapes. */
bool scene_intersect(const rayd_scene *s, const ray *r, double tmax, struct hit *h);

/* Fraction of light that passes from the ray's origin to distance tmax:
 * 0 behind an opaque object, (transparency * color) per transparent one. */
vec3 scene_transmittance(const rayd_scene *s, const ray *r, double tmax);
/* scene_intersect and scene_transmittance passing over objs[leave] (none:
 * SCENE_NO_LEAVE), for rays that leave that object and cannot meet it
 * again (the path tracer's, scene_leave.c): the same answers, without its
 * test.  And scene_occluded_from: whether any surface closer than tmax
 * blocks r, transparent or not -- the path tracer's shadow test (light
 * through glass comes by the sampled path alone, or it would be counted
 * twice). */
#define SCENE_NO_LEAVE UINT32_MAX
bool scene_intersect_from(const rayd_scene *s, const ray *r, double tmax, uint32_t leave,
                          struct hit *h);
vec3 scene_transmittance_from(const rayd_scene *s, const ray *r, double tmax, uint32_t leave);
bool scene_occluded_from(const rayd_scene *s, const ray *r, double tmax, uint32_t leave);

/* The same two queries for the rays r[i] whose bit i is set in active, as
 * a packet (scene_packet.c): ray i gets exactly what it would get alone.
 * scene_intersect16 returns the mask of rays that hit. */
uint32_t scene_intersect16(const rayd_scene *s, const ray r[16], const double tmax[16],
                           uint32_t active, struct hit h[16]);
void scene_transmittance16(const rayd_scene *s, const ray r[16], const double tmax[16],
                           uint32_t active, vec3 out[16]);
/* 16 times INFINITY: no bound.  (A constant: the packet code reads it 8 at
 * a time, which a just-written array of doubles would stall.) */
extern const double scene_unbounded16[16];

/* A packet's hits on untransformed spheres and planes as structure of
 * arrays: ray i in lanes hit leaf[i] at t[i], with no instance, part or
 * orientation (hit16_get gives the struct hit). */
struct hit16 {
    LANES_ALIGN double t[16];
    const struct object *leaf[16];
    uint32_t lanes;
};

static inline struct hit hit16_get(const struct hit16 *hs, int i) {
    return (struct hit){.t = hs->t[i], .leaf = hs->leaf[i]};
}

/* scene_intersect16 for rays as structure of arrays.  With simple (else
 * NULL), the hits on untransformed spheres and planes go there instead of
 * to h: the wide shader takes them so, without the struct hits. */
uint32_t scene_intersect16_soa(const rayd_scene *s, const struct ray16 *r, const double tmax[16],
                               uint32_t active, struct hit h[16], struct hit16 *simple);
/* scene_transmittance16 with the rays and the answers as structure of
 * arrays: ray i from (o[0][i], o[1][i], o[2][i]) along (d[0][i], d[1][i],
 * d[2][i]) lets through (out[0][i], out[1][i], out[2][i]); 0 for the rays
 * outside active.  light is the index of the light the rays are shadow rays
 * of -- from just off a surface point p, along the unit vector from p to
 * the light, for p's distance to it -- or -1 for other rays; given, the
 * light's buffer (light_buffer.c) may stand in for the BVH walk. */
void scene_transmittance16_soa(const rayd_scene *s, int light, const double o[3][16],
                               const double d[3][16], const double tmax[16], uint32_t active,
                               double out[3][16]);

/* Point, normals and material of a hit of ray r. */
void scene_surface(const rayd_scene *s, const ray *r, const struct hit *h, struct surface *sf);

/* scene_cost.c: the rays one camera sample is expected to cast, each
 * weighted by its cost against a plain ray's (an upper-bound estimate from
 * the scene's description alone). */
double scene_rays_per_sample(const struct rayd_scene *s);
/* scene_cost.c: sets s->ray_tests from the built BVHs (scene_freeze). */
void scene_cost_freeze(struct rayd_scene *s);

#endif
