/* cluster.h -- rayd nodes sharing jobs, frames and tiles through Redis
 * (rayd --redis URL), as the handlers and main.c see it.
 *
 * Layer: cluster (redis.c, cluster.c, cluster_items.c, cluster_jobs.c, cluster_node.c,
 * cluster_assemble.c), above the work layer and below the handlers.  May
 * include: work.h (and through it base.h), hiredis and cJSON -- never an
 * HTTP header.  Included by the handlers (api_cluster.c) and main.c.
 *
 * Without --redis nothing here runs and cluster_on() is false: the job
 * routes are the single node's.  With it, every job route of any node is
 * answered from Redis: the handler fills a struct cluster_op and hands it
 * to cluster_submit, which suspends the request (op->suspend, before the
 * op is linked) and answers it from the cluster's request thread
 * (op->done), so no Redis call ever runs on an HTTP thread.  The work --
 * tiles of frames -- is taken from a Redis stream by every node's puller
 * (cluster_node.c) and rendered through the work layer like any render.
 */
#ifndef RAYD_SERVER_CLUSTER_H
#define RAYD_SERVER_CLUSTER_H

#include "work/work.h"

bool cluster_on(void); /* --redis was given */
/* Main thread, after config_load: parses --redis (and RAYD_REDIS_PASSWORD);
 * -1 after a message naming the part of the URL that is wrong (exit 2). */
int cluster_configure(void);
/* Main thread, once the listener has its port: connects (a Redis that is
 * down is retried, never fatal) and starts the request thread and the
 * puller.  false if a thread could not be made. */
bool cluster_start(int port);
/* The puller stops taking items (the drain); items in flight are left to
 * be reclaimed by other nodes. */
void cluster_drain(void);
void cluster_stop(void); /* after the listener stopped */

/* ---- one job request, answered from the request thread -------------------- */

enum cluster_op_kind {
    CO_SUBMIT, /* POST /v1/jobs: the job and its items written */
    CO_GET,    /* GET /v1/jobs/{id} */
    CO_CANCEL, /* DELETE /v1/jobs/{id} */
    CO_IMAGE,  /* a frame's PNG: image.png (frame 0 of a still) or frames/{k}.png */
    CO_VIDEO,  /* a frame range's video.mp4 (in png), once made */
    CO_LIST,   /* GET /v1/jobs */
    CO_EVENTS, /* GET /v1/jobs/{id}/events: the events after a cursor */
    CO_STOP    /* POST /v1/jobs/{id}/stop: a progressive job ends with its latest pass */
};
enum cluster_status {
    CS_OK,
    CS_UNKNOWN, /* no such job (or its tombstone expired too) */
    CS_GONE,    /* the job expired (--job-ttl after it ended): gone says how, 410 */
    CS_FULL,    /* CO_SUBMIT: --max-jobs jobs of the cluster are unfinished: 503 */
    CS_DOWN,    /* Redis unreachable or answering errors: 503 cluster_unavailable */
    CS_NOMEM
};
#define CLUSTER_LIST_MAX 100
/* Work items one job may make (frames x tiles): written in one script, so
 * a job's POST holds Redis for at most some 100 ms. */
