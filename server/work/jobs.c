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
 * finished first: the admitting client's own, else of a client that keeps
 * more of them than it has jobs (struct jobs_whose).  Such a job keeps its
 * numbers and says "evicted" (its
 * image answers 410 result_evicted), so a client knows to render again
 * rather than think its id wrong.
 *
 * With --data-dir every job is also a record on disk (store.c): created
 * before its 202 is sent, ended when its task finishes (the finish hook,
 * its images written by the store thread), dropped when it is forgotten.
 * A job whose images are on disk (j->stored) may let go of them in memory
 * without being evicted: they are read back from the file.  A task the
 * drain cancels is not an end: its jobs stay queued on disk and render
 * after the restart.  Priorities (POST /v1/jobs?priority=) are the task's
 * (task.c orders a client's own tasks by them) and jobs_list pages a
 * client's jobs newest first by their creation number, which survives a
 * restart.
 */
#include "work/work_private.h"

#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <time.h>

static struct job **jobs_table;
static int jobs_n, jobs_max;
static long long jobs_seq; /* the last creation number given */

/* The ring of tombstones: the next slot to write, and how many are used. */
static struct jobs_tomb {
    char id[33];
    struct jobs_gone g;
} jobs_tombs[JOBS_TOMBSTONES];
static int jobs_tomb_next, jobs_tomb_n;

static struct jobs_shots jobs_shots; /* shots.c's (jobs_shots_hooks); NULLs before */

void jobs_shots_hooks(const struct jobs_shots *h) { jobs_shots = *h; }

static long jobs_gauge(void) {
    work_lock_take();
    long n = jobs_n;
    work_lock_give();
    return n;
}

/* Whether every job of t has its images on disk (--data-dir). */
static bool jobs_all_stored(const struct task *t) {
    bool any = false;
    for (int i = 0; i < jobs_n; i++)
        if (jobs_table[i]->task == t) {
            if (!jobs_table[i]->stored) return false;
            any = true;
        }
    return any;
}

/* Drops the images (PNG, EXR) of j's task, which every job of that task
 * shared: from now on their image and status routes answer 410
 * result_evicted with why (copied; e.g. "over --max-memory").  The bytes
 * freed (blob lengths; a blob still referenced elsewhere, by a response in
 * flight or the result cache, is counted but lives on until released). */
static size_t jobs_evict_result(struct job *j, const char *why);
static bool jobs_evict_job(struct job *victim);

/* Whose images a reservation may let go of.  First the admitting
 * client's own (own).  Then, for a reservation of no client's, anyone's;
 * for a client's, only a client's that keeps more finished images (jobs and
 * frame-range jobs that keep one) than the admitting client holds jobs --
 * unfinished, or finished and keeping an image (rule): a client whose own
 * jobs hold the memory, queued or running with nothing finished to let go,
 * is refused 503 memory_full rather than take the image of a client that
 * keeps fewer -- one client's 4096x4096 EXR jobs made another's only image,
 * 11 s old, 410 result_evicted.  A client holding nothing (its jobs ended,
 * their images let go) still makes room, as a newcomer does. */
struct jobs_whose {
    bool own, rule;
    uint64_t client;
    int mine;          /* the admitting client's jobs that hold memory */
    uint64_t *keepers; /* sorted: an owner once for each job that keeps an image */
    int nkeepers;
};

static bool jobs_keeps(const struct job *j) {
    const struct task *t = j->task;
    bool keeps = t->png || t->exr || (t->passes && t->passes->done);
    return t->finished && t->status == RAYD_OK && !t->evicted && keeps;
}

static int jobs_cmp_owner(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* How many entries of the sorted keepers are owner's. */
static int jobs_kept_by(const struct jobs_whose *w, uint64_t owner) {
    int lo = 0, hi = w->nkeepers;
    while (lo < hi) { /* the first entry >= owner */
        int mid = lo + (hi - lo) / 2;
        if (w->keepers[mid] < owner)
            lo = mid + 1;
        else
            hi = mid;
    }
    int n = 0;
    while (lo + n < w->nkeepers && w->keepers[lo + n] == owner) n++;
    return n;
}

bool jobs_whose_may(const struct jobs_whose *w, uint64_t owner) {
    if (w->own) return owner == w->client;
    if (!w->rule) return true;
    return owner != w->client && jobs_kept_by(w, owner) > w->mine;
}

static void jobs_whose_add(void *u, uint64_t owner, bool keeps, bool live) {
    struct jobs_whose *w = u;
    w->mine += owner == w->client && (keeps || live);
    if (keeps) w->keepers[w->nkeepers++] = owner;
}

/* w's counts for its rule; false when there is no memory for them. */
static bool jobs_whose_load(struct jobs_whose *w) {
    long shots = jobs_shots.each ? jobs_max : 0; /* the frame-range jobs: as many at most */
    w->keepers = malloc(sizeof *w->keepers * (size_t)(jobs_n + shots + 1));
    if (!w->keepers) return false;
    for (int i = 0; i < jobs_n; i++)
        jobs_whose_add(w, jobs_table[i]->client, jobs_keeps(jobs_table[i]),
                       !jobs_table[i]->task->finished);
    if (jobs_shots.each) jobs_shots.each(jobs_whose_add, w);
    qsort(w->keepers, (size_t)w->nkeepers, sizeof *w->keepers, jobs_cmp_owner);
    return true;
}

/* The finished job of an owner w allows that finished first and keeps an
 * image; NULL when none. */
static struct job *jobs_oldest_kept(const struct jobs_whose *w) {
    struct job *victim = NULL;
    for (int i = 0; i < jobs_n; i++) {
        struct job *j = jobs_table[i];
        if (jobs_keeps(j) && (!victim || j->task->t_end < victim->task->t_end) &&
            jobs_whose_may(w, j->client))
            victim = j;
    }
    return victim;
}

/* Lets go of the oldest image of an owner w allows: a finished job's (of
 * the task it shares with any other job: its jobs become "evicted" and
 * answer 410 result_evicted, jobs_evict_result) or, when a finished
 * frame-range job ended before it, that job's oldest frame kept (shots.c).
 * false when none keeps one. */
static bool jobs_evict_whose(const struct jobs_whose *w) {
    struct job *victim = jobs_oldest_kept(w);
    double shot_end = jobs_shots.oldest_end ? jobs_shots.oldest_end(w) : -1;
    if (shot_end >= 0 && (!victim || shot_end < victim->task->t_end) && jobs_shots.evict_oldest(w))
        return true;
    return victim && jobs_evict_job(victim);
}

/* One image let go for the budget, whose as struct jobs_whose says. */
static bool jobs_evict_oldest(void) {
    struct jobs_whose w = {0};
    bool admitting = budget_admitting(&w.client);
    w.own = admitting;
    if (admitting && jobs_evict_whose(&w)) return true;
    w.own = false;
    w.rule = admitting;
    if (w.rule && !jobs_whose_load(&w)) return false;
    bool freed = jobs_evict_whose(&w);
    free(w.keepers);
    return freed;
}

/* Lets go of victim's images (only from memory when they are on disk). */
static bool jobs_evict_job(struct job *victim) {
    struct task *t = victim->task;
    if (jobs_all_stored(t)) { /* on disk: only the memory goes */
        task_let_go_images(t);
        if (t->passes) passes_let_go(t->passes);
        return true;
    }
    jobs_evict_result(victim, JOBS_EVICTED_WHY);
    task_evicted(t);
    return true;
}

/* Whether the two caches hold more than half the memory budget, lock
 * held. */
static bool jobs_caches_over_half(void) {
    size_t scenes, results, n;
    cache_stats(&scenes, &n);
    rcache_stats(&results, &n);
    return scenes + results > mem_limit() / 2;
}

/* The memory budget's reclaimer (mem.c): one thing let go, cheapest
 * first; false when nothing is left to let go.  A body in flight is
 * transient, and many slow uploads must not wipe out every client's
 * finished images: it may take the caches' room only.  And a body costs
 * its sender nothing until its bytes arrive (600 connections that each
 * declare 4 MiB and send one byte a second), so a body evicts from the
 * caches only while they hold over half the budget: the other half keeps
 * them warm whatever the uploads, and the bodies still find room once the
 * caches are down to half.  A parse (its cap) may let go of what the scene
 * it builds may.  Takes work_lock. */
static bool jobs_reclaim(enum mem_kind k, size_t need) {
    (void)need; /* called again until the reservation fits */
    work_lock_take();
    bool freed = false;
    if (k != MEM_BODIES || jobs_caches_over_half()) freed = rcache_evict_one() || cache_evict_one();
    if (!freed && k != MEM_BODIES) freed = jobs_evict_oldest();
    work_lock_give();
    return freed;
}

static void jobs_finished(struct task *t);
static void jobs_written(const char *id);
static void jobs_disk_evicted(const char *id, const char *why, double wall);

int jobs_start(int max_jobs) {
    jobs_max = max_jobs;
    mem_set_reclaim(jobs_reclaim);
    task_on_finish(jobs_finished);
    store_hooks(jobs_written, jobs_disk_evicted);
    jobs_table = calloc((size_t)max_jobs, sizeof *jobs_table);
    metrics_gauge(MG_JOBS, jobs_gauge);
    return jobs_table ? 0 : -1;
}

void jobs_stop(void) {
    for (int i = 0; i < jobs_n; i++) jobs_unref(jobs_table[i]);
    jobs_n = 0;
    free(jobs_table);
    jobs_table = NULL;
    jobs_tomb_n = jobs_tomb_next = 0;
}

const char *jobs_state_name(enum jobs_state s) {
    static const char *const names[] = {"queued", "running",  "succeeded",
                                        "failed", "canceled", "evicted"};
    return names[s];
}

enum jobs_state jobs_state(const struct job *j) {
    const struct task *t = j->task;
    if (j->canceled) return JS_CANCELED;
    if (t->finished && (t->evicted || (j->evicted_at > 0 && t->status == RAYD_OK)))
        return JS_EVICTED;
    if (t->finished)
        return t->status == RAYD_OK           ? JS_SUCCEEDED
               : t->status == RAYD_E_CANCELED ? JS_CANCELED
                                              : JS_FAILED;
    return t->t_start == 0 && !t->finalizing ? JS_QUEUED : JS_RUNNING;
}

static bool jobs_final(const struct job *j) {
    enum jobs_state s = jobs_state(j);
    return s == JS_SUCCEEDED || s == JS_FAILED || s == JS_CANCELED || s == JS_EVICTED;
}

/* When a final job ended (clock_now's clock): its DELETE, or its task's
 * end (never before the job was made, for a task it joined late). */
static double jobs_ended(const struct job *j) {
    if (j->canceled) return j->canceled_at;
    double end = j->task->t_end;
    return end > j->created ? end : j->created;
}

/* A clock_now() time as wall-clock seconds since the epoch, for answers. */
static double jobs_wall(double mono) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9 - (clock_now() - mono);
}

struct job *jobs_find(const char *id) {
    work_assert_locked();
    for (int i = 0; i < jobs_n; i++)
        if (!strcmp(jobs_table[i]->id, id)) return jobs_table[i];
    return NULL;
}

void jobs_unref(struct job *j) {
    if (--j->refs > 0) return;
    if (j->task) task_unref(j->task);
    free(j);
}

/* Writes j's tombstone over the oldest one once the ring is full. */
static void jobs_bury(const struct job *j, enum jobs_gone_why why, double now) {
    struct jobs_tomb *t = &jobs_tombs[jobs_tomb_next];
    jobs_tomb_next = (jobs_tomb_next + 1) % JOBS_TOMBSTONES;
    if (jobs_tomb_n < JOBS_TOMBSTONES) jobs_tomb_n++;
    memset(t, 0, sizeof *t);
    snprintf(t->id, sizeof t->id, "%s", j->id);
    t->g.why = why;
    t->g.state = jobs_state(j);
    t->g.ended_wall = jobs_wall(jobs_ended(j));
    t->g.gone_wall = jobs_wall(now);
}

/* Forgets the final job at i, leaving its tombstone. */
static void jobs_forget(int i, enum jobs_gone_why why, double now) {
    struct job *j = jobs_table[i];
    jobs_bury(j, why, now);
    if (store_on()) store_forget(j->id);
    jobs_table[i] = jobs_table[--jobs_n];
    jobs_unref(j);
}

void jobs_expire(double now) {
    work_assert_locked();
    for (int i = 0; i < jobs_n;) {
        const struct job *j = jobs_table[i];
        if (jobs_final(j) && now - jobs_ended(j) > (double)config.job_ttl)
            jobs_forget(i, JG_EXPIRED, now);
        else
            i++;
    }
}

bool jobs_gone(const char *id, struct jobs_gone *g) {
    bool found = false;
    work_lock_take();
    for (int k = 1; k <= jobs_tomb_n && !found; k++) { /* the newest first */
        const struct jobs_tomb *t =
            &jobs_tombs[(jobs_tomb_next - k + JOBS_TOMBSTONES) % JOBS_TOMBSTONES];
        if (!strcmp(t->id, id)) {
            *g = t->g;
            found = true;
        }
    }
    work_lock_give();
    return found;
}

static size_t jobs_evict_result(struct job *j, const char *why) {
    work_assert_locked();
    struct task *t = j->task;
    size_t bytes = task_let_go_images(t);
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

void jobs_count(long *unfinished, long *cap) {
    long n = jobs_shots.unfinished ? jobs_shots.unfinished() : 0;
    for (int i = 0; i < jobs_n; i++) n += !jobs_final(jobs_table[i]);
    *unfinished = n;
    *cap = jobs_max;
}

/* As the render queue keeps its last places (task_queue_kept): a
 * frame-range job holds no place in the queue until its frames start, so
 * twenty POSTs of one client's 1000-frame jobs filled a --max-jobs of 20,
 * and every other client's POST /v1/jobs got 503 for as long as those
 * frames took. */
bool jobs_over_share(uint64_t client) {
    long n, cap, mine = jobs_shots.unfinished_of ? jobs_shots.unfinished_of(client) : 0;
    jobs_count(&n, &cap);
    long quarter = cap / 4;
    if (quarter < 1 || n < cap - quarter) return false;
    for (int i = 0; i < jobs_n; i++)
        mine += !jobs_final(jobs_table[i]) && jobs_table[i]->client == client;
    return mine >= quarter;
}

enum work_submit jobs_room(uint64_t client) {
    work_lock_take();
    long n, cap;
    jobs_count(&n, &cap);
    enum work_submit r = task_draining()           ? WORK_DRAINING
                         : n >= cap                ? WORK_TOO_MANY_JOBS
                         : jobs_over_share(client) ? WORK_JOBS_SHARE
                                                   : WORK_OK;
    work_lock_give();
    return r;
}

/* Makes room in the table for a job of client by forgetting the job of
 * its own that ended first, or when it has none, anyone's: one client's
 * flood of jobs forgets its own finished ones, not the others' long
 * before their --job-ttl. */
static bool jobs_evict(uint64_t client) {
    int victim = -1;
    for (int pass = 0; pass < 2 && victim < 0; pass++)
        for (int i = 0; i < jobs_n; i++)
            if (jobs_final(jobs_table[i]) && (pass || jobs_table[i]->client == client) &&
                (victim < 0 || jobs_ended(jobs_table[i]) < jobs_ended(jobs_table[victim])))
                victim = i;
    if (victim < 0) return false;
    jobs_forget(victim, JG_EVICTED, clock_now());
    return true;
}

static bool jobs_new_id(char id[33]) {
    uint8_t rnd[16];
    if (getrandom(rnd, sizeof rnd, 0) != (ssize_t)sizeof rnd) return false;
    for (int i = 0; i < 16; i++) snprintf(id + 2 * i, 3, "%02x", rnd[i]);
    return true;
}

/* A progressive job's task: its passes' sums, and a key of its own (the
 * job id), since its passes, budgets and stop belong to this job alone. */
static bool jobs_progressive(struct task *t, struct cache_entry *scene,
                             const struct jobs_plan *plan, const char *id) {
    struct rayd_region *tiles = calloc((size_t)t->ntiles, sizeof *tiles);
    if (!tiles) return false;
    for (int i = 0; i < t->ntiles; i++) tiles[i] = task_tile(t, i);
    bool raw = t->denoise && (!t->aov_mask || t->aov); /* its image shows light, denoised */
    task_progressive(
        t, passes_new(cache_scene(scene), plan, tiles, t->ntiles, raw, t->reg.w, t->reg.h),
        id); /* owns tiles */
    return t->passes != NULL;
}

/* A clock_now() time of a wall-clock one (seconds since the epoch). */
static double jobs_mono(double wall) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return clock_now() - ((double)ts.tv_sec + (double)ts.tv_nsec / 1e9 - wall);
}

long long jobs_next_seq(void) {
    work_assert_locked();
    return ++jobs_seq;
}

void jobs_seen_seq(long long seq) {
    if (seq > jobs_seq) jobs_seq = seq;
}

const char *jobs_priority_name(int p) {
    static const char *const names[] = {"low", "normal", "high"};
    return p >= JP_LOW && p <= JP_HIGH ? names[p] : "normal";
}

/* j's record for the store: what it renders, and how it ended so far. */
static void jobs_record(const struct job *j, struct store_job *row) {
    const struct task *t = j->task;
    memset(row, 0, sizeof *row);
    snprintf(row->id, sizeof row->id, "%s", j->id);
    row->seq = j->seq;
    row->client = j->client;
    row->priority = j->priority;
    row->created_wall = j->created_wall;
    row->state = jobs_state(j);
    snprintf(row->scene_id, sizeof row->scene_id, "%s", t->scene_id);
    row->reg = t->reg;
    row->keep_exr = t->keep_exr;
    row->denoise = t->denoise;
    row->aov = t->aov_mask;
    row->progressive = t->passes != NULL;
    if (t->passes) row->plan = t->passes->plan;
    row->tiles = t->ntiles;
    row->rays = t->rays;
    row->est_rays = t->est_rays;
    task_times(t, clock_now(), &row->queue_ms, &row->render_ms);
    row->encode_ms = t->encode_s * 1e3;
    if (row->state == JS_FAILED) row->err = t->err;
    if (jobs_final(j)) row->ended_wall = jobs_wall(jobs_ended(j));
}

/* The finish hook (task.c), lock held: each job of t that ended is
 * recorded with its images.  A task the drain cancelled did not end for
 * its jobs: they stay queued on disk and render again after the restart. */
static void jobs_finished(struct task *t) {
    if (!store_on() || (task_draining() && t->status == RAYD_E_CANCELED)) return;
    for (int i = 0; i < jobs_n; i++) {
        struct job *j = jobs_table[i];
        if (j->task != t || j->canceled || j->recorded) continue;
        struct store_job row;
        jobs_record(j, &row);
        bool ok = row.state == JS_SUCCEEDED;
        store_end(&row, ok ? t->png : NULL, ok ? t->exr : NULL, NULL);
        j->recorded = true;
    }
}

/* The store hooks, on the store thread: j's images are on disk; or they
 * were evicted from it (--max-disk), so j answers 410 result_evicted. */
static void jobs_written(const char *id) {
    work_lock_take();
    struct job *j = jobs_find(id);
    if (j) j->stored = true;
    work_lock_give();
}

static void jobs_disk_evicted(const char *id, const char *why, double wall) {
    work_lock_take();
    struct job *j = jobs_find(id);
    if (j && j->evicted_at == 0) {
        j->stored = false;
        j->evicted_at = jobs_mono(wall);
        snprintf(j->evicted_why, sizeof j->evicted_why, "%s", why);
        bool shared = false;
        for (int i = 0; i < jobs_n; i++)
            shared |= jobs_table[i] != j && jobs_table[i]->task == j->task;
        if (!shared) task_let_go_images(j->task); /* nobody else reads them */
    }
    work_lock_give();
}

/* j (zeroed) becomes job id of task t (lock held, the table has room). */
static struct job *jobs_add(struct job *j, const char *id, struct task *t, uint64_t client,
                            int priority) {
    snprintf(j->id, sizeof j->id, "%s", id);
    j->created = clock_now();
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    j->created_wall = (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
    j->refs = 1;
    j->client = client;
    j->priority = priority;
    j->seq = jobs_next_seq();
    j->task = t;
    task_job_ref(t);
    if (t->client == client) task_raise_priority(t, priority); /* its client's order only */
    jobs_table[jobs_n++] = j;
    return j;
}

/* The task a new job renders: fresh, its passes made for a progressive
 * one; NULL with *why. */
static struct task *jobs_task(struct cache_entry *scene, const struct work_target *what,
                              const struct jobs_plan *plan, const char *id, int priority,
                              enum work_submit *why) {
    struct task *fresh = budget_task(scene, what, plan != NULL, why);
    if (!fresh) return NULL;
    if (plan && !jobs_progressive(fresh, scene, plan, id)) {
        task_unref(fresh);
        *why = WORK_NOMEM;
        return NULL;
    }
    task_raise_priority(fresh, priority);
    return fresh;
}

enum work_submit jobs_submit(struct cache_entry *scene, const struct work_target *what,
                             const struct jobs_plan *plan, struct jobs_new *how, char id[33]) {
    how->waiting = false;
    if (!jobs_new_id(id)) return WORK_NOMEM;
    enum work_submit r;
    struct task *fresh = jobs_task(scene, what, plan, id, how->priority, &r);
    if (!fresh) return r;
    struct store_job row = {0};
    struct job *spare = calloc(1, sizeof *spare);
    if (!spare || (store_on() && !(row.scene = malloc(how->scene_len + 1)))) {
        free(spare);
        task_unref(fresh);
        return WORK_NOMEM;
    }
    if (row.scene) {
        memcpy(row.scene, how->scene, how->scene_len);
        row.scene[how->scene_len] = 0;
        row.scene_len = how->scene_len;
    }
    work_lock_take();
    struct task *t = NULL;
    long busy, cap; /* the unfinished jobs, frame-range ones too: --max-jobs */
    jobs_count(&busy, &cap);
    if (task_draining())
        r = WORK_DRAINING;
    else if (busy >= cap || (jobs_n == jobs_max && !jobs_evict(what->client)))
        r = WORK_TOO_MANY_JOBS;
    else if (jobs_over_share(what->client))
        r = WORK_JOBS_SHARE;
    else
        r = task_submit(scene, &fresh, &t);
    struct job *j = r == WORK_OK ? jobs_add(spare, id, t, what->client, how->priority) : NULL;
    if (j) spare = NULL;
    if (j && row.scene) {
        char *scene_copy = row.scene;
        jobs_record(j, &row);
        row.scene = scene_copy;
        row.scene_len = how->scene_len;
        how->waiting = store_insert(&row, how->w);
    }
    work_lock_give();
    free(row.scene);
    free(spare);
    if (fresh) task_unref(fresh);
    return r;
}

/* ---- start-up: the store's jobs put back ------------------------------------------ */

/* A finished task standing for a job that ended before this process:
 * its numbers, no pixels; its image, if any, on disk. */
static struct task *jobs_ended_task(const struct store_job *row) {
    struct task *t = calloc(1, sizeof *t);
    if (!t) return NULL;
    t->reg = row->reg;
    t->ntiles = (int)row->tiles;
    t->done = row->state == JS_SUCCEEDED ? t->ntiles : 0; /* how far another ended is not kept */
    t->tile = 1;
    snprintf(t->scene_id, sizeof t->scene_id, "%s", row->scene_id);
    snprintf(t->key, sizeof t->key, "restored~%s", row->id);
    t->keep_exr = row->keep_exr;
    t->denoise = row->denoise;
    t->aov_mask = row->aov;
    t->rays = row->rays;
    t->est_rays = row->est_rays;
    t->finished = true;
    t->t_end = jobs_mono(row->ended_wall);
    t->status = row->state == JS_SUCCEEDED ? RAYD_OK
                : row->state == JS_FAILED  ? (row->err.code ? row->err.code : RAYD_E_INTERNAL)
                                           : RAYD_E_CANCELED;
    t->err = row->err;
    t->err.code = t->status;
    task_raise_priority(t, row->priority);
    t->refs = 1;
    atomic_init(&t->cancel, 0);
    return t;
}

bool jobs_restore(const struct store_job *row, struct cache_entry *scene) {
    enum work_submit r = WORK_OK;
    struct task *fresh = NULL;
    if (scene) {
        struct work_target what = {.reg = row->reg,
                                   .format = WORK_PNG,
                                   .keep_exr = row->keep_exr,
                                   .aov = row->aov,
                                   .denoise = row->denoise,
                                   .client = row->client};
        fresh = jobs_task(scene, &what, row->progressive ? &row->plan : NULL, row->id,
                          row->priority, &r);
        if (fresh) fresh->restored = true;
    } else {
        fresh = jobs_ended_task(row);
    }
    struct job *spare = fresh ? calloc(1, sizeof *spare) : NULL;
    if (!spare) {
        if (fresh) task_unref(fresh);
        return false;
    }
    work_lock_take();
    struct task *t = fresh;
    if (jobs_n == jobs_max && !jobs_evict(row->client))
        r = WORK_TOO_MANY_JOBS;
    else if (scene)
        r = task_submit(scene, &fresh, &t);
    else
        fresh = NULL;
    struct job *j = r == WORK_OK ? jobs_add(spare, row->id, t, row->client, row->priority) : NULL;
    if (j) {
        spare = NULL;
        j->seq = row->seq;
        if (row->seq > jobs_seq) jobs_seq = row->seq;
        j->created_wall = row->created_wall;
        j->created = jobs_mono(row->created_wall);
        if (!scene) {
            j->restored = j->recorded = true;
            j->stored = row->state == JS_SUCCEEDED && row->result_ok;
            j->canceled = row->state == JS_CANCELED;
            j->canceled_at = t->t_end;
            j->queue_ms = row->queue_ms;
            j->render_ms = row->render_ms;
            j->encode_ms = row->encode_ms;
            if (row->evicted_wall > 0) {
                j->evicted_at = jobs_mono(row->evicted_wall);
                snprintf(j->evicted_why, sizeof j->evicted_why, "%s", row->evicted_why);
            }
            task_unref(t); /* the job's reference stays */
        }
    }
    work_lock_give();
    free(spare);
    if (fresh) task_unref(fresh);
    return j != NULL;
}

/* The share of the work done, lock held: of the tiles, or for a progressive
 * job of the samples' work.  One function, so the job's JSON and the final
 * event of its stream say the same. */
double jobs_progress(const struct job *j) {
    work_assert_locked();
    const struct task *t = j->task;
    if (jobs_state(j) == JS_SUCCEEDED) return 1;
    double frac = t->ntiles ? (double)t->done / t->ntiles : 0;
    return t->passes ? passes_progress(t->passes, t->passes->done, frac) : frac;
}

/* The image jobs_get hands out, lock held: the final one once succeeded,
 * else a progressive job's latest pass (NULL if none yet); referenced. */
static struct blob *jobs_image(const struct job *j, enum jobs_state state, bool exr) {
    work_assert_locked();
    const struct task *t = j->task;
    if (state == JS_SUCCEEDED) return blob_ref(exr ? t->exr : t->png);
    if (!t->passes || t->finished || !t->passes->done) return NULL;
    const struct passes *p = t->passes;
    return blob_ref(exr ? passes_exr(p, p->done) : passes_png(p, p->done));
}

/* The job's numbers, lock held. */
static void jobs_info_of(const struct job *j, struct jobs_info *info, enum jobs_want want) {
    work_assert_locked();
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
    if (info->state == JS_FAILED) info->err = t->err;
    info->keep_exr = t->keep_exr;
    info->denoise = t->denoise;
    info->aov = t->aov_mask;
    info->ended_age = jobs_final(j) ? now - jobs_ended(j) : -1;
    snprintf(info->id, sizeof info->id, "%s", j->id);
    info->priority = j->priority;
    info->seq = j->seq;
    info->created_wall = j->created_wall;
    if (j->restored) {
        info->queue_ms = j->queue_ms;
        info->render_ms = j->render_ms;
        info->encode_ms = j->encode_ms;
    }
    if (j->evicted_at > 0) { /* no image to hand out: why instead */
        info->result_evicted = true;
        info->gone = (struct jobs_gone){.why = JG_RESULT_EVICTED,
                                        .state = info->state,
                                        .ended_wall = jobs_wall(jobs_ended(j)),
                                        .gone_wall = jobs_wall(j->evicted_at)};
        snprintf(info->gone.detail, sizeof info->gone.detail, "%s", j->evicted_why);
        return;
    }
    if (want & JOBS_PNG) info->png = jobs_image(j, info->state, false);
    if (want & JOBS_EXR) info->exr = jobs_image(j, info->state, true);
    /* in memory no more (or never, in this process), on disk still */
    info->on_disk = want && info->state == JS_SUCCEEDED && j->stored &&
                    !((want & JOBS_PNG) && info->png) && !((want & JOBS_EXR) && info->exr);
}

/* Newest first: by creation number, descending. */
static int jobs_newer(const void *a, const void *b) {
    long long x = (*(struct job *const *)a)->seq, y = (*(struct job *const *)b)->seq;
    return x < y ? 1 : x > y ? -1 : 0;
}

int jobs_list(uint64_t client, int state, long long before, struct jobs_info *out, int n,
              bool *more) {
    *more = false;
    work_lock_take();
    struct job **mine = malloc((size_t)(jobs_n ? jobs_n : 1) * sizeof *mine);
    int m = 0, got = 0;
    for (int i = 0; mine && i < jobs_n; i++) {
        struct job *j = jobs_table[i];
        if (j->client == client && (before <= 0 || j->seq < before) &&
            (state < 0 || jobs_state(j) == (enum jobs_state)state))
            mine[m++] = j;
    }
    if (mine) qsort(mine, (size_t)m, sizeof *mine, jobs_newer);
    for (; got < n && got < m; got++) {
        memset(&out[got], 0, sizeof out[got]);
        jobs_info_of(mine[got], &out[got], JOBS_NUMBERS);
    }
    *more = m > got;
    work_lock_give();
    free(mine);
    return got;
}

bool jobs_get(const char *id, struct jobs_info *info, enum jobs_want want) {
    memset(info, 0, sizeof *info);
    work_lock_take();
    struct job *j = jobs_find(id);
    if (j) jobs_info_of(j, info, want);
    work_lock_give();
    return j != NULL;
}

bool jobs_cancel(const char *id, struct work_waiter *w, bool *waiting) {
    struct task_notify n = {0}, sse = {0};
    work_lock_take();
    struct job *j = jobs_find(id);
    if (j && !j->canceled && !j->task->finished) {
        struct task *t = j->task;
        j->canceled = true;
        j->canceled_at = clock_now();
        task_job_drop(t);
        if (t->njobs == 0 && !t->waiters) {
            task_cancel(t, MC_DELETE, &n, &sse);
            if (t->passes) /* a cancelled job's passes are never served again */
                passes_let_go(t->passes);
        }
        task_notify_add(&sse, &t->sse_waiters);
        if (store_on() && !j->recorded) {
            struct store_job row;
            jobs_record(j, &row);
            bool told = store_end(&row, NULL, NULL, w);
            if (waiting) *waiting = told;
            j->recorded = true;
        }
    }
    work_lock_give();
    task_notify_run(&n);
    task_notify_run(&sse); /* the watcher gives freed sums back (mem_trim) */
    return j != NULL;
}

bool jobs_pass_image(const char *id, int pass, enum jobs_image kind, struct blob **img,
                     int *samples) {
    *img = NULL;
    *samples = 0;
    work_lock_take();
    struct job *j = jobs_find(id);
    const struct passes *p = j ? j->task->passes : NULL;
    if (p && !j->canceled && j->evicted_at == 0 && pass >= 1 && pass <= p->done) {
        *img = blob_ref(kind == JI_EXR   ? passes_exr(p, pass)
                        : kind == JI_RAW ? passes_raw(p, pass)
                                         : passes_png(p, pass));
        *samples = p->samples[pass - 1];
    }
    work_lock_give();
    return j != NULL;
}

bool jobs_end_early(const char *id, bool *progressive) {
    struct task_notify n = {0}, sse = {0};
    work_lock_take();
    struct job *j = jobs_find(id);
    *progressive = j && j->task->passes;
    if (*progressive && !j->canceled && task_end_early(j->task, PASSES_BY_CLIENT))
        task_finish(j->task, &n, &sse);
    work_lock_give();
    task_notify_run(&n);
    task_notify_run(&sse);
    return j != NULL;
}
