/* compile.c -- scenes parsed and built off the HTTP threads: a small pool of
 * its own.
 *
 * Parsing a scene, decoding its textures and building its meshes and BVHs
 * takes milliseconds to tens of seconds.  Run on libmicrohttpd's threads, a
 * few heavy bodies held every one of them, and /healthz (a liveness probe)
 * waited 20 s and more behind them.  So a request whose scene is not
 * already compiled is suspended, like a request waiting for its render, and
 * --parse-threads threads of this file parse it and resume it with the
 * compiled scene (the handler's continuation runs on that thread, still
 * suspended, and either answers or hands the request on to a render).
 *
 * What stays on the connection's thread is what costs about as much as
 * having received the body: its SHA-256 and the cache lookup, and the stat
 * check of a cached scene's files when there are few of them (at most
 * COMPILE_INLINE_FILES distinct files; more are checked on the pool).  A
 * scene in the cache therefore answers at once, with no thread hop.
 *
 * Bounds: at most --parse-queue scenes wait for a thread; one more is
 * refused 503 queue_full with a Retry-After (the parses queued times the
 * average parse, over the threads).  Each scene queued holds its parse's
 * first cap in the memory budget (kind parses, scenes_parse_cap) from the
 * moment it is queued, so what the queue and the parses may build is
 * counted before it exists; one with no room is refused 503 memory_full.  A body posted while the
 * same body (by its SHA-256) is queued or being parsed does not take a place: it waits for that
 * parse and gets the same scene or the same error, so a scene posted by many tile clients at once
 * is parsed once.
 *
 * A client that hangs up while its scene is parsed is seen later (the
 * watcher, once its render is queued; or libmicrohttpd, once resumed): the
 * parse still finishes and its scene stays cached for the next request.  A
 * frame-range job's DELETE drops its frames' waiters (compile_drop), and a
 * parse no waiter wants any more is stopped through its cancel flag
 * (rayd_limits.cancel: the core looks at it between the parse's steps and
 * inside each BVH build).  A drain answers the scenes still queued with 503
 * draining without parsing them; a parse running finishes, and
 * compile_stop, called after libmicrohttpd stops, raises every running
 * parse's flag and waits for them up to COMPILE_JOIN_SECONDS.
 *
 * The pool's state is under work_lock (the server's one mutex) with a
 * condition variable of its own.  The threads start with the server
 * (compile_start): started on the first scene instead, a first scene that
 * came when no thread could be made left every later scene refused.
 */
#include "work/work_private.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define COMPILE_INLINE_FILES 16  /* files a connection's thread may stat */
#define COMPILE_JOIN_SECONDS 2.0 /* compile_stop's wait for a parse running */

/* A job of the frames' turns (compile_pick): a frame's parse, or the check
 * of a frame-range job's frames, which may take seconds; never all the
 * threads, so a scene a request waits for always has one. */
#define COMPILE_FRAMES_KIND(j) ((j)->frame >= 0 || (j)->check)

/* One scene to parse (or, cached, to check), and who waits for it. */
struct compile_job {
    char id[65];
    const char *body; /* the first waiter's request body: suspended until done;
                         NULL for a GET by id, which only checks the cached scene */
    size_t len;
    long frame; /* the frame to parse the body at (compile_scene_frame), -1: the first */
    long check_first, check_last; /* compile_check_frames's frames (cached: the scene) */
    bool check;
    struct cache_entry *cached; /* found compiled; its files are checked here */
    size_t mem;                 /* bytes of kind parses reserved for it, until parsed */
    struct compile_waiter *waiters;
    int nwaiters;
    atomic_int cancel;        /* raised when no waiter wants the parse (compile_drop) */
    uint64_t client;          /* the first waiter's */
    struct compile_job *next; /* the queue, or the list being parsed */
};

/* lock held */
static struct compile_job *compile_head, *compile_tail, *compile_running;
static long compile_queued, compile_nrunning, compile_started;
static long compile_frames;    /* parses of a frame-range job's frames running */
static long compile_gate = -1; /* parses that may still start (test gate), -1 open */
static bool compile_stopping;
static double compile_avg = 0.1; /* seconds of a parse, a moving average */

