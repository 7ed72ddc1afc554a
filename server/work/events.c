/* events.c -- a job's progress as a stream of events, read at the reader's
 * pace.
 *
 * An open stream is a cursor into its task's tiles in completion order
 * (task.order): each read hands out what happened since the last one -- the
 * job's state first, then one item per finished tile, then the final state
 * -- as plain records; the handler (api_jobs.c) writes them as Server-Sent
 * Events.  A progressive job's stream reports passes instead of tiles: one
 * item per complete pass, in pass order.  A cancelled or failed job's
 * stream, too, reports every tile (or pass) that was finished, then its
 * final state.  When there is nothing new, the reader's waiter is linked to
 * the task and its suspend() runs, both under the lock, so a tile finishing
 * in between cannot be missed; the worker that finishes the next tile
 * answers the waiter (done), and the reader reads again.  An idle stream
 * therefore costs no thread and no polling.  The watcher wakes idle streams
 * every EVENTS_PING_SECONDS seconds so they can send a keep-alive through
 * proxies.
 */
#include "work/work_private.h"

#include <stdlib.h>

struct events_stream {
    struct job *job; /* one reference */
    int cursor;      /* tiles (passes, if progressive) already reported */
    bool started, sent_done;
    double last_write; /* for the keep-alive */
};

struct events_stream *events_open(const char *id) {
    struct events_stream *s = calloc(1, sizeof *s);
    if (!s) return NULL;
    work_lock_take();
    struct job *j = jobs_find(id);
    if (j) {
        j->refs++;
        s->job = j;
    }
    work_lock_give();
    if (!j) {
        free(s);
        return NULL;
    }
    return s;
}

/* The news since the last read, lock held: how many items were written. */
static int events_news(struct events_stream *s, struct events_item *it, int n,
                       struct rayd_error *err) {
    work_assert_locked();
    struct job *j = s->job;
    const struct task *t = j->task;
    int k = 0;
    if (!s->started && k < n) {
        it[k++] = (struct events_item){.kind = EVENTS_STATE, .state = jobs_state(j)};
        s->started = true;
    }
    const struct passes *p = t->passes;
    while (p && s->cursor < p->done && k < n) {
        int c = s->cursor++;
        it[k++] = (struct events_item){.kind = EVENTS_PASS,
                                       .done = s->cursor,
                                       .total = p->n,
                                       .samples = p->samples[c],
                                       .time_s = p->time_s[c],
                                       .noise = p->noise[c],
                                       .progress = passes_progress(p, s->cursor, 0)};
    }
    while (!p && t->order && s->cursor < t->done && k < n) { /* none: restored (durable.c) */
        s->cursor++;
        it[k++] = (struct events_item){.kind = EVENTS_TILE,
                                       .tile = task_tile(t, t->order[s->cursor - 1]),
                                       .done = s->cursor,
                                       .total = t->ntiles,
                                       .progress = (double)s->cursor / t->ntiles};
    }
    enum jobs_state st = jobs_state(j);
    bool final = st == JS_SUCCEEDED || st == JS_FAILED || st == JS_CANCELED || st == JS_EVICTED;
    /* canceled by the drain with --data-dir: queued on disk, no end (jobs.c) */
    bool drained = st == JS_CANCELED && !j->canceled && task_draining() && store_on();
    if (k == 0 && final && !s->sent_done) {
        it[k++] = (struct events_item){.kind = drained ? EVENTS_DRAIN : EVENTS_DONE,
                                       .state = st,
                                       .samples = p && p->done ? p->samples[p->done - 1] : 0,
                                       .progress = jobs_progress(j)};
        if (st == JS_FAILED && err) *err = t->err;
        s->sent_done = true;
    }
    double now = clock_now();
    if (k == 0 && !final && s->last_write > 0 && now - s->last_write >= EVENTS_PING_SECONDS)
        it[k++] = (struct events_item){.kind = EVENTS_PING};
    if (k > 0) s->last_write = now;
    return k;
}

int events_read(struct events_stream *s, struct events_item *items, int n, struct rayd_error *err,
                struct work_waiter *w) {
    work_lock_take();
    int k = events_news(s, items, n, err);
    if (k == 0 && s->sent_done) {
        k = -1;
    } else if (k == 0) {
        task_wait_news(s->job->task, w);
    }
    work_lock_give();
    return k;
}

void events_close(struct events_stream *s) {
    if (!s) return;
    work_lock_take();
    jobs_unref(s->job);
    work_lock_give();
    free(s);
}
