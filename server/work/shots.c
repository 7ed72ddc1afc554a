/* shots.c -- frame-range jobs: POST /v1/jobs of an animated scene renders
 * frames A..B, each frame a render of its own.
 *
 * A shot keeps the scene as sent and, per frame, its state and images.
 * Frames go through the ordinary machinery one at a time: the scene is
 * parsed at that frame (compile_scene_frame, on the parse threads: frame k
 * is a scene of its own in the cache), then rendered as a plain task of the
 * job's client and priority, so every frame is fair-shared tile by tile
 * with everything else exactly as a single job is (fair.c chooses the
 * client, task_pick the client's task).  At most as many frames as there
 * are workers are in flight at once (parsing or rendering): enough to keep
 * the pool busy on small frames, few enough that the frames' scenes and
 * pixels stay bounded whatever the range.
 *
 * Frame k's image is the task's PNG (and EXR, ?format=exr), the same bytes
 * POST /v1/render of the scene at frame k gives, and rayd-render --frame K.
 * A frame that fails is tried again, SHOTS_TRIES attempts in all; a frame
 * out of attempts stops the shot (no new frame starts) and the job fails
 * naming it once the frames in flight are done.  A failure that would be
 * the same at every attempt -- the scene invalid at that frame (a keyframed
 * value out of range), or the frame alone over the memory budget -- fails
 * it at once.  A render cancelled by the drain is not a failure: the frame
 * is queued again (and, with --data-dir, rendered after the restart).  Nor
 * is a frame refused for room (the queue, the memory budget): it waits,
 * queued as it was, and the watcher starts the shot again a second later
 * (shots_kick), whether or not another of its frames is still in flight
 * to do it.
 *
 * Nothing here blocks: the parse threads call shots_parsed, the workers
 * shots_rendered (both with no lock held), and each starts the next
 * frames.  The table and every shot's numbers are under work_lock; a shot
 * is held by the table, each frame in flight and each open event stream.
 */
#include "work/shots_private.h"

#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <time.h>

static const char *const shots_gone_why[] = {
    "",
    "the frame's image was let go to keep rayd within its memory budget (--max-memory; the "
    "oldest finished frames go first): render it again",
    "the frame's image was evicted from disk (--max-disk; the oldest finished results go "
    "first): render it again"};

static struct shot **shots_table;
static int shots_n;

static double shots_wall_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

/* Lets go of the scene s keeps for its next frame (lock held). */
static void shots_drop_kept(struct shot *s) {
    work_assert_locked();
    cache_release(s->kept);
    s->kept = NULL;
}

static void shots_free(struct shot *s) {
    shots_drop_kept(s);
    for (int i = 0; i < s->n; i++) {
        blob_unref(s->f[i].png);
        blob_unref(s->f[i].exr);
    }
    blob_unref(s->video);
    free(s->f);
    free(s->order);
    free(s->text);
    mem_release(MEM_FRAMES, s->held);
    free(s);
}

/* An ended shot's scene text, which no frame parses again, let go (lock
 * held): only its frames and video stay.  Not while a frame's parse may
 * still read it (flying). */
static void shots_drop_text(struct shot *s) {
    work_assert_locked();
    if (!s->text || !shots_final(s) || s->flying) return;
    free(s->text);
    s->text = NULL;
    mem_release(MEM_FRAMES, s->len + 1);
    s->held -= s->len + 1;
}

/* Lock held. */
void shots_unref(struct shot *s) {
    work_assert_locked();
    if (--s->refs == 0) shots_free(s);
}

/* Forgets the shot at i of the table, which ended (lock held). */
static void shots_forget(int i) {
    struct shot *s = shots_table[i];
    if (store_on()) store_forget(s->id);
    shots_table[i] = shots_table[--shots_n];
    shots_unref(s);
}

/* Forgets the shots that ended more than --job-ttl seconds ago; lock held. */
static void shots_expire(double now) {
    for (int i = 0; i < shots_n;) {
        struct shot *s = shots_table[i];
        if (shots_final(s) && s->flying == 0 && now - shots_ended(s) > (double)config.job_ttl)
            shots_forget(i);
        else
            i++;
    }
}

/* Room in a full table (lock held), as jobs_evict: client's oldest ended shot, else anyone's. */
static bool shots_evict_ended(uint64_t client) {
    int victim = -1;
    for (int pass = 0; pass < 2 && victim < 0; pass++)
        for (int i = 0; i < shots_n; i++) {
            const struct shot *s = shots_table[i];
            if (shots_final(s) && s->flying == 0 && (pass || s->client == client) &&
                (victim < 0 || shots_ended(s) < shots_ended(shots_table[victim])))
                victim = i;
        }
    if (victim < 0) return false;
    shots_forget(victim);
    return true;
}

struct shot *shots_find(const char *id) {
    work_assert_locked();
    shots_expire(clock_now());
    for (int i = 0; i < shots_n; i++)
        if (!strcmp(shots_table[i]->id, id)) return shots_table[i];
    return NULL;
}

/* The shots not finished (they count against --max-jobs with the jobs). */
static long shots_unfinished(void) {
    work_assert_locked();
    long n = 0;
    for (int i = 0; i < shots_n; i++) n += !shots_final(shots_table[i]);
    return n;
}

