/* router.h -- method + path -> handler, and what the transport asks of the
 * route table.
 *
 * Layer: router (router.c), between the transport above and the handlers
 * below.  May include: request.h (and base.h through it); router.c itself
 * includes api.h, the handlers it dispatches to.  Included by http_flow.c
 * and main.c.
 */
#ifndef RAYD_SERVER_ROUTER_H
#define RAYD_SERVER_ROUTER_H

#include "req/request.h"

/* Registers the routes' metric labels (metrics_route_name), at start-up. */
void router_start(void);
/* The route label index of a path (its pattern's first row), -1 for none;
 * the request metrics count by it. */
int router_find(const char *url);
/* Runs the handler of r's method and path, or replies 404 / 405. */
void router_dispatch(struct http_req *r);
/* Replies 404 / 405 as router_dispatch would when no route takes r's
 * method and path: true after that reply.  Asked with the headers, so a
 * body is never read (nor "100 Continue" sent) for a request no route
 * serves.  The row it finds is kept in r (route_row, route_id), and
 * router_dispatch takes it from there: one lookup per request. */
bool router_refuse(struct http_req *r);
/* Allowed methods for a path ("GET, DELETE"), NULL when no route matches. */
const char *router_allow(const char *path, char *buf, size_t size);
/* Routes open without a token: the probes and the preview's own files. */
bool router_public(const char *method, const char *url);

#endif
