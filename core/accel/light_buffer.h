/* light_buffer.h -- which objects can shadow which directions from a point
 * light (light_buffer.c). */
#ifndef LIGHT_BUFFER_H
#define LIGHT_BUFFER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rayd/rayd.h"
#include "math/vec.h"

/* One face of the cube around the light: the directions r (from the light)
 * whose largest component is r[axis], of sign `sign`, at face coordinates
 * u = r[b] / |r[axis]|, v = r[c] / |r[axis]| (b, c the next two axes).  The
 * rectangle the objects cover is cut into nu x nv cells; cell (i, j) lists
 * ids[start[j * nu + i] .. start[j * nu + i + 1]), indices into the boxes
 * the buffers were built over. */
struct light_face {
    double u0, v0;  /* the rectangle's low corner */
    double su, sv;  /* cells per unit of u and v */
    double cu, cv;  /* and a cell's width in u and v, 1 / su and 1 / sv */
    int32_t nu, nv; /* 0 x 0: no object shows on this face */
    uint32_t *start, *ids;
    /* The 2 x 2 cells from (i, j) on, i in -1 .. nu - 1 and j in -1 .. nv - 1
     * (cells outside the rectangle hold nothing): their objects, each once,
     * in the order of the cells' lists, are quad[qstart[q] .. qstart[q + 1])
     * with q = (j + 1) * (nu + 1) + i + 1.  A packet's candidates are then
     * one range, not four lists merged while its rays wait. */
    uint32_t *qstart, *quad;
};

struct light_buffer {
    bool ok;                   /* built: a point light no object's box comes near */
    vec3 at;                   /* the light's position */
    double reach;              /* valid for shadow rays leaving points within this box
                                  around the origin (max |coordinate|) */
    struct light_face face[6]; /* 2 * axis + (sign < 0) */
};

/* A light as the buffers see it: where it is, and whether it is a point
 * light (only those get a buffer). */
struct light_buffer_light {
    vec3 at;
    bool point;
};

/* Builds one buffer per light over the objects' boxes (an object without
 * bounds comes as an infinite box): ok false for lights that are not
 * points, and where a buffer would not be sound or passes the bounds.
 * *out NULL when no light gets one.  Fails only when out of memory. */
/* Whether light_buffers_build could give any light a buffer: a point light
 * among them, and an object count the buffers pay for. */
bool light_buffers_worth(const struct light_buffer_light *lights, int nlights, int32_t nobjs);
enum rayd_status light_buffers_build(const struct aabb *box, int32_t nobjs,
                                     const struct light_buffer_light *lights, int nlights,
                                     struct light_buffer **out, struct rayd_error *err);
void light_buffers_free(struct light_buffer *bufs, int nlights);
/* The memory they take. */
size_t light_buffers_bytes(const struct light_buffer *bufs, int nlights);

#endif