/* Those of client. */
static long shots_unfinished_of(uint64_t client) {
    work_assert_locked();
    long n = 0;
    for (int i = 0; i < shots_n; i++)
        n += !shots_final(shots_table[i]) && shots_table[i]->client == client;
    return n;
}

/* ---- the store (--data-dir) ------------------------------------------------------ */

/* s ended: its end recorded once (lock held), w (NULL: none) told once it
 * is on disk; true when it will be. */
static bool shots_record_end(struct shot *s, struct work_waiter *w) {
    if (!store_on() || s->recorded) return false;
    struct store_job row;
    shots_record(s, &row);
    s->recorded = true;
    return store_end(&row, NULL, NULL, w);
}

/* ---- one frame's attempt ------------------------------------------------------ */

static void shots_pump(struct shot *s);
static void shots_suspend_none(struct compile_waiter *w) { (void)w; }

/* How an attempt that made no image counts. */
enum shots_miss {
    SM_TRY,   /* a failure: the frame is tried again while it has attempts left */
    SM_ROOM,  /* refused for room: queued again as it was, for shots_kick */
    SM_KEPT,  /* its parse found no room while the shot kept a scene: at once, without it */
    SM_NEVER, /* the same at every attempt: the frame fails now */
};

/* The attempt fl of a frame is over (no lock held): its images kept, or
 * the frame queued again (a drain, a refusal for room, or a failure with
 * attempts left), or failed for good.  The streams are told, and, pump,
 * the next frames started: always but where shots_pump's own loop goes on
 * (the attempt ended within it, fl->sync). */
static void shots_frame_end(struct shots_fly *fl, enum rayd_status st, const struct rayd_error *err,
                            struct blob *png, struct blob *exr, bool drained, enum shots_miss miss,
                            bool pump) {
    struct shot *s = fl->s;
    struct task_notify sse = {0};
    work_lock_take();
    struct shot_frame *f = &s->f[fl->i];
    s->flying--;
    for (struct shots_fly **p = &s->flies; *p; p = &(*p)->next)
        if (*p == fl) {
            *p = fl->next;
            break;
        }
    if (st == RAYD_OK && png) {
        f->state = SF_DONE;
        f->png = png;
        f->exr = exr;
        png = exr = NULL;
        blob_kind(f->png, MEM_FRAMES);
        if (f->exr) blob_kind(f->exr, MEM_FRAMES);
        s->ndone++;
        s->latest = fl->i;
        s->order[s->norder++] = fl->i;
        if (store_on()) {
            struct store_job row;
            shots_record(s, &row);
            store_frame(&row, s->first + fl->i, f->png, f->exr);
        }
        if (s->ndone == s->n) shots_video_queue(s);
    } else if (drained || s->canceled || (st == RAYD_E_CANCELED && task_draining())) {
        f->state = SF_QUEUED;
    } else if (miss == SM_KEPT) {
        /* the scene kept for this parse held the room: let go, it is back,
         * and the frame starts again at once (decoding its images) */
        f->state = SF_QUEUED;
        shots_drop_kept(s);
    } else if (miss == SM_ROOM) {
        f->state = SF_QUEUED;
        s->waiting = true;
        shots_drop_kept(s); /* no scene pinned while the frame waits */
        log_info("job %s: frame %ld waits (%s)", s->id, s->first + fl->i, err ? err->message : "?");
    } else if (miss == SM_TRY && ++f->tries < SHOTS_TRIES) {
        f->state = SF_QUEUED;
        log_warn("job %s: frame %ld failed (%s), trying again", s->id, s->first + fl->i,
                 err ? err->message : "?");
    } else {
        if (miss == SM_NEVER) f->tries++;
        f->state = SF_FAILED;
        s->nfailed++;
        s->order[s->norder++] = fl->i;
        if (!s->err.code && err) s->err = *err;
        if (!s->err.code) s->err.code = st != RAYD_OK ? st : RAYD_E_INTERNAL;
        if (!s->err_tries) s->err_tries = f->tries;
        log_warn("job %s: frame %ld failed after %d attempt%s, and the job with it (%s%s%s)", s->id,
                 s->first + fl->i, f->tries, f->tries == 1 ? "" : "s",
                 err && err->path[0] ? err->path : "", err && err->path[0] ? ": " : "",
                 err ? err->message : "?");
    }
    bool ended = shots_final(s) && s->t_end == 0;
    if (ended) s->t_end = clock_now();
    if (shots_final(s)) shots_drop_kept(s);
    /* a drain's cancel is no end: the job stays queued on disk */
    if (shots_final(s) && s->flying == 0 && !(drained && !s->canceled)) {
        shots_record_end(s, NULL);
        shots_drop_text(s);
    }
    task_notify_add(&sse, &s->sse);
    work_lock_give();
    blob_unref(png);
    blob_unref(exr);
    task_notify_run(&sse);
    if (pump) shots_pump(s);
    work_lock_take();
    shots_unref(s);
    work_lock_give();
    free(fl);
}

