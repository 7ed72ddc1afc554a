/* shots_private.h -- a frame-range job (shots.c) as the files of its
 * topics see it: the shot, its frames and its attempts in flight, and the
 * few functions they share.  Everything here is under work_lock.
 *
 *   shots.c         the table, each frame's parse and render, the store,
 *                   letting go of frames and videos, the video
 *   shots_info.c    the numbers a status reads, its error's message, its record
 *   shots_events.c  the job's event stream (GET /v1/jobs/{id}/events)
 */
#ifndef SHOTS_PRIVATE_H
#define SHOTS_PRIVATE_H

#include "work/work_private.h"

#define SHOTS_TRIES 3 /* a frame's attempts in all */

enum shots_fstate { SF_QUEUED, SF_PARSING, SF_RUNNING, SF_DONE, SF_FAILED };
enum shots_gone { SG_KEPT, SG_MEMORY, SG_DISK };
struct shot_frame {
    unsigned char state; /* enum shots_fstate */
    unsigned char tries; /* attempts that failed */
    bool on_disk;        /* its images are files (--data-dir): no copy in memory */
    unsigned char gone;  /* enum shots_gone: done, but its images were let go */
    struct blob *png, *exr;
};

/* One attempt at one frame: the parse, then the render. */
struct shots_fly {
    struct compile_waiter cw; /* first: the parse's callbacks get it back */
    struct work_waiter ww;
    struct shot *s;
    int i;                  /* the frame's index in the shot (frame first + i) */
    struct task *t;         /* the render, once submitted (a job's reference) */
    bool dropped;           /* the cancel let go of t's interest already */
    bool sync;              /* parsed within shots_pump, whose loop goes on by itself */
    struct shots_fly *next; /* the shot's attempts in flight */
};

struct shot {
    char id[33];
    int refs; /* the table, each attempt in flight, each open stream */
    uint64_t client;
    int priority;
    long long seq;
    double created, created_wall, t_end, canceled_at;
    char *text; /* the scene as sent */
    size_t len;
    size_t held; /* its text until it ends, counted as kind frames in --max-memory */
    char scene_id[65];
    struct rayd_region reg;
    bool keep_exr, canceled, recorded; /* recorded: its end is queued to the store */
    bool waiting;                      /* a frame was refused for room: shots_kick goes on */
    bool denoise;                      /* each frame denoised (work_target's) */
    unsigned aov;                      /* each frame's AOVs (work_target's) */
    long first, last;
    int n, ndone, nfailed, flying, latest;
    double fps, est_rays;
    uint64_t rays;
    double first_start;                    /* when a tile of its first frame to start began, 0 */
    double queue_ms, render_ms, encode_ms; /* its frames' times, added as each ends */
    struct shot_frame *f;
    int *order; /* frames in the order they ended (done or failed), for streams */
    int norder;
    struct rayd_error err;   /* the first frame that failed for good */
    int err_tries;           /* its attempts */
    bool err_whole;          /* err is shots_error's already: a failed job put back */
    struct shots_fly *flies; /* in flight */
    /* Its newest frame's scene, held until the next frame is parsed, so
     * that parse takes the image textures decoded and the mesh sources
     * built (rayd_asset_cache, scenes.c) even when no frame is in flight
     * between the two; let go when a frame waits for room and when the
     * shot ends. */
    struct cache_entry *kept;
    size_t scene_bytes;      /* its newest frame's scene's (or the admitted one's), counted */
    struct work_waiter *sse; /* event streams waiting for news */
    int video_state;         /* enum shots_video */
    struct blob *video;
    double video_used; /* clock_now() when made or last asked for: the budget's order */
    char video_error[200];
};

/* The shot of id, or NULL (lock held). */
struct shot *shots_find(const char *id);
/* Lets go of one reference to s: the last frees it (lock held). */
void shots_unref(struct shot *s);
/* s has every frame: its video queued for the video thread (lock held;
 * shots_video.c). */
void shots_video_queue(struct shot *s);
/* Whether s has ended (done, failed or cancelled), frames in flight aside. */
static inline bool shots_final(const struct shot *s) {
    return s->canceled || s->ndone == s->n || (s->nfailed > 0 && s->flying == 0);
}

static inline enum jobs_state shots_state(const struct shot *s) {
    if (s->canceled) return JS_CANCELED;
    if (s->ndone == s->n) return JS_SUCCEEDED;
    if (s->nfailed > 0 && s->flying == 0) return JS_FAILED;
    if (s->ndone > 0) return JS_RUNNING;
    for (const struct shots_fly *fl = s->flies; fl; fl = fl->next)
        if (fl->t && fl->t->t_start > 0) return JS_RUNNING; /* a tile of it started */
    return JS_QUEUED;
}

/* When a final shot ended (clock_now's clock). */
static inline double shots_ended(const struct shot *s) {
    return s->canceled ? s->canceled_at : s->t_end;
}

/* The error s failed with: its first frame that failed for good (shots_info.c). */
void shots_error(const struct shot *s, struct rayd_error *err);
/* s's numbers, for a status (shots_info.c). */
void shots_info_of(const struct shot *s, struct shots_info *o);
/* s's record for the store, its figures so far (shots_info.c). */
void shots_record(const struct shot *s, struct store_job *row);

#endif
