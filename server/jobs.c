/* jobs.c -- asynchronous renders: a table of jobs, each following a task.
 *
 * A job is a render nobody waits on: created at once with a random id, it
 * follows a task (possibly shared with synchronous requests and other jobs)
 * and outlives it, keeping the finished task -- its state, its timings, its
 * PNG -- for GET /v1/jobs/{id} and the image.  The table is bounded:
 * --max-jobs jobs at most, the job that ended first making room for a new
 * one, and the watcher (watch.c) forgets jobs that ended more than
 * --job-ttl seconds ago.  The TTL counts from the end (succeeded, failed or
 * cancelled), never from the POST: a render longer than the TTL must still
 * be there for the client that polls it when it ends.  Cancelling a job
 * (DELETE) cancels its task only when nobody else -- no other job, no
 * waiting connection -- still wants it.
 *
 * A forgotten job leaves a tombstone: its id, how and when it ended, why
 * and when it went, in a ring of the last JOBS_TOMBSTONES (a fixed array,
 * under 1 MB), so its routes answer 410 job_expired or job_evicted rather
 * than the 404 of an id that never was -- a client then knows it polled too
 * late, not that it has a wrong id.  Past the ring an old id is a 404
 * again; the ring only has to outlast a poller's interval.  A job whose
 * images were dropped by a memory budget (jobs_evict_result) stays in the
 * table with its numbers, and answers 410 result_evicted with the reason.
 *
 * All under work_lock; a job's memory is held by the table and by each open
 * event stream (events.c), so a stream outlives the job's eviction.
 *
 * The memory budget (--max-memory, mem.c) reclaims through here: when a
 * reservation does not fit, jobs_reclaim lets go of one thing at a time,
 * the cheapest first -- the result cache's least recently used PNG, a
 * compiled scene nobody renders, then the images of the finished job that
 * finished first.  Such a job keeps its numbers and says "evicted" (its
 * image answers 410 result_evicted), so a client knows to render again
 * rather than think its id wrong.
 */
#include "work_private.h"

#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <time.h>

static struct job **jobs_table;
static int jobs_n, jobs_max;

/* The ring of tombstones: the next slot to write, and how many are used. */
static struct jobs_tomb {
    char id[33];
    struct jobs_gone g;
} jobs_tombs[JOBS_TOMBSTONES];
static int jobs_tomb_next, jobs_tomb_n;

static long jobs_gauge(void)
{
    pthread_mutex_lock(&work_lock);
    long n = jobs_n;
    pthread_mutex_unlock(&work_lock);
    return n;
}

/* Drops the images (PNG, EXR) of j's task, which every job of that task
 * shared: from now on their image and status routes answer 410
 * result_evicted with why (copied; e.g. "over --max-memory").  The bytes
 * freed (blob lengths; a blob still referenced elsewhere, by a response in
 * flight or the result cache, is counted but lives on until released). */
static size_t jobs_evict_result(struct job *j, const char *why);

/* Lets go of the images of the finished job that finished first (of the
 * task it shares with any other job): its jobs become "evicted" and answer
 * 410 result_evicted (jobs_evict_result).  false when no finished job
 * keeps an image. */
static bool jobs_evict_oldest(void)
{
    struct job *victim = NULL;
    for (int i = 0; i < jobs_n; i++) {
        struct job *j = jobs_table[i];
        struct task *t = j->task;
        bool keeps = t->png || t->exr || (t->passes && t->passes->done);
        if (t->finished && t->status == RAYD_OK && !t->evicted && keeps &&
            (!victim || t->t_end < victim->task->t_end))
            victim = j;
    }
    if (!victim)
        return false;
    struct task *t = victim->task;
    jobs_evict_result(victim, JOBS_EVICTED_WHY);
    if (t->passes)
        passes_let_go(t->passes);
    t->evicted = true;
    return true;
}

/* The memory budget's reclaimer (mem.c): one thing let go, cheapest
 * first; false when nothing is left to let go.  A body in flight is
 * transient, and many slow uploads must not wipe out every client's
 * finished images: it may take the caches' room only.  Takes work_lock. */
static bool jobs_reclaim(enum mem_kind k, size_t need)
{
    (void)need; /* called again until the reservation fits */
    pthread_mutex_lock(&work_lock);
    bool freed =
        rcache_evict_one() || cache_evict_one() || (k != MEM_BODIES && jobs_evict_oldest());
    pthread_mutex_unlock(&work_lock);
    return freed;
}