static void shots_noop(struct work_waiter *w) { (void)w; }

/* Frame render t's rays and times added to s's, lock held: the job waited
 * until its first frame began, and rendered and encoded for the sum of its
 * frames' times (a single job's three figures, frame by frame). */
static void shots_times(struct shot *s, const struct task *t) {
    double queue_ms, render_ms;
    task_times(t, clock_now(), &queue_ms, &render_ms);
    s->rays += t->rays;
    s->render_ms += render_ms;
    s->encode_ms += t->encode_s * 1e3;
    if (t->t_start > 0 && (s->first_start == 0 || t->t_start < s->first_start)) {
        s->first_start = t->t_start;
        s->queue_ms = (t->t_start - s->created) * 1e3;
    }
}

/* A worker finished the frame's render (no lock held). */
static void shots_rendered(struct work_waiter *w, struct work_result *res) {
    struct shots_fly *fl = (struct shots_fly *)((char *)w - offsetof(struct shots_fly, ww));
    work_lock_take();
    struct task *t = fl->t;
    struct blob *exr = res->status == RAYD_OK ? blob_ref(t->exr) : NULL;
    shots_times(fl->s, t);
    if (!fl->dropped) task_job_drop(t);
    task_unref(t);
    fl->t = NULL; /* the readers of s->flies must not see it again */
    work_lock_give();
    shots_frame_end(fl, res->status, &res->err, res->png, exr, res->draining, SM_TRY, true);
}

/* The frame's refusal as an error naming why. */
static void shots_refusal(enum work_submit why, struct rayd_error *err) {
    memset(err, 0, sizeof *err);
    err->code = why == WORK_TOO_BIG ? RAYD_E_LIMIT : RAYD_E_NOMEM;
    snprintf(err->message, sizeof err->message, "the frame's render was refused: %s",
             why == WORK_TOO_BIG  ? "it alone is over the memory budget (--max-memory)"
             : why == WORK_MEMORY ? "no room in the memory budget now (--max-memory)"
             : why == WORK_FULL || why == WORK_FULL_SHARE ? "the render queue is full (--queue)"
             : why == WORK_PARSE_FULL ? "the scene parse queue is full (--parse-queue)"
                                      : "out of memory");
}

/* Whether frame fl, refused for room, can never have it while its job's
 * finished frames stay in memory (they are not evicted before the job
 * ends): with them and the need bytes it is over the budget.  Waiting
 * would never end; err then says why.  No lock held. */
static bool shots_never_room(const struct shots_fly *fl, size_t need, struct rayd_error *err) {
    if (store_on()) return false; /* with --data-dir its frames leave memory once written */
    size_t own = 0;
    work_lock_take();
    const struct shot *s = fl->s;
    for (int i = 0; i < s->n; i++)
        own += (s->f[i].png ? s->f[i].png->len : 0) + (s->f[i].exr ? s->f[i].exr->len : 0);
    work_lock_give();
    if (own + need <= mem_limit()) return false;
    snprintf(err->message, sizeof err->message,
             "the job's finished frames hold %zu bytes of the memory budget of %zu bytes "
             "(--max-memory) and frame %ld needs %zu more: run rayd with --data-dir (frames "
             "kept on disk) or render fewer frames a job",
             own, mem_limit(), s->first + fl->i, need);
    return true;
}

/* The frame's scene is compiled: its render submitted (no lock held). */
static void shots_render(struct shots_fly *fl, struct cache_entry *scene) {
    struct shot *s = fl->s;
    struct work_target what = {.reg = s->reg,
                               .format = WORK_PNG,
                               .keep_exr = s->keep_exr,
                               .aov = s->aov,
                               .denoise = s->denoise,
                               .client = s->client};
    enum work_submit r = WORK_OK;
    struct task *fresh = budget_task(scene, &what, false, &r);
    if (fresh) task_admitted(fresh, s->priority);
    work_lock_take();
    struct task *t = NULL;
    if (fresh) r = s->canceled ? WORK_DRAINING : task_submit(scene, &fresh, &t);
    if (r == WORK_OK) {
        fl->t = t;
        task_job_ref(t);
        s->f[fl->i].state = SF_RUNNING;
        fl->ww.done = shots_rendered;
        fl->ww.suspend = shots_noop;
        fl->ww.fd = -1;
        task_wait(t, &fl->ww);
    }
    work_lock_give();
    if (fresh) task_unref(fresh);
    if (r == WORK_OK) return;
    struct rayd_error err;
    shots_refusal(r, &err);
    bool never =
        r == WORK_TOO_BIG ||
        (r == WORK_MEMORY &&
         shots_never_room(fl, budget_need(scene, &what, false) + cache_bytes(scene), &err));
    shots_frame_end(fl, err.code, &err, NULL, NULL, r == WORK_DRAINING, never ? SM_NEVER : SM_ROOM,
                    !fl->sync);
}

/* Whether the memory budget has room now for another scene as big as e:
 * only then is e kept for the next frame's parse, which counts its shared
 * images again.  Under a budget with room for one frame's scene at a time
 * a kept scene would only make each frame wait for it.  No lock held. */