/* The clients of the last parses started, for compile_pick's turns. */
#define COMPILE_RECENT 16
static uint64_t compile_recent[COMPILE_RECENT];
static int compile_recent_n, compile_recent_at;

static pthread_cond_t compile_cond = PTHREAD_COND_INITIALIZER;
static pthread_t *compile_threads;
static int compile_nthreads;
static int compile_alive; /* threads not yet ended, lock held */

static void *compile_thread(void *arg);

bool compile_start(void) {
    long n = config.parse_threads > 0 ? config.parse_threads : 2;
    compile_threads = calloc((size_t)n, sizeof *compile_threads);
    work_lock_take();
    for (int i = 0; compile_threads && i < n; i++) {
        if (pthread_create(&compile_threads[i], NULL, compile_thread, NULL)) break;
        compile_nthreads++;
        compile_alive++;
    }
    work_lock_give();
    return compile_nthreads == n;
}

/* The job of id (with a body to parse, or by id only) queued or being
 * parsed, lock held; NULL if none.  A queued job that no one wanted any
 * more (compile_drop) is wanted again: its flag is lowered.  A running one
 * whose flag is up is stopping, and is not found, so a new one is queued:
 * joined, it answered RAYD_E_CANCELED, and a frame-range job's frame
 * failed for good because another job of the same frames was deleted. */
static struct compile_job *compile_find(const char *id, bool by_id) {
    work_assert_locked();
    for (struct compile_job *j = compile_head; j; j = j->next)
        if (!strcmp(j->id, id) && (j->body == NULL) == by_id) {
            atomic_store(&j->cancel, 0);
            return j;
        }
    for (struct compile_job *j = compile_running; j; j = j->next)
        if (!strcmp(j->id, id) && (j->body == NULL) == by_id && !atomic_load(&j->cancel)) return j;
    return NULL;
}

/* Unlinks j from the list at *head, lock held. */
static void compile_unlink(struct compile_job **head, struct compile_job *j) {
    work_assert_locked();
    for (struct compile_job **p = head; *p; p = &(*p)->next)
        if (*p == j) {
            *p = j->next;
            return;
        }
}

static long compile_queue_cap(void) { return config.parse_queue > 0 ? config.parse_queue : 64; }

/* Whether client may not take a place now, lock held: the queue's last
 * quarter is kept for clients with fewer than a quarter of it queued, so
 * one client's scenes cannot fill it (12 KB scenes of big textures, 3 s of
 * parse each: another client's new scene got 503 queue_full). */
static bool compile_over_share(uint64_t client) {
    long cap = compile_queue_cap(), quarter = cap / 4, mine = 0;
    if (quarter < 1 || compile_queued < cap - quarter) return false;
    for (struct compile_job *j = compile_head; j; j = j->next) mine += j->client == client;
    return mine >= quarter;
}

/* How many of the last parses started were client's, lock held. */
static int compile_recent_count(uint64_t client) {
    int n = 0;
    for (int i = 0; i < compile_recent_n; i++) n += compile_recent[i] == client;
    return n;
}

static void compile_recent_add(uint64_t client) {
    compile_recent[compile_recent_at] = client;
    compile_recent_at = (compile_recent_at + 1) % COMPILE_RECENT;
    if (compile_recent_n < COMPILE_RECENT) compile_recent_n++;
}

/* Joins w to the job of the same body queued or being parsed, lock held:
 * WORK_OK after w->suspend; WORK_CACHED when there is none (w not used), or
 * the refusal. */
