/* client.h -- the internal interfaces of rayd-client.
 *
 * rayd-client is a few files, one idea each, and every public name starts
 * with its file's name, as in the server:
 *
 *   rayd-client.c  the command line: options, the render / job / health
 *                  commands, exit codes
 *   scenefile.c    reads a scene, inlines the mesh and texture files it
 *                  names, validates it with the core, hashes it (scene id)
 *   gltf_bundle.c  a .gltf's buffer and image files as data: URIs, so that
 *                  it travels alone
 *   net.c          libcurl glue shared by the commands: response buffers,
 *                  headers, the API's JSON errors, Retry-After
 *   tiles.c        the tile scheduler: one frame as tiles (or sample ranges)
 *                  over many servers with libcurl's multi interface,
 *                  retries, stitching (or adding the ranges' sums)
 *   progress.c     the progress bar (terminal) or plain progress lines
 *   job.c          the asynchronous job API with its Server-Sent Events
 *   job_frames.c   a frame-range job: each frame to -o's pattern, the video
 *   sse.c          one connection to an event stream, read between requests
 *   watch.c        render --progressive and watch ID: a job followed pass
 *                  by pass, each pass written to -o as it arrives
 *   thumbnails.c   the thumbnails command: each model of a folder in a
 *                  studio scene, framed, rendered by tiles.c
 *
 * From programs/common/ (common.h), shared with rayd-render: the option
 * helpers, the finished image into -o (output_write: a temporary file
 * renamed when whole, or standard output for "-"), the output's format
 * by its name, and the base64 encoder of the embedded files.
 *
 * Exit status (rayd-client.c): 0 done, 1 failure (the scene or job was
 * refused, a server is unhealthy, tiles are missing, a transport or write
 * error), 2 usage error; 130 when interrupted.  Errors are printed as
 * "rayd-client: error: ..." on stderr, status lines as "rayd-client: ...".
 *
 * Only include/rayd/rayd.h crosses from the core; libcurl and cJSON types
 * stay in the files that need them.
 */
#ifndef RAYD_CLIENT_H
#define RAYD_CLIENT_H

#include "common/common.h"

#include <stddef.h>
#include <stdbool.h>
#include <stdint.h>

#define CLIENT_MAX_SERVERS 64

/* ---- rayd-client.c: the options every command shares ------------------- */

struct client_opts {
    const char *servers[CLIENT_MAX_SERVERS]; /* base URLs, no trailing '/' */
    int nservers;
    const char *out;  /* -o */
    int tile;         /* tile edge in pixels */
    int parallel;     /* transfers in flight at once, all servers together */
    int retries;      /* further attempts of a failed tile */
    double timeout;   /* seconds per request */
    char *token;      /* from --token-file, trimmed; NULL = none */
    int quiet;        /* no progress at all */
    int ranges;       /* > 0: split the samples into this many ranges, not the pixels */
    int threads;      /* PNG encoding threads of the stitched frame; 0 = every core */
    const char *what; /* named first in tiles.c's error lines (thumbnails: the model), or NULL */
    int no_hedge;     /* --no-hedge: never send a straggler's copy to a second server */
    int frames_set;   /* job --frames A-B given */
    long frame_a, frame_b; /* its frames, inclusive */
    const char *video;     /* job --video: the MP4 to write, or NULL */
    int progressive;       /* render --progressive: a progressive job (watch.c) */
    int detach;            /* render --progressive --detach: start it, print its id */
    const char *pass_step, *time_budget, *noise_target; /* its query's values, or NULL */
};

/* ---- scenefile.c ---------------------------------------------------------- */

struct scenefile {
    const char *name; /* the scene as messages name it: its path, or <stdin> */
    char *bytes;      /* exactly what is sent (malloc'd) */
    size_t len;
    char id[65]; /* lowercase hex SHA-256 of bytes: the server's scene id */
    int width, height;
    int samples;
    int bundled;  /* files inlined */
    int animated; /* an "animation" block: frames anim_start..anim_end */
    long anim_start, anim_end;
    /* JSON Pointers of the keys the inlined bytes went to ("/render/
     * environment/base64"), each where the scene said "file": an error the
     * core finds in those bytes is reported at the "file" the user wrote,
     * as rayd-render reports it.  malloc'd, ninlined of them. */
    char **inlined;
    int ninlined;
};

