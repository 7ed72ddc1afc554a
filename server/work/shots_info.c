/* shots_info.c -- what a frame-range job's status says: its numbers as the
 * routes read them (struct shots_info, the same shape as a single job's
 * struct jobs_info), and the message of its error, naming the frames that
 * failed, and its record for the store (--data-dir).  Readers only: the
 * shot is shots.c's, and the lock is held.
 */
#include "work/shots_private.h"

#include <stdio.h>
#include <string.h>

/* The failed frames named in err's message: "frames 3, 4 failed after 3
 * attempts: ..." (lock held). */
void shots_error(const struct shot *s, struct rayd_error *err) {
    *err = s->err;
    if (s->err_whole) return; /* as it was recorded, frames and attempts named */
    char list[200];
    size_t used = 0;
    int named = 0;
    list[0] = 0;
    for (int i = 0; i < s->n && named < 10; i++)
        if (s->f[i].state == SF_FAILED) {
            int k =
                snprintf(list + used, sizeof list - used, "%s%ld", named ? ", " : "", s->first + i);
            if (k > 0 && (size_t)k < sizeof list - used) used += (size_t)k;
            named++;
        }
    char head[256];
    int tries = s->err_tries ? s->err_tries : SHOTS_TRIES;
    snprintf(head, sizeof head, "frame%s %s failed after %d attempt%s: ", s->nfailed > 1 ? "s" : "",
             list, tries, tries > 1 ? "s" : "");
    size_t h = strlen(head);
    memcpy(err->message, head, h < sizeof err->message ? h : sizeof err->message - 1);
    snprintf(err->message + h, sizeof err->message - h, "%s", s->err.message);
}

/* s's numbers (lock held). */
void shots_info_of(const struct shot *s, struct shots_info *o) {
    memset(o, 0, sizeof *o);
    struct jobs_info *j = &o->job;
    double now = clock_now();
    j->state = shots_state(s);
    j->progress = (double)s->ndone / s->n;
    j->tiles_done = s->ndone;
    j->tiles_total = s->n;
    j->region = s->reg;
    snprintf(j->scene_id, sizeof j->scene_id, "%s", s->scene_id);
    j->created_age = now - s->created;
    j->rays = s->rays;
    j->est_rays = s->est_rays;
    j->queue_ms = s->first_start > 0 || s->queue_ms > 0 ? s->queue_ms : (now - s->created) * 1e3;
    j->render_ms = s->render_ms;
    j->encode_ms = s->encode_ms;
    j->keep_exr = s->keep_exr;
    j->denoise = s->denoise;
    j->aov = s->aov;
    j->ended_age = shots_final(s) && s->flying == 0 ? now - shots_ended(s) : -1;
    if (j->state == JS_FAILED) shots_error(s, &j->err);
    snprintf(j->id, sizeof j->id, "%s", s->id);
    j->priority = s->priority;
    j->seq = s->seq;
    j->created_wall = s->created_wall;
    o->first = s->first;
    o->last = s->last;
    o->total = s->n;
    o->done = s->ndone;
    o->failed = s->nfailed;
    for (const struct shots_fly *fl = s->flies; fl; fl = fl->next)
        o->running += fl->t && fl->t->t_start > 0; /* a tile of it started */
    /* none once it ended (as in cluster mode): a cancelled or failed job starts no more */
    o->queued = shots_final(s) ? 0 : s->n - s->ndone - s->nfailed - o->running;
    o->latest = s->latest >= 0 ? s->first + s->latest : -1;
    o->fps = s->fps;
    o->eta_s = -1;
    if (j->state == JS_SUCCEEDED) {
        o->eta_s = 0;
    } else if (!shots_final(s) && s->ndone > 0) {
        double per = (now - s->created) / s->ndone; /* from the frames done so far */
        o->eta_s = per * (s->n - s->ndone);
    }
    o->video = s->video_state;
    snprintf(o->video_error, sizeof o->video_error, "%s", s->video_error);
}

/* s's record for the store (lock held). */
void shots_record(const struct shot *s, struct store_job *row) {
    memset(row, 0, sizeof *row);
    snprintf(row->id, sizeof row->id, "%s", s->id);
    row->seq = s->seq;
    row->client = s->client;
    row->priority = s->priority;
    row->created_wall = s->created_wall;
    row->state = shots_state(s);
    snprintf(row->scene_id, sizeof row->scene_id, "%s", s->scene_id);
    row->reg = s->reg;
    row->keep_exr = s->keep_exr;
    row->denoise = s->denoise;
    row->aov = s->aov;
    row->tiles = s->ndone;
    row->rays = s->rays;
    row->est_rays = s->est_rays;
    row->queue_ms = s->queue_ms;
    row->render_ms = s->render_ms;
    row->encode_ms = s->encode_ms;
    row->frames = true;
    row->first = s->first;
    row->last = s->last;
    row->fps = s->fps;
    if (row->state == JS_FAILED) shots_error(s, &row->err);
    if (shots_final(s)) row->ended_wall = s->created_wall + (shots_ended(s) - s->created);
}