static enum work_submit compile_join_same(const char *id, bool by_id, struct cache_entry *e,
                                          struct compile_waiter *w) {
    work_assert_locked();
    if (compile_stopping || compile_nthreads == 0)
        return compile_stopping ? WORK_DRAINING : WORK_NOMEM;
    if (task_draining()) /* nothing new is suspended once the drain began */
        return WORK_DRAINING;
    struct compile_job *j = compile_find(id, by_id);
    if (!j) return WORK_CACHED;
    if (e) cache_release(e); /* that job has its own */
    w->dropped = false;
    w->suspend(w);
    w->next = j->waiters;
    j->waiters = w;
    j->nwaiters++;
    return WORK_OK;
}

/* Queues a new job for body (with e, a cached scene to check, or NULL; mem
 * bytes of kind parses reserved for it, the job's once queued), lock held;
 * WORK_OK after w->suspend, or the refusal.  *joined: w waits for the same
 * body queued meanwhile, and mem is still the caller's. */
static enum work_submit compile_enqueue(const char *id, const char *body, size_t len, long frame,
                                        const long *check, struct cache_entry *e, size_t mem,
                                        struct compile_waiter *w, bool *joined) {
    enum work_submit s = compile_join_same(id, body == NULL, e, w);
    *joined = s == WORK_OK;
    if (s != WORK_CACHED) return s;
    if (compile_queued >= compile_queue_cap() || compile_over_share(w->client))
        return WORK_PARSE_FULL;
    struct compile_job *j;
    j = calloc(1, sizeof *j);
    if (!j) return WORK_NOMEM;
    snprintf(j->id, sizeof j->id, "%s", id);
    j->body = body;
    j->len = len;
    j->frame = frame;
    if (check) {
        j->check = true;
        j->check_first = check[0];
        j->check_last = check[1];
    }
    j->cached = e;
    j->mem = mem;
    j->waiters = w;
    j->nwaiters = 1;
    j->client = w->client;
    w->dropped = false;
    w->suspend(w);
    w->next = NULL;
    if (compile_tail)
        compile_tail->next = j;
    else
        compile_head = j;
    compile_tail = j;
    compile_queued++;
    pthread_cond_signal(&compile_cond);
    return WORK_OK;
}

/* Reserves a new parse's first cap (no lock held: the reservation may
 * reclaim), then queues it; e is released unless the job took it. */
static enum work_submit compile_queue_new(const char *id, const char *body, size_t len, long frame,
                                          const long *check, struct cache_entry *e,
                                          struct compile_waiter *w) {
    size_t mem = check ? scenes_check_cap(len) : scenes_parse_cap(len);
    if (!budget_reserve(w->client, MEM_PARSES, mem)) {
        metrics_reject(MR_MEMORY);
        scenes_release(e);
        return WORK_MEMORY;
    }
    bool joined = false;
    work_lock_take();
    enum work_submit s = compile_enqueue(id, body, len, frame, check, e, mem, w, &joined);
    work_lock_give();
    if (s != WORK_OK || joined) mem_release(MEM_PARSES, mem);
    if (s != WORK_OK) scenes_release(e);
    return s;
}

/* The id of body at frame (-1: the body's own id): the SHA-256 of the
 * body's id and the frame number, so every frame is a scene of its own in
 * the cache. */
static bool compile_id(const char *body, size_t len, long frame, char id[65],
                       struct rayd_error *err) {
    if (!scenes_id(body, len, id, err)) return false;
    if (frame < 0) return true;
    char text[96];
    int n = snprintf(text, sizeof text, "%s#frame=%ld", id, frame);
    return scenes_id(text, (size_t)n, id, err);
}

enum work_submit compile_scene(const char *body, size_t len, struct compile_waiter *w,
                               struct compile_result *res) {
    return compile_scene_frame(body, len, -1, w, res);
}

