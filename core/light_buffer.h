/* light_buffer.h -- which objects can shadow which directions from a point
 * light (light_buffer.c). */
#ifndef LIGHT_BUFFER_H
#define LIGHT_BUFFER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rayd/rayd.h"
#include "vec.h"

/* One face of the cube around the light: the directions r (from the light)
 * whose largest component is r[axis], of sign `sign`, at face coordinates
 * u = r[b] / |r[axis]|, v = r[c] / |r[axis]| (b, c the next two axes).  The
 * rectangle the objects cover is cut into nu x nv cells; cell (i, j) lists
 * ids[start[j * nu + i] .. start[j * nu + i + 1]), indices into the scene's
 * objs. */
struct light_face {
    double u0, v0;  /* the rectangle's low corner */
    double su, sv;  /* cells per unit of u and v */
    double cu, cv;  /* and a cell's width in u and v, 1 / su and 1 / sv */
    int32_t nu, nv; /* 0 x 0: no object shows on this face */
    uint32_t *start, *ids;
};

struct light_buffer {
    bool ok;                   /* built: a point light no object's box comes near */
    vec3 at;                   /* the light's position */
    double reach;              /* valid for shadow rays leaving points within this box
                                  around the origin (max |coordinate|) */
    struct light_face face[6]; /* 2 * axis + (sign < 0) */
};

/* Builds the buffers of the scene's point lights into s->light_buffers
 * (one per light; ok false for other lights, and where a buffer would not
 * be sound or passes the bounds).  Fails only when out of memory. */
enum rayd_status light_buffers_build(rayd_scene *s, struct rayd_error *err);
void light_buffers_free(rayd_scene *s);
/* The memory they take. */
size_t light_buffers_bytes(const rayd_scene *s);

#endif
