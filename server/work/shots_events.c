/* shots_events.c -- what a client follows of a frame-range job: its event
 * stream (its state, one "frame" event a frame as each ends, done or
 * failed, in that order, then "done"; keep-alives between, as events.c's
 * streams of single jobs), and its video, made again when asked for after
 * the budget let it go or a restart (shots_video).  A reader with nothing
 * new waits on the shot (its sse list), woken when a frame ends (shots.c)
 * or by the watcher for a keep-alive.
 */
#include "work/shots_private.h"

struct shot *shots_open(const char *id) {
    work_lock_take();
    struct shot *s = shots_find(id);
    if (s) s->refs++;
    work_lock_give();
    return s;
}

void shots_close(struct shot *s) {
    if (!s) return;
    work_lock_take();
    shots_unref(s);
    work_lock_give();
}

int shots_events_read(struct shot *s, struct shots_cursor *c, struct events_item *it, int n,
                      struct rayd_error *err, struct work_waiter *w) {
    work_lock_take();
    int k = 0;
    if (!c->started && k < n) {
        it[k++] = (struct events_item){.kind = EVENTS_STATE, .state = shots_state(s)};
        c->started = true;
    }
    while (c->cursor < s->norder && k < n) {
        int i = s->order[c->cursor++];
        bool failed = s->f[i].state == SF_FAILED;
        c->done += !failed;
        it[k++] = (struct events_item){.kind = EVENTS_FRAME,
                                       .frame = s->first + i,
                                       .frame_failed = failed,
                                       .done = c->done,
                                       .total = s->n};
    }
    bool final = shots_final(s) && s->flying == 0;
    /* the drain starts no frame and waits for those in flight: then the
     * stream ends (a reader left suspended held the stop up 8 s, and rayd
     * exited 1 without its clean-up); with --data-dir the job goes on
     * after the restart, without it the job ends with the server */
    bool drained = !final && task_draining() && s->flying == 0;
    double now = clock_now();
    if (k == 0 && !final && c->last_write > 0 && now - c->last_write >= EVENTS_PING_SECONDS)
        it[k++] = (struct events_item){.kind = EVENTS_PING}; /* as events.c's streams */
    if (k == 0 && drained && !c->sent_done) {
        it[k++] = (struct events_item){.kind = store_on() ? EVENTS_DRAIN : EVENTS_DONE,
                                       .state = store_on() ? JS_QUEUED : JS_CANCELED,
                                       .progress = (double)s->ndone / s->n};
        c->sent_done = true;
    }
    if (k == 0 && final && !c->sent_done) {
        enum jobs_state st = shots_state(s);
        it[k++] = (struct events_item){
            .kind = EVENTS_DONE, .state = st, .progress = (double)s->ndone / s->n};
        if (st == JS_FAILED && err) shots_error(s, err);
        c->sent_done = true;
    }
    if (k > 0) c->last_write = now;
    if (k == 0 && c->sent_done) {
        k = -1;
    } else if (k == 0) {
        w->suspend(w);
        w->next = s->sse;
        s->sse = w;
    }
    work_lock_give();
    return k;
}

struct blob *shots_video(const char *id, struct shots_info *info) {
    work_lock_take();
    struct shot *s = shots_find(id);
    struct blob *b = NULL;
    if (s && s->video_state == SV_NONE && s->ndone == s->n && store_on())
        shots_video_queue(s); /* let go for the memory budget: made again from the files */
    if (s) {
        shots_info_of(s, info);
        b = blob_ref(s->video);
        if (b) s->video_used = clock_now(); /* the budget lets go of the least used first */
    }
    work_lock_give();
    if (!s) info->job.id[0] = 0;
    return b;
}