enum work_submit compile_scene_frame(const char *body, size_t len, long frame,
                                     struct compile_waiter *w, struct compile_result *res) {
    memset(res, 0, sizeof *res);
    char id[65];
    if (!compile_id(body, len, frame, id, &res->err)) {
        res->status = RAYD_E_NOMEM;
        return WORK_CACHED;
    }
    struct cache_entry *e = scenes_peek(id);
    if (e && rayd_scene_files(cache_scene(e)) <= COMPILE_INLINE_FILES) {
        if (scenes_current(e, true)) {
            metrics_cache(true);
            res->scene = e;
            res->hit = true;
            return WORK_CACHED;
        }
        scenes_release(e); /* a file changed: parse it again */
        e = NULL;
    }
    work_lock_take();
    enum work_submit s = compile_join_same(id, false, e, w);
    work_lock_give();
    if (s == WORK_CACHED) /* a new parse: its first cap reserved before it is queued */
        s = compile_queue_new(id, body, len, frame, NULL, e, w);
    else if (s != WORK_OK)
        scenes_release(e);
    return s;
}

enum work_submit compile_check_frames(struct cache_entry *e, const char *body, size_t len,
                                      long first, long last, struct compile_waiter *w,
                                      struct compile_result *res) {
    memset(res, 0, sizeof *res);
    char id[65], text[128];
    const long check[2] = {first, last};
    int n = snprintf(text, sizeof text, "%s#check=%ld-%ld", cache_id(e), first, last);
    if (!scenes_id(text, (size_t)n, id, &res->err)) {
        res->status = RAYD_E_NOMEM;
        return WORK_CACHED;
    }
    work_lock_take();
    cache_ref(e); /* the job's own, handed to its first waiter */
    enum work_submit s = compile_join_same(id, false, e, w);
    work_lock_give();
    if (s == WORK_CACHED)
        s = compile_queue_new(id, body, len, -1, check, e, w);
    else if (s != WORK_OK)
        scenes_release(e);
    return s;
}

enum work_submit compile_find_scene(const char *id, struct compile_waiter *w,
                                    struct compile_result *res) {
    memset(res, 0, sizeof *res);
    struct cache_entry *e = scenes_peek(id);
    if (!e || rayd_scene_files(cache_scene(e)) <= COMPILE_INLINE_FILES) {
        if (e && !scenes_current(e, false)) {
            scenes_release(e);
            e = NULL;
        }
        res->scene = e;
        res->hit = e != NULL;
        return WORK_CACHED;
    }
    bool joined;
    work_lock_take();
    enum work_submit s = compile_enqueue(id, NULL, 0, -1, NULL, e, 0, w, &joined);
    work_lock_give();
    if (s != WORK_OK) scenes_release(e);
    return s;
}

/* Parses j (or checks its cached scene) outside the lock: the status, and
 * the scene referenced once (NULL for a GET by id whose files changed);
 * *hit when it was found compiled. */
static enum rayd_status compile_run(struct compile_job *j, struct cache_entry **out, bool *hit,
                                    struct rayd_error *err, bool *full) {
    *hit = false;
    *full = false;
    if (j->check) { /* compile_check_frames: the scene as it came, once its frames pass */
        enum rayd_status st =
            scenes_check_frames(j->body, j->len, j->check_first, j->check_last, &j->cancel, err);
        if (st == RAYD_OK)
            *out = j->cached;
        else
            scenes_release(j->cached);
        *hit = true;
        return st;
    }
    if (j->cached) {
        if (scenes_current(j->cached, j->body != NULL)) {
            *out = j->cached;
            *hit = true;
            return RAYD_OK;
        }
        scenes_release(j->cached);
    }
    if (!j->body) return RAYD_OK; /* unknown here now: the client sends the text again */
    double t0 = clock_now();
    enum rayd_status st =
        scenes_build(j->id, j->body, j->len, j->frame, j->mem, &j->cancel, out, err, full);
    j->mem = 0; /* scenes_build's now: the scene's own, or released */
    double took = clock_now() - t0;
    work_lock_take();
    compile_avg += (took - compile_avg) * 0.2;
    work_lock_give();
    return st;
}

/* Answers j's waiters with st (each its own reference to e) and frees j;
 * no lock held.  draining: refused, nothing was parsed. */