static bool shots_room_for_another(const struct cache_entry *e) {
    size_t used = 0;
    for (int k = 0; k < MEM__COUNT; k++) used += mem_used((enum mem_kind)k);
    return used + cache_bytes(e) <= mem_limit();
}

/* What a frame's parse that found no room in the budget (res) does: when
 * its shot keeps a scene for it, the frame starts again at once without it
 * (SM_KEPT); when the job's finished frames (which stay) and a scene as big
 * as its last are over the budget, it fails, naming them (SM_NEVER: waiting
 * would never end); else it waits for the room without spending an
 * attempt, as a render refused for room does (SM_ROOM).  Another out of
 * memory is an attempt (SM_TRY). */
static enum shots_miss shots_parse_miss(struct shots_fly *fl, struct compile_result *res) {
    struct shot *s = fl->s;
    work_lock_take();
    bool kept = s->kept != NULL;
    size_t need = s->scene_bytes;
    work_lock_give();
    if (!res->memory_full) return SM_TRY;
    if (kept) return SM_KEPT;
    return shots_never_room(fl, need, &res->err) ? SM_NEVER : SM_ROOM;
}

/* The parse threads' answer (no lock held).  A scene that does not parse
 * at this frame will not at the next attempt either; only running out of
 * memory may pass. */
static void shots_parsed(struct compile_waiter *w, struct compile_result *res) {
    struct shots_fly *fl = (struct shots_fly *)w;
    if (res->status != RAYD_OK || !res->scene) {
        enum shots_miss miss = res->status != RAYD_E_NOMEM ? SM_NEVER : shots_parse_miss(fl, res);
        shots_frame_end(fl, res->status ? res->status : RAYD_E_INTERNAL, &res->err, NULL, NULL,
                        res->draining, miss, !fl->sync);
        return;
    }
    bool roomy = shots_room_for_another(res->scene);
    work_lock_take(); /* kept for the next frame's parse, in place of the one before */
    struct shot *s = fl->s;
    s->scene_bytes = cache_bytes(res->scene);
    shots_drop_kept(s);
    if (!shots_final(s) && roomy) s->kept = cache_ref(res->scene);
    work_lock_give();
    shots_render(fl, res->scene);
    scenes_release(res->scene);
}

/* How many frames of a shot may be in flight: the workers'. */
static int shots_width(void) {
    struct sched_stats st;
    sched_stats(&st);
    return st.workers > 1 ? (int)st.workers : 1;
}

/* Starts s's next frames while fewer than shots_width are in flight (no
 * lock held); stops at a failed frame, a cancel, a drain or a refusal for
 * room (shots_kick goes on from there). */
static void shots_pump(struct shot *s) {
    int width = shots_width();
    for (;;) {
        int i = -1;
        work_lock_take();
        if (!s->canceled && !s->nfailed && !s->waiting && !task_draining() && s->flying < width)
            for (int k = 0; k < s->n && i < 0; k++)
                if (s->f[k].state == SF_QUEUED) i = k;
        struct shots_fly *fl = i >= 0 ? calloc(1, sizeof *fl) : NULL;
        if (fl) {
            s->f[i].state = SF_PARSING;
            s->flying++;
            s->refs++;
            fl->next = s->flies;
            s->flies = fl;
        }
        work_lock_give();
        if (!fl) return;
        fl->s = s;
        fl->i = i;
        fl->cw.done = shots_parsed;
        fl->cw.suspend = shots_suspend_none;
        fl->cw.client = s->client;
        struct compile_result res;
        enum work_submit r = compile_scene_frame(s->text, s->len, s->first + i, &fl->cw, &res);
        if (r == WORK_CACHED) {
            fl->sync = true; /* the parse threads never had it */
            shots_parsed(&fl->cw, &res);
        } else if (r != WORK_OK) {
            struct rayd_error err;
            shots_refusal(r, &err);
            shots_frame_end(fl, err.code, &err, NULL, NULL, r == WORK_DRAINING, SM_ROOM, false);
            return;
        }
    }
}

/* SHOTS_KICK_MAX shots at most a kick; the others wait for the next. */
#define SHOTS_KICK_MAX 64

/* The watcher's, once a second (no lock held): the shots whose frames
 * were refused for room start again. */
static void shots_kick(void) {
    struct shot *kick[SHOTS_KICK_MAX];
    int n = 0;
    work_lock_take();
    for (int i = 0; i < shots_n && n < SHOTS_KICK_MAX; i++) {
        struct shot *s = shots_table[i];
        if (!s->waiting) continue;
        s->waiting = false;
        if (shots_final(s)) continue;
        s->refs++;
        kick[n++] = s;
    }
    work_lock_give();
    for (int i = 0; i < n; i++) shots_pump(kick[i]);
    work_lock_take();
    for (int i = 0; i < n; i++) shots_unref(kick[i]);
    work_lock_give();
}

/* ---- letting go of frames: the memory budget, --data-dir, --max-disk ------------ */

/* Whether s keeps what the memory budget may let go (lock held): a frame's
 * image, but none with --data-dir (a frame there is in memory only until
 * the store wrote it, and the write holds it too: letting go would free
 * nothing), or its video. */
