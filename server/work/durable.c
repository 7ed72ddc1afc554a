/* durable.c -- at start-up, the jobs of --data-dir put back.
 *
 * store.c keeps the records and images, jobs.c the table; this file, above
 * both and above the parse pool (compile.c), joins them once, on the main
 * thread, before the server listens: every record comes back as a job of
 * the table, in creation order.  One that ended comes back as it ended
 * (its image read from its file when asked, its TTL counting from when it
 * ended, so one that expired while rayd was down is forgotten at once by
 * the watcher).  One that had not ended -- queued, rendering, or with its
 * image half written when rayd was killed -- is queued again: its scene,
 * kept as it was sent, is parsed again on the parse pool (its files read
 * from --asset-dir again), and it renders from the start (a progressive
 * job from its first pass).  A scene that no longer parses (a file gone
 * from --asset-dir) ends its job as failed with the parser's error, and a
 * job found unfinished DURABLE_ATTEMPTS times (rayd killed during it each
 * time) fails too, rather than take every restart down with it -- a frame-
 * range job as a one-image job, counted by its frames left, and counted
 * again from zero each time one of its frames is done: a job killed five
 * times that went on each time is no job that kills rayd.  A clean stop
 * (a drain) counts no attempt (store_stop marks jobs.db).
 *
 * Only when every job is back does the server listen, so no client sees a
 * 404 for a job it was told of.  Layer: work, above compile.c.
 */
#include "work/work_private.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

#define DURABLE_ATTEMPTS 5

struct durable_wait {
    struct compile_waiter w;
    struct store_job *row;
};

static long durable_pending; /* lock held: compiles not yet answered */

/* Records row as failed with err (the store thread writes it). */
static void durable_record_failed(struct store_job *row, const struct rayd_error *err) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    row->state = JS_FAILED;
    row->err = *err;
    row->ended_wall = (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
    log_warn("job %s: not restarted: %s", row->id, err->message);
    work_lock_take();
    store_end(row, NULL, NULL, NULL);
    work_lock_give();
}

static void durable_fail(struct store_job *row, const struct rayd_error *err) {
    durable_record_failed(row, err);
    jobs_restore(row, NULL);
}

/* Whether row, unfinished, was found so DURABLE_ATTEMPTS times, each a
 * rayd that did not stop cleanly: it is failed (recorded, not restored). */
static bool durable_given_up(struct store_job *row) {
    if (row->state != JS_QUEUED || row->attempts < DURABLE_ATTEMPTS) return false;
    struct rayd_error err = {.code = RAYD_E_INTERNAL};
    snprintf(err.message, sizeof err.message,
             "rayd stopped %d times while the job was unfinished; it is not started again",
             row->attempts);
    durable_record_failed(row, &err);
    return true;
}

/* A parse thread's answer for one unfinished job. */
static void durable_compiled(struct compile_waiter *w, struct compile_result *res) {
    struct durable_wait *d = (struct durable_wait *)w;
    if (res->status == RAYD_OK) {
        if (!jobs_restore(d->row, res->scene))
            log_error("job %s: no room or memory to queue it again (it stays on disk for the "
                      "next start)",
                      d->row->id);
        scenes_release(res->scene);
    } else {
        struct rayd_error err = res->err;
        err.code = res->draining ? RAYD_E_CANCELED : res->status;
        char msg[sizeof err.message];
        snprintf(msg, sizeof msg, "its scene no longer loads: %.200s", res->err.message);
        snprintf(err.message, sizeof err.message, "%s", msg);
        durable_fail(d->row, &err);
    }
    work_lock_take();
    durable_pending--;
    work_lock_give();
    free(d);
}

static void durable_suspend(struct compile_waiter *w) { (void)w; }

/* An unfinished job: its scene parsed again, then queued (durable_compiled). */
static void durable_requeue(struct store_job *row) {
    if (durable_given_up(row)) {
        jobs_restore(row, NULL);
        return;
    }
    struct durable_wait *d = calloc(1, sizeof *d);
    struct compile_result res;
    if (!d) {
        log_error("job %s: out of memory to queue it again", row->id);
        return;
    }
    d->row = row;
    d->w.done = durable_compiled;
    d->w.suspend = durable_suspend;
    d->w.client = row->client;
    work_lock_take();
    durable_pending++;
    work_lock_give();
    enum work_submit s;
    while ((s = compile_scene(row->scene, row->scene_len, &d->w, &res)) == WORK_PARSE_FULL) {
        struct timespec ts = {0, 20 * 1000000L}; /* the pool is busy with the others */
        nanosleep(&ts, NULL);
    }
    if (s == WORK_CACHED)
        durable_compiled(&d->w, &res);
    else if (s != WORK_OK) {
        work_lock_take();
        durable_pending--;
        work_lock_give();
        free(d);
    }
}

/* A succeeded frame-range job whose frame files were lost (deleted, cut
 * short: store_load_frames found them not whole) is queued again, as a
 * one-image job's is (store_row): those frames render again and it ends
 * anew.  Frames evicted by --max-disk stay evicted. */
static void durable_frames_lost(struct store_job *row, const unsigned char *states) {
    if (row->state != JS_SUCCEEDED) return;
    for (long k = 0; k <= row->last - row->first; k++)
        if (states[k] == STORE_FRAME_QUEUED) {
            row->state = JS_QUEUED;
            return;
        }
}

static long durable_left(void) {
    work_lock_take();
    long n = durable_pending;
    work_lock_give();
    return n;
}

int durable_start(void) {
    if (!config.data_dir) return 0;
    struct store_job *rows = NULL;
    int n = 0;
    if (store_open(config.data_dir) || store_load(&rows, &n)) return -1;
    /* the frames' states read before anything starts: a jobs.db that
     * cannot be read stops the start before any job is put back */
    unsigned char **frame_states = calloc((size_t)n + 1, sizeof *frame_states);
    bool read = frame_states != NULL;
    for (int i = 0; read && i < n; i++)
        if (rows[i].frames &&
            (frame_states[i] = malloc((size_t)(rows[i].last - rows[i].first + 1))) &&
            store_load_frames(&rows[i], frame_states[i]) < 0)
            read = false;
    if (!read || store_start()) {
        for (int i = 0; frame_states && i < n; i++) free(frame_states[i]);
        free(frame_states);
        store_rows_free(rows, n);
        return -1;
    }
    long finished = 0, queued = 0;
    for (int i = 0; i < n; i++) {
        if (rows[i].frames) { /* a frame-range job: its frames parse as they are rendered */
            unsigned char *states = frame_states[i];
            bool ok = states != NULL;
            if (ok) durable_frames_lost(&rows[i], states);
            if (ok) durable_given_up(&rows[i]);
            ok = ok && shots_restore(&rows[i], states);
            if (!ok) log_error("job %s: cannot be put back (out of memory or room)", rows[i].id);
            free(states);
            if (rows[i].state == JS_QUEUED)
                queued += ok;
            else
                finished += ok;
        } else if (rows[i].state == JS_QUEUED) {
            durable_requeue(&rows[i]);
            queued++;
        } else {
            finished += jobs_restore(&rows[i], NULL);
        }
    }
    while (durable_left() > 0) {
        struct timespec ts = {0, 10 * 1000000L};
        nanosleep(&ts, NULL);
    }
    free(frame_states);
    store_rows_free(rows, n);
    if (n)
        log_info("--data-dir %s: %ld ended jobs kept, %ld queued again", config.data_dir, finished,
                 queued);
    return 0;
}

void durable_stop(void) { store_stop(); }