static void compile_answer(struct compile_job *j, enum rayd_status st, struct cache_entry *e,
                           bool hit, const struct rayd_error *err, bool draining, bool full) {
    work_assert_unlocked();
    mem_release(MEM_PARSES, j->mem); /* not parsed: a hit, or a drain */
    work_lock_take();
    for (int i = 1; e && i < j->nwaiters; i++)
        cache_ref(e); /* the first waiter takes the parse's own */
    work_lock_give();
    struct compile_waiter *w = j->waiters;
    bool j_body = j->body != NULL && !j->check; /* a check's scene was counted by its parse */
    free(j);
    while (w) {
        struct compile_waiter *next = w->next;
        struct compile_result res = {
            .status = st, .hit = hit, .draining = draining, .memory_full = full};
        if (err) res.err = *err;
        res.scene = e;
        if (!draining && j_body) metrics_cache(hit);
        w->done(w, &res);
        w = next;
    }
}

/* The link to the queued job to parse next, lock held; NULL when none may
 * start.  A scene a request waits for comes before the frames of
 * frame-range jobs (and cluster items), queued in their hundreds and each
 * parsed in full, and those frames take at most all threads but one: a
 * 2 KB scene of textures that decode to 64 MB each made a new 8x8 scene
 * of another client wait 5 s for its parse, against 1.4 ms.  Among the
 * scenes, the client with the fewest of the last parses started goes
 * first (the oldest of its scenes): 20 such scenes from one client made
 * another's new scene wait 32 s.  In the frames' turns the check of a
 * new job's frames (a POST waits for it) goes before the frames.  A drain
 * takes the queue in order, to refuse it. */
static struct compile_job **compile_pick(bool draining) {
    work_assert_locked();
    struct compile_job **frame = NULL, **scene = NULL;
    int least = COMPILE_RECENT + 1;
    for (struct compile_job **p = &compile_head; *p; p = &(*p)->next) {
        if (draining) return p;
        if (COMPILE_FRAMES_KIND(*p)) {
            if (!frame || ((*p)->check && !(*frame)->check)) frame = p;
            continue;
        }
        int n = compile_recent_count((*p)->client);
        if (n < least) {
            least = n;
            scene = p;
        }
    }
    if (scene) return scene;
    long room = compile_nthreads > 1 ? compile_nthreads - 1 : 1;
    return frame && compile_frames < room ? frame : NULL;
}

/* The next job to parse, lock held, moved to the running list; NULL when
 * the pool stops.  The test gate holds jobs in the queue, until a drain. */
static struct compile_job *compile_next(void) {
    work_assert_locked();
    struct compile_job **at;
    for (;;) {
        if (compile_stopping) return NULL;
        bool draining = sched_draining(); /* a drain lets the held ones be refused */
        at = compile_pick(draining);
        if (at && (compile_gate != 0 || draining)) break;
        if (!at) { /* none queued, or frames only, while others hold their room */
            work_wait(&compile_cond);
            continue;
        }
        struct timespec t; /* held by the test gate: look at the drain again soon */
        clock_gettime(CLOCK_REALTIME, &t);
        t.tv_nsec += 200000000L;
        t.tv_sec += t.tv_nsec / 1000000000L;
        t.tv_nsec %= 1000000000L;
        work_timedwait(&compile_cond, &t);
    }
    struct compile_job *j = *at;
    *at = j->next;
    if (compile_tail == j) /* the queue's last: its new last is before it */
        for (compile_tail = compile_head; compile_tail && compile_tail->next;)
            compile_tail = compile_tail->next;
    compile_queued--;
    compile_frames += COMPILE_FRAMES_KIND(j);
    compile_recent_add(j->client);
    if (compile_gate > 0) compile_gate--;
    compile_started++;
    compile_nrunning++;
    j->next = compile_running;
    compile_running = j;
    return j;
}