#define CLUSTER_MAX_ITEMS 50000L
#define CLUSTER_EVENTS_MAX 32
/* One job event as kept in its stream. */
struct cluster_event {
    char cursor[48];        /* the stream entry's id */
    char kind[16];          /* state, tile, frame, pass, done */
    char state[16];         /* state, done */
    long frame, tile;       /* tile, frame */
    long done, total;       /* tile: tiles of the job done; frame: frames done; pass: the pass */
    struct rayd_region reg; /* tile: where it is in the image */
    double progress;        /* pass: the job's progress; < 0: none */
    long samples;           /* pass: its samples, what it took, its noise estimate */
    double time_s, noise;
};
struct cluster_op {
    enum cluster_op_kind kind;
    char id[33];
    long frame; /* CO_IMAGE: the frame (a still job's is 0) */
    long pass;  /* CO_IMAGE: a progressive job's pass asked (?pass=K), 0: the latest */
    /* CO_SUBMIT */
    const char *scene; /* the body as sent: valid until done() */
    size_t scene_len;
    char scene_id[65];
    const char *query; /* what shaped it, for the record */
    struct rayd_region reg;
    int priority;
    uint64_t client;
    long first, last; /* frames; a still: 0, 0 and animated false */
    bool animated;
    bool denoise; /* each tile rendered denoised (with its apron): crops of the denoised frame */
    bool exr;     /* CO_SUBMIT: the job keeps an EXR too (format=exr); CO_IMAGE: the EXR asked */
    unsigned aov; /* the one AOV the PNG shows instead of the light (enum rayd_aov bits), or 0 */
    bool progressive; /* CO_SUBMIT: rendered in passes (plan, samples) */
    struct jobs_plan plan;
    int samples[PASSES_MAX], npasses;
    double fps, est_rays;
    /* CO_LIST */
    long long after; /* the cursor (a creation time in ms), 0: from the newest */
    int state, limit;
    /* CO_EVENTS: read after this cursor ("0": from the start) */
    char cursor[48];
    /* out */
    enum cluster_status status;
    char why[400];           /* CS_DOWN: the address and the reason */
    struct jobs_gone gone;   /* CS_GONE: how and when it ended, when it went */
    struct shots_info info;  /* the job (info.job), and its frames when animated */
    bool is_animated;        /* the job is a frame range */
    bool canceled_now;       /* CO_CANCEL: this request ended it */
    bool not_progressive;    /* CO_STOP: the job has no passes to stop (409) */
    double created_ms;       /* CO_SUBMIT: when the job was made (ms since the epoch) */
    struct blob *png;        /* CO_IMAGE: the frame's PNG (or EXR), when it is there */
    int pass_samples;        /* CO_IMAGE of a progressive job: the samples of that pass */
    struct shots_info *rows; /* CO_LIST: limit rows (the caller's array) */
    bool *row_animated;
    int nrows;
    bool more;
    struct cluster_event events[CLUSTER_EVENTS_MAX];
    int nevents;
    double at; /* clock_now() before which the op waits (an event stream's poll); 0: now */
    void (*suspend)(struct cluster_op *op); /* under the queue's lock, before linking */
    void (*done)(struct cluster_op *op);    /* on the request thread, once */
    struct cluster_op *next;
};
/* The bytes assembling a frame of w x h pixels in tiles of tile pixels
 * (with its EXR of the AOVs aov: exr) holds (the memory budget's charge):
 * over --max-memory, a job of such frames is refused at POST, as one node
 * refuses such a render. */
size_t cluster_assemble_bytes(long w, long h, long tile, bool exr, unsigned aov);
/* Likewise for a progressive job's pass (cluster_passes.c): the pass's
 * image and PNG, the previous pass's, and a tile's sums. */
size_t cluster_passes_bytes(long w, long h, long tile);
/* Queues op: true after op->suspend ran (op->done will be called once);
 * false when the cluster is stopping (op not used). */
bool cluster_submit(struct cluster_op *op);

/* ---- what /healthz and /metrics show ---------------------------------------- */

struct cluster_status_view {
    bool checked; /* the puller has looked at Redis once: before, redis_up says nothing */
    bool redis_up;
    char address[300];
    char reason[200]; /* why it is down */
    long nodes, queued, in_flight;
    long node_in_flight, done_total, reclaimed_total, deferred_total;
    long jobs_unfinished;        /* the cluster's (rayd:unfinished), against --max-jobs */
    char other_versions[4][120]; /* "rayd 0.9.0: 12 items wait ..." */
    int nother;
};
void cluster_view(struct cluster_status_view *v); /* a snapshot the puller keeps */
const char *cluster_version(void);                /* the items' version (tests may set it) */
/* The cluster's lines of /metrics appended to text (len bytes, malloc'd),
 * or text as it was when out of memory. */
char *cluster_metrics(char *text, size_t *len);

#endif