int jobs_start(int max_jobs)
{
    jobs_max = max_jobs;
    mem_set_reclaim(jobs_reclaim);
    jobs_table = calloc((size_t)max_jobs, sizeof *jobs_table);
    metrics_gauge(MG_JOBS, jobs_gauge);
    return jobs_table ? 0 : -1;
}

void jobs_stop(void)
{
    for (int i = 0; i < jobs_n; i++)
        jobs_unref(jobs_table[i]);
    jobs_n = 0;
    free(jobs_table);
    jobs_table = NULL;
    jobs_tomb_n = jobs_tomb_next = 0;
}

const char *jobs_state_name(enum jobs_state s)
{
    static const char *const names[] = {"queued", "running",  "succeeded",
                                        "failed", "canceled", "evicted"};
    return names[s];
}

enum jobs_state jobs_state(const struct job *j)
{
    const struct task *t = j->task;
    if (j->canceled)
        return JS_CANCELED;
    if (t->finished && t->evicted)
        return JS_EVICTED;
    if (t->finished)
        return t->status == RAYD_OK           ? JS_SUCCEEDED
               : t->status == RAYD_E_CANCELED ? JS_CANCELED
                                              : JS_FAILED;
    return t->t_start == 0 && !t->finalizing ? JS_QUEUED : JS_RUNNING;
}

static bool jobs_final(const struct job *j)
{
    enum jobs_state s = jobs_state(j);
    return s == JS_SUCCEEDED || s == JS_FAILED || s == JS_CANCELED || s == JS_EVICTED;
}

/* When a final job ended (clock_now's clock): its DELETE, or its task's
 * end (never before the job was made, for a task it joined late). */
static double jobs_ended(const struct job *j)
{
    if (j->canceled)
        return j->canceled_at;
    double end = j->task->t_end;
    return end > j->created ? end : j->created;
}

/* A clock_now() time as wall-clock seconds since the epoch, for answers. */
static double jobs_wall(double mono)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9 - (clock_now() - mono);
}

struct job *jobs_find(const char *id)
{
    for (int i = 0; i < jobs_n; i++)
        if (!strcmp(jobs_table[i]->id, id))
            return jobs_table[i];
    return NULL;
}

void jobs_unref(struct job *j)
{
    if (--j->refs > 0)
        return;
    if (j->task)
        task_unref(j->task);
    free(j);
}

/* Writes j's tombstone over the oldest one once the ring is full. */
static void jobs_bury(const struct job *j, enum jobs_gone_why why, double now)
{
    struct jobs_tomb *t = &jobs_tombs[jobs_tomb_next];
    jobs_tomb_next = (jobs_tomb_next + 1) % JOBS_TOMBSTONES;
    if (jobs_tomb_n < JOBS_TOMBSTONES)
        jobs_tomb_n++;
    memset(t, 0, sizeof *t);
    snprintf(t->id, sizeof t->id, "%s", j->id);
    t->g.why = why;
    t->g.state = jobs_state(j);
    t->g.ended_wall = jobs_wall(jobs_ended(j));
    t->g.gone_wall = jobs_wall(now);
}

/* Forgets the final job at i, leaving its tombstone. */
static void jobs_forget(int i, enum jobs_gone_why why, double now)
{
    struct job *j = jobs_table[i];
    jobs_bury(j, why, now);
    jobs_table[i] = jobs_table[--jobs_n];
    jobs_unref(j);
}

void jobs_expire(double now)
{
    for (int i = 0; i < jobs_n;) {
        const struct job *j = jobs_table[i];
        if (jobs_final(j) && now - jobs_ended(j) > (double)config.job_ttl)
            jobs_forget(i, JG_EXPIRED, now);
        else
            i++;
    }
}

bool jobs_gone(const char *id, struct jobs_gone *g)
{
    bool found = false;
    pthread_mutex_lock(&work_lock);
    for (int k = 1; k <= jobs_tomb_n && !found; k++) { /* the newest first */
        const struct jobs_tomb *t =
            &jobs_tombs[(jobs_tomb_next - k + JOBS_TOMBSTONES) % JOBS_TOMBSTONES];
        if (!strcmp(t->id, id)) {
            *g = t->g;
            found = true;
        }
    }
    pthread_mutex_unlock(&work_lock);
    return found;
}