/* Reads path, inlines "file" references (mesh sources and image textures,
 * relative to the scene's folder) as base64, validates the result with the
 * core and hashes it.  Returns 0, or -1 after printing why on stderr. */
int scenefile_load(const char *path, struct scenefile *sf);
/* The mesh source format a model file's name implies ("obj", "ply", "glb",
 * "gltf", any case), or NULL when the name is no model's. */
const char *scenefile_format(const char *name);
void scenefile_free(struct scenefile *sf);
/* With sf->bytes (malloc'd) and sf->len set: validates and hashes them as
 * scenefile_load does.  0, or -1 after printing why (sf freed). */
int scenefile_finish(const char *name, struct scenefile *sf);

/* ---- gltf_bundle.c ------------------------------------------------------- */

/* *json (malloc'd, *len bytes) is the .gltf at path: every buffer and image
 * "uri" naming a file is replaced by a data: URI of that file's bytes, read
 * from path's folder and confined to it.  *json is replaced when anything
 * changed; bytes that are no JSON object (a .glb) are left as they are.
 * The number of files inlined (0: *json unchanged), or -1 after printing
 * why (naming path, the JSON Pointer and the file). */
int gltf_bundle(const char *path, char **json, size_t *len);
/* The same for a .gltf whose files are in the folder dir ("" = the current
 * one); messages call it name. */
int gltf_bundle_in(const char *dir, const char *name, char **json, size_t *len);
/* Why a file name may not be sent from the folder it is read from (empty,
 * an absolute path, a ".." component), or NULL: the one rule for a .gltf's
 * files and a scene's own "file" names alike. */
const char *gltf_bundle_outside(const char *name);

/* ---- net.c ---------------------------------------------------------------- */

/* A growing response body, capped at max bytes (0 = 64 MiB). */
struct net_buf {
    char *data;
    size_t len, cap, max;
    int overflow;
};

void net_buf_reset(struct net_buf *b);
void net_buf_free(struct net_buf *b);

void net_global_init(void);
void net_global_cleanup(void);
/* A new easy handle for url writing into body, with the options shared by
 * every request (timeouts, keep-alive, token, user agent).  json_body, when
 * not NULL, makes it a POST of those bytes as application/json.  *hdrs
 * receives the header list to free with curl_slist_free_all after the
 * transfer.  The handle is a CURL * (void here to keep curl out). */
void *net_easy(const struct client_opts *o, const char *url, struct net_buf *body,
               const char *json_body, size_t json_len, void **hdrs);
/* s as it may be printed on a terminal, into buf: control characters (C0
 * incl. ESC, CR and LF, DEL, C1 raw or UTF-8 encoded) and bytes that are
 * no UTF-8 as \xNN, the rest as it is; cut with "..." to fit size.  Every
 * string a server sent goes through it before it is printed.  Returns buf
 * ("" for NULL).  net_safe_n: the first n bytes of s (up to a NUL). */
char *net_safe(const char *s, char *buf, size_t size);
char *net_safe_n(const char *s, size_t n, char *buf, size_t size);
/* Describes an answer that is not a success: "HTTP 422 invalid_scene at
 * /objects/1/radius: must be > 0" from the API's JSON error, or the first
 * bytes of the body.  Returns buf. */
char *net_describe(long status, const struct net_buf *body, char *buf, size_t size);
/* Runs the request of handle h (net_easy's, with its header list hdrs) and
 * frees both: the HTTP status, or 0 with why set on a transport error. */
long net_perform(void *h, void *hdrs, char *why, size_t size);
/* o[k] when it is a string, else NULL (o a cJSON *, void here to keep cJSON
 * out). */
const char *net_json_str(const void *o, const char *k);
/* The API error code of a JSON error body ("scene_unknown"), into buf; "" if
 * none. */