static void *compile_thread(void *arg) {
    (void)arg;
    work_lock_take();
    struct compile_job *j;
    while ((j = compile_next()) != NULL) {
        work_lock_give();
        struct rayd_error err = {0};
        struct cache_entry *e = NULL;
        bool hit = false, full = false, draining = sched_draining();
        budget_bind(j->client); /* the parse's charges: its first waiter's client */
        enum rayd_status st = draining ? RAYD_E_CANCELED : compile_run(j, &e, &hit, &err, &full);
        budget_unbind();
        if (draining) scenes_release(j->cached);
        work_lock_take();
        compile_unlink(&compile_running, j); /* no one joins it from now on */
        compile_nrunning--;
        if (COMPILE_FRAMES_KIND(j)) { /* a frame's room is free: a frame queued may start */
            compile_frames--;
            pthread_cond_broadcast(&compile_cond);
        }
        work_lock_give();
        compile_answer(j, st, e, hit, &err, draining, full);
        work_lock_take();
    }
    compile_alive--;
    pthread_cond_broadcast(&compile_cond); /* compile_join */
    work_lock_give();
    return NULL;
}

double compile_retry_seconds(void) {
    work_lock_take();
    double s = compile_avg * (double)(compile_queued + compile_nrunning) /
               (double)(compile_nthreads > 0 ? compile_nthreads : 1);
    work_lock_give();
    return s;
}

/* Joins the threads, waiting up to COMPILE_JOIN_SECONDS for the parses
 * still running; threads not ended by then are left to the exit. */
static bool compile_join(void) {
    struct timespec until;
    clock_gettime(CLOCK_REALTIME, &until);
    until.tv_sec += (time_t)COMPILE_JOIN_SECONDS;
    work_lock_take();
    while (compile_alive > 0 && work_timedwait(&compile_cond, &until) != ETIMEDOUT)
        ;
    bool ended = compile_alive == 0;
    work_lock_give();
    for (int i = 0; i < compile_nthreads; i++) {
        if (ended)
            pthread_join(compile_threads[i], NULL);
        else
            pthread_detach(compile_threads[i]);
    }
    return ended;
}

/* Raises j's cancel flag when none of its waiters wants it, lock held. */
static void compile_unwanted(struct compile_job *j) {
    for (struct compile_waiter *w = j->waiters; w; w = w->next)
        if (!w->dropped) return;
    atomic_store(&j->cancel, 1);
}

void compile_drop(struct compile_waiter *w) {
    work_assert_locked();
    w->dropped = true;
    struct compile_job *lists[] = {compile_head, compile_running};
    for (int i = 0; i < 2; i++)
        for (struct compile_job *j = lists[i]; j; j = j->next)
            for (struct compile_waiter *o = j->waiters; o; o = o->next)
                if (o == w) {
                    compile_unwanted(j);
                    return;
                }
}

void compile_stop(void) {
    work_lock_take();
    compile_stopping = true;
    /* nothing parsed now is wanted: the parses running stop within
     * milliseconds, and the threads are joined */
    for (struct compile_job *j = compile_running; j; j = j->next) atomic_store(&j->cancel, 1);
    struct compile_job *queued = compile_head;
    compile_head = compile_tail = NULL;
    compile_queued = 0;
    pthread_cond_broadcast(&compile_cond);
    work_lock_give();
    while (queued) {
        struct compile_job *next = queued->next;
        scenes_release(queued->cached);
        compile_answer(queued, RAYD_E_CANCELED, NULL, false, NULL, true, false);
        queued = next;
    }
    if (compile_join()) {
        free(compile_threads);
        compile_threads = NULL;
        compile_nthreads = 0;
    }
}

void compile_gate_set(long parses) {
    work_lock_take();
    compile_gate = parses;
    pthread_cond_broadcast(&compile_cond);
    work_lock_give();
}

void compile_gate_get(struct compile_gate_state *g) {
    work_lock_take();
    long waiting = 0;
    for (struct compile_job *j = compile_head; j; j = j->next) waiting += j->nwaiters;
    for (struct compile_job *j = compile_running; j; j = j->next) waiting += j->nwaiters;
    *g = (struct compile_gate_state){compile_gate, compile_started, compile_queued,
                                     compile_nrunning, waiting};
    work_lock_give();
}
