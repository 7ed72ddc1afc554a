/* mesh_io.h -- triangle meshes decoded from OBJ and PLY bytes (internal). */
#ifndef MESH_IO_H
#define MESH_IO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "base/array.h"
#include "rayd/rayd.h"

/* An indexed triangle mesh.  Every array is malloc'd and owned by the
 * struct; free them all with mesh_data_free. */
struct mesh_data {
    float *pos;      /* 3 floats per vertex */
    float *normal;   /* 3 per vertex, or NULL */
    float *uv;       /* 2 per vertex, or NULL */
    uint32_t *index; /* 3 per triangle, each < nverts */
    uint32_t nverts, ntris;
    size_t charged; /* bytes charged through mesh_limits.charge for these arrays */
};

/* Upper bounds on a decoded mesh, taken literally (0 allows nothing).  A
 * NULL limits pointer means "no limit beyond what a uint32_t index holds". */
struct mesh_limits {
    uint32_t max_vertices;
    uint32_t max_triangles;
    /* Optional: the caller's memory budget (rayd_limits.charge's contract).
     * A decoder calls it with the bytes of a big array before allocating
     * it (its arrays as sized from a header or grown), stops with the
     * status it returns (its reason in the message), and calls it with
     * minus the bytes it frees.  On success mesh_data.charged says what is
     * still charged for the arrays; on failure all is given back. */
    enum rayd_status (*charge)(void *arg, long long bytes, char *why, size_t why_len);
    void *charge_arg;
};

/* Frees the arrays and zeroes the struct; m may be NULL. */
void mesh_data_free(struct mesh_data *m);

/* Decodes Wavefront OBJ text text[0..len) (need not be NUL-terminated).
 * On RAYD_OK *out owns a new mesh with at least one triangle (free it with
 * mesh_data_free); otherwise *out is untouched and err says which line is
 * wrong: RAYD_E_INVALID for bad data, RAYD_E_LIMIT over lim, RAYD_E_NOMEM. */
enum rayd_status mesh_parse_obj(const char *text, size_t len, const struct mesh_limits *lim,
                                struct mesh_data *out, struct rayd_error *err);

/* Decodes a PLY file (ascii, binary_little_endian or binary_big_endian
 * 1.0) from data[0..len).  Same contract as mesh_parse_obj; messages name
 * the header line or the element record (0-based, as PLY indices are). */
enum rayd_status mesh_parse_ply(const void *data, size_t len, const struct mesh_limits *lim,
                                struct mesh_data *out, struct rayd_error *err);

/* The same decoders on several threads: threads > 0 exactly that many
 * (1: one pass in order, as above), <= 0 every core for inputs large
 * enough to gain from them.  The mesh, and on failure the error, are the
 * same whatever the count. */
enum rayd_status mesh_parse_obj_threads(const char *text, size_t len, const struct mesh_limits *lim,
                                        int threads, struct mesh_data *out, struct rayd_error *err);
enum rayd_status mesh_parse_ply_threads(const void *data, size_t len, const struct mesh_limits *lim,
                                        int threads, struct mesh_data *out, struct rayd_error *err);

/* Tests: OBJ lines read only the general way (false), or with the fast
 * path for plain "v" and "f" lines (true, the default); both must give
 * the same mesh or the same error. */
void mesh_obj_fast_path(bool on);

/* ---- helpers shared by mesh_obj.c and mesh_ply.c ------------------------ */

/* Records (PLY) or lines (OBJ) a thread at least when the decoders pick
 * the thread count themselves. */
#define MESH_IO_CHUNK 8192

/* Parses the whole of s[0..n) as a decimal number (sign, digits, point,
 * exponent; strtod's forms such as "nan" and "inf" too, so the caller can
 * say "not finite" rather than "not a number").  False unless every byte is
 * part of the number.  Never reads s[n]. */
bool mesh_parse_number(const char *s, size_t n, double *out);

/* The number that starts at s (before end) in its common form -- sign,
 * at most 19 significant digits, point, exponent, a value the fast path
 * computes exactly -- into *out: the bytes it spans, or 0 when s does not
 * start such a number (mesh_parse_number then asks strtod).  The decoders'
 * loops read numbers with it in place, without cutting tokens first. */
size_t mesh_scan_number(const char *s, const char *end, double *out);

/* Copies s[0..n) into buf (MESH_QUOTE_SIZE bytes) for an error message:
 * bytes outside printable ASCII become '?' (messages end up in JSON), and
 * a long token is cut with "...".  Returns buf. */
#define MESH_QUOTE_SIZE 48
const char *mesh_quote(char *buf, const char *s, size_t n);

/* lim's bounds, capped at (and for a NULL lim equal to) UINT32_MAX - 1. */
uint32_t mesh_max_vertices(const struct mesh_limits *lim);
uint32_t mesh_max_triangles(const struct mesh_limits *lim);

/* Charges bytes to lim's hook (none: always RAYD_OK), adding them to
 * *charged; on a refusal why holds the hook's reason. */
enum rayd_status mesh_charge(const struct mesh_limits *lim, size_t *charged, size_t bytes,
                             char *why, size_t why_len);

/* Gives back bytes (at most *charged) to lim's hook. */
void mesh_give_back(const struct mesh_limits *lim, size_t *charged, size_t bytes);

/* array_grow with the growth charged before it is allocated: RAYD_OK,
 * the hook's refusal (why says it), or RAYD_E_NOMEM (charge given back). */
enum rayd_status mesh_grow(const struct mesh_limits *lim, size_t *charged, void **arr, size_t *cap,
                           size_t need, size_t elem, char *why, size_t why_len);

#endif