char *net_error_code(const struct net_buf *body, char *buf, size_t size);
/* Retry-After of the last answer of handle h in seconds (>= 0), or def. */
double net_retry_after(void *h, double def);
/* Monotonic seconds. */
double net_now(void);
/* "host:port" of a URL, for labels. */
void net_label(const char *url, char *buf, size_t size);

/* ---- progress.c ----------------------------------------------------------- */

struct progress {
    int tty, quiet;
    int total;
    double t0, last_draw, last_line;
    int last_pct, last_done;
    int width;        /* drawn width, to clear */
    const char *unit; /* what the pieces are called: "tiles" unless set after init */
};

void progress_init(struct progress *p, int total, int quiet);
/* Draws at most a few times a second (always when force).  per_server[i]
 * tiles done by labels[i]; rays_per_s < 0 when unknown. */
void progress_update(struct progress *p, int done, int failed, int nservers, const long *per_server,
                     char labels[][40], double rays_per_s, int force);
/* Ends the bar's line. */
void progress_end(struct progress *p);
/* secs left as every progress line says it ("45s", "3m05s", "2h10m";
 * "--" when < 0). */
void progress_eta(double secs, char *buf, size_t size);
/* A progressive job's pass k of n, of samples out of target, written to
 * path (NULL: none), secs after its render began, eta_s left (< 0 when
 * unknown): the bar redrawn, or one line. */
void progress_pass(struct progress *p, long k, long n, long samples, long target, double secs,
                   double eta_s, const char *path);

/* ---- tiles.c -------------------------------------------------------------- */

/* Renders sf as tiles over o->servers and writes o->out.  Returns 0 on a
 * complete image, 1 when the scene was refused or tiles are missing
 * (nothing is written then). */
int tiles_render(const struct client_opts *o, const struct scenefile *sf);

/* ---- thumbnails.c ---------------------------------------------------------- */

/* Renders every .ply/.obj/.glb/.gltf model in dir as a size x size PNG in
 * outdir (NAME.png) over o->servers: the model in a studio scene framed
 * with camera.frame = all from view ("three-quarter", "front", "side",
 * "top").  turntable > 0 renders that many frames a model instead,
 * NAME-000.png ..., the view turned about +Y in equal steps.  One line a
 * PNG on stderr; 0 when every model was written, 1 when any failed (the
 * others are still written).  A model whose name differs from an earlier
 * one's only in the extension (a.gltf after a.glb) would overwrite its
 * PNGs: it is skipped, said, and counts as failed. */
int thumbnails_run(const struct client_opts *o, const char *dir, const char *outdir, int size,
                   const char *view, int turntable);

/* ---- sse.c ---------------------------------------------------------------- */

/* How one connection to an event stream ended (sse_run). */
enum { SSE_DONE, SSE_FAILED, SSE_STOPPED, SSE_DROPPED, SSE_REFUSED };

/* One event stream being followed.  The caller sets o, on_event, idle and
 * user; sse_run sets the rest. */
struct sse {
    const struct client_opts *o;
    /* Each event, never inside a libcurl callback: 0 go on, 1 the stream
     * ended well (SSE_DONE), -1 stop (SSE_FAILED).  data is "" when none. */
    int (*on_event)(void *user, const char *event, const char *data);
    /* Between reads, at least five times a second: 0 go on, 1 stop
     * (SSE_STOPPED), -1 stop (SSE_FAILED).  It may make requests. */
    int (*idle)(void *user);
    void *user;
    long status;               /* the answer's HTTP status (0: none came) */
    struct net_buf error_body; /* a status other than 200: the body's first bytes */
    long retry_ms;             /* the stream's "retry:", 100..10000 (0: none said) */
    int events;                /* events read on this connection */
    char why[300];             /* how a dropped stream ended */
};

/* Opens url (GET) and follows it until on_event or idle ends it, or the
 * stream ends: SSE_DONE or SSE_FAILED (on_event), SSE_STOPPED or
 * SSE_FAILED (idle), SSE_DROPPED (the stream ended or broke: why says
 * how), SSE_REFUSED (a status other than 200: status, error_body).  Free
 * s->error_body with net_buf_free. */
