/* transport.h -- the top of the daemon: libmicrohttpd and the request flow.
 *
 * Layer: transport (http_flow.c, http.c, http_deadline.c), above the router.  http_flow.c
 * takes a request from its first header to its end -- limits, framing,
 * auth, CORS preflight, then the router -- for any transport; http.c plugs
 * libmicrohttpd into it.  May include: router.h, request.h, base.h and
 * libmicrohttpd.  Included by main.c and the fuzz harnesses; nothing below
 * includes it.
 */
#ifndef RAYD_SERVER_TRANSPORT_H
#define RAYD_SERVER_TRANSPORT_H

#include "req/request.h"

/* ---- http_flow.c: a request's life, independent of the transport ------------
 *   http_req_new    (request.h) a request with its method and path;
 *   http_flow_begin headers only: refuses early (400 for unsound framing --
 *                   the transport's r->conn.framing, a header name that is no
 *                   token, no Host, a bad target, an ambiguous body length
 *                   --, 417 for an unknown Expect, 401 without the token,
 *                   413 by Content-Length, 414 over --max-url);
 *                   false when a reply is already pending;
 *   http_flow_body  appends a body chunk (counted, not kept, past --max-body);
 *                   false when the transport should drop the connection;
 *   http_flow_handle the whole request is here: auth, CORS, routing; the
 *                   handler replies (r->conn.pending) or suspends (then r->conn.parked
 *                   is set and r belongs to the worker until it resumes it);
 *   http_flow_end   access log, metrics, free. */
bool http_flow_begin(struct http_req *r);
bool http_flow_body(struct http_req *r, const char *data, size_t n);
void http_flow_handle(struct http_req *r);
void http_flow_end(struct http_req *r, const char *note);
/* The access line and count of a request libmicrohttpd refused with status
 * before rayd saw even its target (a request line over --max-header-bytes:
 * 414), from client ("" unknown); why is the reason ("" unknown). */
void http_flow_refused(const char *client, unsigned status, const char *why);
/* The access line and count of a connection cut by --header-seconds
 * (http_deadline.c) before its headers were in: from client, its target
 * (NULL: its request line never came), waited seconds after its deadline
 * was armed.  Nothing was sent; the line says 408, as nginx's. */
void http_flow_header_timeout(const char *client, const char *target, double waited);

/* ---- http_deadline.c: --header-seconds, a total deadline for the headers ----
 *   http_deadline_start/stop  the sweeper thread (none with --header-seconds 0);
 *   http_deadline_open   a connection accepted on fd: watched from now
 *                        (NULL: not watched -- off, or no memory);
 *   http_deadline_done   its headers are in: no longer watched; true once
 *                        when the sweeper cut it first (the caller logs it);
 *   http_deadline_next   a request ended on it (keep-alive): watched again;
 *   http_deadline_claim  true once when it was cut and nobody logged it yet,
 *                        with the seconds since it was armed into *waited;
 *   http_deadline_close  libmicrohttpd closes it (before its fd is closed). */
struct http_deadline;
int http_deadline_start(void);
void http_deadline_stop(void);
struct http_deadline *http_deadline_open(int fd);
bool http_deadline_done(struct http_deadline *d);
void http_deadline_next(struct http_deadline *d);
bool http_deadline_claim(struct http_deadline *d, double *waited);
void http_deadline_close(struct http_deadline *d);

/* ---- http.c: libmicrohttpd ------------------------------------------------------ */

int http_start(void); /* also registers the suspended-connections gauge */
bool http_tls(void);  /* serving HTTPS */
int http_port(void);
void http_stop(void);

#endif