static bool shots_keeps(const struct shot *s) {
    for (int i = 0; i < s->n && !store_on(); i++)
        if (s->f[i].png || s->f[i].exr) return true;
    return s->video != NULL;
}

/* Frame i's images let go (lock held); gone: why they answer 410 now. */
static void shots_let_go(struct shot *s, int i, enum shots_gone gone) {
    blob_unref(s->f[i].png);
    blob_unref(s->f[i].exr);
    s->f[i].png = s->f[i].exr = NULL;
    if (gone) s->f[i].gone = (unsigned char)gone;
}

/* s's video let go for the memory budget (lock held): made again from the
 * frames' files when asked for (--data-dir, every frame on disk), else gone
 * for good (410). */
static void shots_let_go_video(struct shot *s) {
    bool files = store_on();
    for (int i = 0; i < s->n && files; i++) files = s->f[i].on_disk;
    blob_unref(s->video);
    s->video = NULL;
    s->video_state = files ? SV_NONE : SV_EVICTED;
    snprintf(s->video_error, sizeof s->video_error, "%s",
             files ? ""
                   : "the video was let go to keep rayd within its memory budget "
                     "(--max-memory); render the range again");
    log_info("job %s: video evicted (over --max-memory)", s->id);
}

/* When the budget may let go of what s keeps: the oldest first, by its end,
 * or by when its video was last made or asked for -- so a video made again
 * is not the next to go, made again, and so on. */
static double shots_kept_since(const struct shot *s) {
    return s->video && s->video_used > shots_ended(s) ? s->video_used : shots_ended(s);
}

/* Whether s is finished and keeps a frame or its video to let go of. */
static bool shots_let_goable(const struct shot *s) {
    return shots_final(s) && s->flying == 0 && shots_keeps(s);
}

/* The shot of an owner w allows that keeps what it may let go of longest. */
static struct shot *shots_oldest_kept(const struct jobs_whose *w) {
    work_assert_locked();
    struct shot *best = NULL;
    for (int i = 0; i < shots_n; i++) {
        struct shot *s = shots_table[i];
        if ((!best || shots_kept_since(s) < shots_kept_since(best)) && shots_let_goable(s) &&
            jobs_whose_may(w, s->client))
            best = s;
    }
    return best;
}

static double shots_oldest_end(const struct jobs_whose *w) {
    struct shot *s = shots_oldest_kept(w);
    return s ? shots_kept_since(s) : -1;
}

static void shots_each(void (*fn)(void *u, uint64_t owner, bool keeps, bool live), void *u) {
    for (int i = 0; i < shots_n; i++)
        fn(u, shots_table[i]->client, shots_let_goable(shots_table[i]),
           !shots_final(shots_table[i]));
}

static bool shots_evict_oldest(const struct jobs_whose *w) {
    struct shot *s = shots_oldest_kept(w);
    for (int c = 0; s && !store_on() && c < s->norder; c++) { /* its frames as they ended */
        int i = s->order[c];
        if (s->f[i].png || s->f[i].exr) {
            shots_let_go(s, i, SG_MEMORY);
            log_info("job %s: frame %ld evicted (over --max-memory)", s->id, s->first + i);
            return true;
        }
    }
    if (!s || !s->video) return false;
    shots_let_go_video(s);
    return true;
}

/* The store's hooks (store thread, no lock held): frame k of id is on
 * disk, its copy in memory goes; or --max-disk evicted it. */
static void shots_on_disk(const char *id, long k, const char *why) {
    work_lock_take();
    struct shot *s = NULL;
    for (int i = 0; i < shots_n && !s; i++)
        if (!strcmp(shots_table[i]->id, id)) s = shots_table[i];
    if (s && k >= s->first && k <= s->last && s->f[k - s->first].state == SF_DONE) {
        s->f[k - s->first].on_disk = !why;
        s->f[k - s->first].gone = why ? SG_DISK : SG_KEPT;
        shots_let_go(s, (int)(k - s->first), SG_KEPT);
    }
    work_lock_give();
}

static void shots_written(const char *id, long k) { shots_on_disk(id, k, NULL); }

static void shots_disk_evicted(const char *id, long k, const char *why) {
    shots_on_disk(id, k, why);
}

/* ---- the table ------------------------------------------------------------------ */

/* The stop's wait for the video thread to let go of its videos (ffmpeg
 * killed: milliseconds). */
#define SHOTS_VIDEO_STOP_SECONDS 2.0

static struct work_waiter **shots_streams(int i);
static bool shots_unwait(struct work_waiter *w, struct task_notify *gone);

bool shots_start(int max_jobs) {
    static const struct jobs_shots hooks = {shots_oldest_end, shots_evict_oldest, shots_each,
                                            shots_unfinished, shots_unfinished_of};
    store_frame_hooks(shots_written, shots_disk_evicted);
    jobs_shots_hooks(&hooks);
    watch_streams_hooks(shots_streams, shots_unwait, shots_kick);
    int swept = video_sweep();
    if (swept > 0) log_info("removed %d video folders that stopped servers left", swept);
    shots_table = calloc((size_t)max_jobs, sizeof *shots_table);
    return shots_table != NULL;
}