static size_t jobs_evict_result(struct job *j, const char *why)
{
    struct task *t = j->task;
    size_t bytes = (t->png ? t->png->len : 0) + (t->exr ? t->exr->len : 0);
    blob_unref(t->png);
    blob_unref(t->exr);
    t->png = t->exr = NULL;
    double now = clock_now();
    for (int i = 0; i < jobs_n; i++) /* every job of t shared those images */
        if (jobs_table[i]->task == t && jobs_table[i]->evicted_at == 0) {
            jobs_table[i]->evicted_at = now;
            snprintf(jobs_table[i]->evicted_why, sizeof jobs_table[i]->evicted_why, "%s", why);
        }
    if (j->evicted_at == 0) { /* j not (or no longer) in the table */
        j->evicted_at = now;
        snprintf(j->evicted_why, sizeof j->evicted_why, "%s", why);
    }
    return bytes;
}

void jobs_count(long *unfinished, long *cap)
{
    long n = 0;
    for (int i = 0; i < jobs_n; i++)
        n += !jobs_final(jobs_table[i]);
    *unfinished = n;
    *cap = jobs_max;
}

/* Makes room in the table by forgetting the job that ended first. */
static bool jobs_evict(void)
{
    int victim = -1;
    for (int i = 0; i < jobs_n; i++)
        if (jobs_final(jobs_table[i]) &&
            (victim < 0 || jobs_ended(jobs_table[i]) < jobs_ended(jobs_table[victim])))
            victim = i;
    if (victim < 0)
        return false;
    jobs_forget(victim, JG_EVICTED, clock_now());
    return true;
}

static bool jobs_new_id(char id[33])
{
    uint8_t rnd[16];
    if (getrandom(rnd, sizeof rnd, 0) != (ssize_t)sizeof rnd)
        return false;
    for (int i = 0; i < 16; i++)
        snprintf(id + 2 * i, 3, "%02x", rnd[i]);
    return true;
}

/* A progressive job's task: its passes' sums, and a key of its own (the
 * job id), since its passes, budgets and stop belong to this job alone. */
static bool jobs_progressive(struct task *t, struct cache_entry *scene,
                             const struct jobs_plan *plan, const char *id)
{
    struct rayd_region *tiles = calloc((size_t)t->ntiles, sizeof *tiles);
    if (!tiles)
        return false;
    for (int i = 0; i < t->ntiles; i++)
        tiles[i] = task_tile(t, i);
    t->passes = passes_new(cache_scene(scene), plan, tiles, t->ntiles); /* owns tiles */
    size_t n = strlen(t->key);
    snprintf(t->key + n, sizeof t->key - n, "~%s", id);
    return t->passes != NULL;
}

enum work_submit jobs_create(struct cache_entry *scene, const struct work_target *what,
                             const struct jobs_plan *plan, char id[33])
{
    if (!jobs_new_id(id))
        return WORK_NOMEM;
    enum work_submit why;
    struct task *fresh = budget_task(scene, what, plan != NULL, &why);
    if (!fresh)
        return why;
    struct job *j = calloc(1, sizeof *j);
    if (plan && !jobs_progressive(fresh, scene, plan, id)) {
        task_unref(fresh);
        fresh = NULL;
    }
    if (!j || !fresh) {
        free(j);
        if (fresh)
            task_unref(fresh);
        return WORK_NOMEM;
    }
    snprintf(j->id, sizeof j->id, "%s", id);
    j->created = clock_now();
    j->refs = 1;
    pthread_mutex_lock(&work_lock);
    enum work_submit r = WORK_OK;
    struct task *t = NULL;
    if (task_draining())
        r = WORK_DRAINING;
    else if (jobs_n == jobs_max && !jobs_evict())
        r = WORK_TOO_MANY_JOBS;
    else
        r = task_submit(scene, &fresh, &t);
    if (r == WORK_OK) {
        j->task = t;
        t->refs++;
        t->njobs++;
        jobs_table[jobs_n++] = j;
        j = NULL;
    }
    pthread_mutex_unlock(&work_lock);
    free(j);
    if (fresh)
        task_unref(fresh);
    return r;
}

/* The share of the work done, lock held: of the tiles, or for a progressive
 * job of the samples' work.  One function, so the job's JSON and the final
 * event of its stream say the same. */
double jobs_progress(const struct job *j)
{
    const struct task *t = j->task;
    if (jobs_state(j) == JS_SUCCEEDED)
        return 1;
    double frac = t->ntiles ? (double)t->done / t->ntiles : 0;
    return t->passes ? passes_progress(t->passes, t->passes->done, frac) : frac;
}

/* The image jobs_get hands out, lock held: the final one once succeeded,
 * else a progressive job's latest pass (NULL if none yet); referenced. */