int sse_run(struct sse *s, const char *url);

/* ---- job.c ---------------------------------------------------------------- */

/* The asynchronous API on o->servers[0]: POST /v1/jobs, follow the events,
 * fetch the PNG into o->out (a still scene: rayd-client.c sends an animated
 * one, or --frames, to job_frames_run).  Returns 0, 1 when refused, failed or on a
 * transport error, 130 when interrupted (the job is cancelled). */
int job_run(const struct client_opts *o, const struct scenefile *sf);
/* What job_frames.c shares of job.c.  job_stopped: Ctrl-C or SIGTERM came.
 * job_request: one blocking request (body: the scene, or NULL); the
 * status, or 0 with why set.  job_post: POST /v1/jobs + query (""), the id
 * into id; 0, or 1 said.  job_write: the image into path when it is a
 * PNG (an OpenEXR for .exr) of w x h; 0, or -1 said.  job_cancel: DELETE
 * the job, say so; returns 130. */
int job_stopped(void);
/* catch 1: Ctrl-C and SIGTERM set job_stopped from now on; 0: as before. */
void job_signals(int catch);
long job_request(const struct client_opts *o, const char *method, const char *url,
                 const struct scenefile *sf, struct net_buf *body, char *why, size_t size);
int job_post(const struct client_opts *o, const struct scenefile *sf, const char *query, char *id,
             size_t size);
int job_write(const char *path, const struct net_buf *b, int w, int h);
/* The size an image's header says (a PNG, an OpenEXR for an .exr path):
 * 0, or -1 when it has none. */
int job_image_size(const char *path, const struct net_buf *b, long *w, long *h);
int job_cancel(const struct client_opts *o, const char *id);
/* A poll of job id that got status st (0: no answer; b its body, why the
 * transport's words): true when it is worth asking again -- no answer or a
 * 502/503/504, a server restarting -- for up to --timeout seconds from the
 * first (*down; the caller sets it to 0 on an answer), said once as a
 * warning; else false, the error said. */
bool job_poll_again(const struct client_opts *o, const char *id, long st, const struct net_buf *b,
                    char *why, size_t size, double *down);
/* DELETE /v1/jobs/{id}, unsaid: whether this cancelled the job.  state
 * gets the job's state from the answer ("canceled"; "succeeded" or
 * "failed" when it had ended already: a DELETE then changes nothing), ""
 * when there was no such answer. */
bool job_delete(const struct client_opts *o, const char *id, char *state, size_t size);

/* ---- job_frames.c --------------------------------------------------------- */

/* `job` of an animated scene (or with --frames): POST /v1/jobs?frames=A-B,
 * each finished frame into o->out's pattern, o->video once all are done.
 * Returns 0, 1 when refused, failed or on a transport or write error, 2 on
 * a usage error (said, nothing sent), 130 when interrupted (cancelled). */
int job_frames_run(const struct client_opts *o, const struct scenefile *sf);
/* watch ID of a frame-range job (watch.c read its frames first..last and
 * its w x h): every frame done into o->out's pattern as it comes, then
 * o->video.  Ctrl-C leaves the job running.  The exit status as above. */
int job_frames_watch(const struct client_opts *o, const char *id, long first, long last, int w,
                     int h);

/* ---- watch.c -------------------------------------------------------------- */

/* render --progressive: POST /v1/jobs?progressive=1 (o's pass_step,
 * time_budget, noise_target; format=exr for -o *.exr), then each pass into
 * o->out as it arrives and the final image at the end; o->detach: print
 * the job's id on stdout and leave it running.  Returns 0 when the job
 * succeeded (its image written), 1 when refused, failed or on a transport
 * or write error, 130 when interrupted (the job cancelled, -o keeping the
 * last whole pass). */
int watch_render(const struct client_opts *o, const struct scenefile *sf);
/* watch ID: follows job id (progressive or not) on o->servers[0] as
 * watch_render does, writing to o->out when given; interrupted, it leaves
 * the job running (130). */
int watch_job(const struct client_opts *o, const char *id);

#endif