void shots_stop(void) {
    videoq_stop(SHOTS_VIDEO_STOP_SECONDS);
    work_lock_take();
    for (int i = 0; i < shots_n; i++) shots_unref(shots_table[i]);
    shots_n = 0;
    work_lock_give();
    free(shots_table);
    shots_table = NULL;
}

/* What a shot of n keeps until it ends, beside its frames' images: the
 * scene's text, for its frames' parses (up to --max-body: a tiny animated
 * scene padded to that size is a job).  Counted in --max-memory: 300 jobs
 * of a 4 MB body held 1.2 GB under a budget of 512 MB, and every one of
 * them had finished at once.  Its tables, a few dozen bytes a frame, are
 * held to --max-frames instead. */
static size_t shots_bytes(const struct shots_new *n) { return n->len + 1; }

/* A new shot of n->first..n->last (lock held; the table has room), held
 * bytes of kind frames its own (released with it, or here on failure). */
static struct shot *shots_new(const struct shots_new *n, size_t held) {
    struct shot *s = calloc(1, sizeof *s);
    long count = n->last - n->first + 1;
    if (!s) {
        mem_release(MEM_FRAMES, held);
        return NULL;
    }
    s->held = held;
    s->f = calloc((size_t)count, sizeof *s->f);
    s->order = calloc((size_t)count, sizeof *s->order);
    s->text = malloc(n->len + 1);
    if (!s->f || !s->order || !s->text) {
        shots_free(s);
        return NULL;
    }
    memcpy(s->text, n->text, n->len);
    s->text[n->len] = 0;
    s->len = n->len;
    s->n = (int)count;
    s->first = n->first;
    s->last = n->last;
    s->fps = n->fps;
    s->reg = n->what.reg;
    s->keep_exr = n->what.keep_exr;
    s->denoise = n->what.denoise;
    s->aov = n->what.aov;
    s->client = n->what.client;
    s->priority = n->priority;
    s->est_rays = n->est_rays;
    s->latest = -1;
    snprintf(s->scene_id, sizeof s->scene_id, "%s", n->scene_id);
    s->created = clock_now();
    s->created_wall = shots_wall_now();
    s->refs = 1;
    return s;
}

enum work_submit shots_submit(struct shots_new *n, char id[33]) {
    n->waiting = false;
    uint8_t rnd[16];
    if (getrandom(rnd, sizeof rnd, 0) != (ssize_t)sizeof rnd) return WORK_NOMEM;
    for (int i = 0; i < 16; i++) snprintf(id + 2 * i, 3, "%02x", rnd[i]);
    bool roomy = n->scene && shots_room_for_another(n->scene);
    size_t held = shots_bytes(n);
    if (!budget_reserve(n->what.client, MEM_FRAMES, held)) {
        metrics_reject(MR_MEMORY);
        return WORK_MEMORY;
    }
    work_lock_take();
    enum work_submit r = WORK_OK;
    long unfinished, cap;
    shots_expire(clock_now());
    jobs_count(&unfinished, &cap); /* the shots' too */
    struct shot *s = NULL;
    if (task_draining())
        r = WORK_DRAINING;
    else if (!shots_table) /* shots_start not run (a harness of the handlers) */
        r = WORK_NOMEM;
    else if (unfinished >= cap ||
             (shots_n >= config.max_jobs && !shots_evict_ended(n->what.client)))
        r = WORK_TOO_MANY_JOBS;
    else if (jobs_over_share(n->what.client))
        r = WORK_JOBS_SHARE;
    else if (!(s = shots_new(n, held))) /* which let go of held */
        r = WORK_NOMEM, held = 0;
    if (!s) mem_release(MEM_FRAMES, held);
    if (s) {
        snprintf(s->id, sizeof s->id, "%s", id);
        s->seq = jobs_next_seq();
        shots_table[shots_n++] = s;
        s->refs++; /* the pump's, below */
        if (roomy) s->kept = cache_ref(n->scene);
        s->scene_bytes = n->scene ? cache_bytes(n->scene) : 0;
        struct store_job row;
        shots_record(s, &row);
        row.scene = store_on() ? malloc(n->len + 1) : NULL;
        if (row.scene) {
            memcpy(row.scene, n->text, n->len);
            row.scene[n->len] = 0;
            row.scene_len = n->len;
            n->waiting = store_insert(&row, n->w);
            free(row.scene);
        }
    }
    work_lock_give();
    if (!s) return r;
    shots_pump(s);
    work_lock_take();
    shots_unref(s);
    work_lock_give();
    return WORK_OK;
}

/* ---- start-up: a frame-range job of the store put back --------------------------- */