static struct blob *jobs_image(const struct job *j, enum jobs_state state, bool exr)
{
    const struct task *t = j->task;
    if (state == JS_SUCCEEDED)
        return blob_ref(exr ? t->exr : t->png);
    if (!t->passes || t->finished || !t->passes->done)
        return NULL;
    const struct passes *p = t->passes;
    return blob_ref(exr ? passes_exr(p, p->done) : passes_png(p, p->done));
}

/* The job's numbers, lock held. */
static void jobs_info_of(const struct job *j, struct jobs_info *info, enum jobs_want want)
{
    const struct task *t = j->task;
    info->state = jobs_state(j);
    info->tiles_done = t->done;
    info->tiles_total = t->ntiles;
    info->progress = jobs_progress(j);
    if (t->passes) {
        info->progressive = true;
        passes_info(t->passes, &info->passes);
    }
    info->region = t->reg;
    snprintf(info->scene_id, sizeof info->scene_id, "%s", t->scene_id);
    double now = clock_now();
    info->created_age = now - j->created;
    task_times(t, now, &info->queue_ms, &info->render_ms);
    info->encode_ms = t->encode_s * 1e3;
    info->rays = t->rays;
    info->est_rays = t->est_rays;
    if (info->state == JS_FAILED)
        info->err = t->err;
    info->keep_exr = t->keep_exr;
    info->ended_age = jobs_final(j) ? now - jobs_ended(j) : -1;
    if (j->evicted_at > 0) { /* no image to hand out: why instead */
        info->result_evicted = true;
        info->gone = (struct jobs_gone){.why = JG_RESULT_EVICTED,
                                        .state = info->state,
                                        .ended_wall = jobs_wall(jobs_ended(j)),
                                        .gone_wall = jobs_wall(j->evicted_at)};
        snprintf(info->gone.detail, sizeof info->gone.detail, "%s", j->evicted_why);
        return;
    }
    if (want & JOBS_PNG)
        info->png = jobs_image(j, info->state, false);
    if (want & JOBS_EXR)
        info->exr = jobs_image(j, info->state, true);
}

bool jobs_get(const char *id, struct jobs_info *info, enum jobs_want want)
{
    memset(info, 0, sizeof *info);
    pthread_mutex_lock(&work_lock);
    struct job *j = jobs_find(id);
    if (j)
        jobs_info_of(j, info, want);
    pthread_mutex_unlock(&work_lock);
    return j != NULL;
}

bool jobs_cancel(const char *id)
{
    struct task_notify n = {0}, sse = {0};
    pthread_mutex_lock(&work_lock);
    struct job *j = jobs_find(id);
    if (j && !j->canceled && !j->task->finished) {
        struct task *t = j->task;
        j->canceled = true;
        j->canceled_at = clock_now();
        t->njobs--;
        if (t->njobs == 0 && !t->waiters) {
            task_cancel(t, MC_DELETE, &n, &sse);
            if (t->passes) /* a cancelled job's passes are never served again */
                passes_let_go(t->passes);
        }
        task_notify_add(&sse, &t->sse_waiters);
    }
    pthread_mutex_unlock(&work_lock);
    task_notify_run(&n);
    task_notify_run(&sse);
    mem_trim(); /* a cancelled job's sums may have been freed */
    return j != NULL;
}

bool jobs_pass_image(const char *id, int pass, bool exr, struct blob **img, int *samples)
{
    *img = NULL;
    *samples = 0;
    pthread_mutex_lock(&work_lock);
    struct job *j = jobs_find(id);
    const struct passes *p = j ? j->task->passes : NULL;
    if (p && !j->canceled && j->evicted_at == 0 && pass >= 1 && pass <= p->done) {
        *img = blob_ref(exr ? passes_exr(p, pass) : passes_png(p, pass));
        *samples = p->samples[pass - 1];
    }
    pthread_mutex_unlock(&work_lock);
    return j != NULL;
}

bool jobs_end_early(const char *id, bool *progressive)
{
    struct task_notify n = {0}, sse = {0};
    pthread_mutex_lock(&work_lock);
    struct job *j = jobs_find(id);
    *progressive = j && j->task->passes;
    if (*progressive && !j->canceled && task_end_early(j->task, PASSES_BY_CLIENT))
        task_finish(j->task, &n, &sse);
    pthread_mutex_unlock(&work_lock);
    task_notify_run(&n);
    task_notify_run(&sse);
    return j != NULL;
}