bool shots_restore(const struct store_job *row, const unsigned char *states) {
    struct shots_new n = {.text = row->scene,
                          .len = row->scene_len,
                          .what = {.reg = row->reg,
                                   .keep_exr = row->keep_exr,
                                   .aov = row->aov,
                                   .denoise = row->denoise,
                                   .client = row->client},
                          .priority = row->priority,
                          .first = row->first,
                          .last = row->last,
                          .fps = row->fps,
                          .est_rays = row->est_rays};
    snprintf(n.scene_id, sizeof n.scene_id, "%s", row->scene_id);
    work_lock_take();
    size_t held = shots_bytes(&n);
    bool room = shots_table && shots_n < config.max_jobs;
    if (room) mem_force(MEM_FRAMES, held); /* it was taken before the stop: it exists again */
    struct shot *s = room ? shots_new(&n, held) : NULL;
    if (s) {
        snprintf(s->id, sizeof s->id, "%s", row->id);
        s->seq = row->seq;
        jobs_seen_seq(row->seq);
        s->created_wall = row->created_wall;
        s->created = clock_now() - (shots_wall_now() - row->created_wall);
        s->rays = row->rays;
        s->queue_ms = row->queue_ms;
        if (row->queue_ms > 0) /* its first frame began before the restart: the wait stays */
            s->first_start = s->created + row->queue_ms / 1e3;
        s->render_ms = row->render_ms;
        s->encode_ms = row->encode_ms;
        for (int i = 0; i < s->n; i++)
            if (states[i] == STORE_FRAME_DONE || states[i] == STORE_FRAME_EVICTED) {
                s->f[i].state = SF_DONE;
                s->f[i].on_disk = states[i] == STORE_FRAME_DONE;
                s->f[i].gone = states[i] == STORE_FRAME_EVICTED ? SG_DISK : SG_KEPT;
                s->order[s->norder++] = i;
                s->ndone++;
                s->latest = i;
            }
        bool ended = row->state != JS_QUEUED;
        if (ended) {
            s->recorded = true;
            s->canceled = row->state == JS_CANCELED;
            s->t_end = s->canceled_at = clock_now() - (shots_wall_now() - row->ended_wall);
            if (row->state == JS_FAILED) { /* its failed frames are not known: the first left */
                s->err = row->err;
                s->err_whole = true;
                for (int i = 0; i < s->n && !s->nfailed; i++)
                    if (s->f[i].state != SF_DONE) {
                        s->f[i].state = SF_FAILED;
                        s->nfailed = 1;
                    }
            }
        }
        if (!ended && s->ndone == s->n)
            s->t_end = clock_now(); /* all done, its end not yet written */
        /* its video is not kept: made again from the frames' files when
         * asked for (shots_video), not at start-up, where 1024 kept jobs
         * would each run ffmpeg before a frame renders */
        shots_table[shots_n++] = s;
        s->refs++;
    }
    work_lock_give();
    if (!s) return false;
    if (row->state == JS_QUEUED) shots_pump(s);
    work_lock_take();
    if (row->state == JS_QUEUED && shots_final(s)) shots_record_end(s, NULL);
    shots_drop_text(s);
    shots_unref(s);
    work_lock_give();
    return true;
}

/* ---- what the handlers read ------------------------------------------------------- */

bool shots_get(const char *id, struct shots_info *info) {
    work_lock_take();
    struct shot *s = shots_find(id);
    if (s) shots_info_of(s, info);
    work_lock_give();
    return s != NULL;
}

int shots_list(uint64_t client, int state, long long before, struct shots_info *out, int n,
               bool *more) {
    *more = false;
    int got = 0;
    work_lock_take();
    shots_expire(clock_now());
    /* newest first: by creation number, descending (a few hundred at most) */
    long long below = before > 0 ? before : (long long)1 << 62;
    for (;;) {
        struct shot *best = NULL;
        for (int i = 0; i < shots_n; i++) {
            struct shot *s = shots_table[i];
            if (s->client == client && s->seq < below &&
                (state < 0 || shots_state(s) == (enum jobs_state)state) &&
                (!best || s->seq > best->seq))
                best = s;
        }
        if (!best) break;
        if (got == n) {
            *more = true;
            break;
        }
        shots_info_of(best, &out[got++]);
        below = best->seq;
    }
    work_lock_give();
    return got;
}

enum shots_frame_state shots_frame(const char *id, long k, bool exr, struct blob **img,
                                   struct shots_info *info) {
    *img = NULL;
    work_lock_take();
    struct shot *s = shots_find(id);
    enum shots_frame_state r = SHOTS_NO_JOB;
    bool disk = false;
    if (s) {
        shots_info_of(s, info);
        long i = k - s->first;
        if (k < s->first || k > s->last) {
            r = SHOTS_OUTSIDE;
        } else {
            static const enum shots_frame_state as[] = {SHOTS_QUEUED, SHOTS_QUEUED, SHOTS_RUNNING,
                                                        SHOTS_DONE, SHOTS_FAILED};
            r = as[s->f[i].state];
            if (r == SHOTS_DONE && s->f[i].gone) {
                r = SHOTS_EVICTED;
                info->evicted_why = shots_gone_why[s->f[i].gone];
            }
            /* an EXR the job does not keep is no file to read (the handler says 409) */
            disk = r == SHOTS_DONE && s->f[i].on_disk && (!exr || s->keep_exr);
            for (const struct shots_fly *fl = s->flies; fl && r == SHOTS_RUNNING; fl = fl->next)
                if (fl->i == i && !(fl->t && fl->t->t_start > 0))
                    r = SHOTS_QUEUED; /* no tile of it started yet */
            *img = blob_ref(exr ? s->f[i].exr : s->f[i].png);
        }
    }
    work_lock_give();
    if (disk) *img = store_read_frame(id, k, exr); /* a plain read: no lock */
    return r;
}

bool shots_cancel(const char *id, struct work_waiter *w, bool *waiting) {
    struct task_notify n = {0}, sse = {0};
    work_lock_take();
    struct shot *s = shots_find(id);
    if (s && !shots_final(s)) {
        s->canceled = true;
        s->canceled_at = clock_now();
        shots_drop_kept(s);
        for (struct shots_fly *fl = s->flies; fl; fl = fl->next) {
            struct task *t = fl->t;
            if (!t) compile_drop(&fl->cw); /* its frame still parsing, or queued to */
            if (!t || fl->dropped || t->finished) continue;
            task_job_drop(t);
            fl->dropped = true;
            bool others = false; /* a synchronous request waiting for the same render */
            for (struct work_waiter *o = t->waiters; o; o = o->next) others |= o != &fl->ww;
            if (t->njobs == 0 && !others) task_cancel(t, MC_DELETE, &n, &sse);
        }
        bool told = shots_record_end(s, w);
        if (waiting) *waiting = told;
        shots_drop_text(s);
        task_notify_add(&sse, &s->sse);
    }
    work_lock_give();
    task_notify_run(&n);
    task_notify_run(&sse);
    return s != NULL;
}

/* The watcher's (watch.c), lock held: the streams waiting on the i-th
 * shot (NULL past the last), to poll for a hang-up and wake for a
 * keep-alive; and w off whichever shot holds it, onto gone. */
static struct work_waiter **shots_streams(int i) {
    work_assert_locked();
    return i < shots_n ? &shots_table[i]->sse : NULL;
}

static bool shots_unwait(struct work_waiter *w, struct task_notify *gone) {
    work_assert_locked();
    for (int i = 0; i < shots_n; i++)
        for (struct work_waiter **pp = &shots_table[i]->sse; *pp; pp = &(*pp)->next)
            if (*pp == w) {
                *pp = w->next;
                w->next = gone->list;
                gone->list = w;
                return true;
            }
    return false;
}

/* ---- the video ------------------------------------------------------------------ */

/* Seconds ffmpeg may take for a video of n frames before it is stopped. */
#define SHOTS_VIDEO_SECONDS(n) (60.0 + 2.0 * (n))

/* s's frames (referenced, read from disk if need be), then the video made
 * without the lock and kept (on the video thread, videoq.c). */
static void shots_video_make(void *arg) {
    struct shot *s = arg;
    struct blob **frames = calloc((size_t)s->n, sizeof *frames);
    work_lock_take();
    for (int i = 0; frames && i < s->n; i++) frames[i] = blob_ref(s->f[i].png);
    work_lock_give();
    int missing = -1; /* the first frame not read */
    for (int i = 0; frames && i < s->n; i++) {
        if (!frames[i] && store_on()) frames[i] = store_read_frame(s->id, s->first + i, false);
        if (!frames[i] && missing < 0) missing = i;
    }
    bool whole = frames && missing < 0;
    struct blob *mp4 = NULL;
    char err[200] = "out of memory for the frames";
    if (frames && missing >= 0) /* its file gone from --data-dir, or no memory to read it */
        snprintf(err, sizeof err, "frame %ld could not be read back", s->first + missing);
    enum video_status st = whole ? video_encode(frames, s->n, s->fps > 0 ? s->fps : 24,
                                                SHOTS_VIDEO_SECONDS(s->n), &mp4, err, sizeof err)
                                 : VIDEO_FAILED;
    for (int i = 0; frames && i < s->n; i++) blob_unref(frames[i]);
    free(frames);
    work_lock_take();
    bool evicted = missing >= 0 && s->f[missing].gone != SG_KEPT;
    if (evicted)
        snprintf(err, sizeof err,
                 "frame %ld was let go before the video was made (%s); a video needs every frame: "
                 "render the range again",
                 s->first + missing, s->f[missing].gone == SG_DISK ? "--max-disk" : "--max-memory");
    s->video = mp4;
    s->video_used = clock_now();
    s->video_state = st == VIDEO_OK ? SV_READY : st == VIDEO_NO_FFMPEG ? SV_NO_FFMPEG : SV_FAILED;
    if (evicted) s->video_state = SV_EVICTED; /* never made: its frame is missing */
    snprintf(s->video_error, sizeof s->video_error, "%s", st == VIDEO_OK ? "" : err);
    if (st != VIDEO_OK) log_warn("job %s: no video: %s", s->id, err);
    shots_unref(s);
    work_lock_give();
}

/* s has every frame: its video queued for the video thread (lock held). */
void shots_video_queue(struct shot *s) {
    s->refs++; /* the video's, let go by shots_video_make */
    if (!videoq_add(shots_video_make, s)) {
        s->refs--;
        s->video_state = SV_FAILED;
        snprintf(s->video_error, sizeof s->video_error, "no thread or memory to make the video");
        return;
    }
    s->video_state = SV_MAKING;
}
