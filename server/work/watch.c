/* watch.c -- the watcher thread: hung-up clients, expired jobs, idle
 * streams, renders past --max-render-seconds.
 *
 * libmicrohttpd does not watch a suspended connection, so a client that
 * gives up on a long render would otherwise keep a worker busy for nothing.
 * Every WATCH_MS this thread polls the sockets of every waiter (a request
 * waiting on a render, an event stream waiting for news) for a hang-up --
 * POLLHUP, or EOF on a peek -- and answers such a waiter with "gone"; a
 * task nobody wants any more (no waiter, no job) is cancelled.  A frame-range
 * job's streams wait on the job, not on a task (shots.c hands them down as
 * hooks), and are polled and pinged the same way.  The same
 * thread, on the same tick, forgets finished jobs past --job-ttl (jobs.c)
 * every EVENTS_PING_SECONDS seconds wakes idle event streams so they send a
 * keep-alive comment, and stops renders that ran past --max-render-seconds
 * (task_past_deadline).  One thread for the four because each is a small
 * periodic look at the same lists under the same lock.  Once a second it
 * also hands freed heap back to the kernel (mem_trim), outside the lock:
 * malloc_trim is too slow for a request's or a worker's path; and starts
 * again the frame-range jobs whose frames were refused for room (shots.c's
 * kick), which nothing else may be left to do.
 */
#include "work/work_private.h"

#include <poll.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <time.h>

#define WATCH_MS 50

static pthread_t watch_thread;
static bool watch_started;
static bool watch_stopping;     /* lock held */
static bool watch_drain_pinged; /* the streams were woken at the drain's start (lock held) */
/* shots.c's streams (watch_streams_hooks): it sits above this file */
static struct work_waiter **(*watch_shots)(int i);
static bool (*watch_shots_unwait)(struct work_waiter *w, struct task_notify *gone);
static void (*watch_shots_kick)(void);

void watch_streams_hooks(struct work_waiter **(*streams)(int i),
                         bool (*unwait)(struct work_waiter *w, struct task_notify *gone),
                         void (*kick)(void)) {
    watch_shots = streams;
    watch_shots_unwait = unwait;
    watch_shots_kick = kick;
}

/* The sockets to poll, lock held. */
struct watch_set {
    struct pollfd *fds;
    struct work_waiter **ws;
    size_t n, cap;
};

static bool watch_add(struct watch_set *s, struct work_waiter *w) {
    work_assert_locked();
    if (s->n == s->cap) {
        size_t nc = s->cap ? s->cap * 2 : 64;
        struct pollfd *f2 = realloc(s->fds, nc * sizeof *s->fds);
        if (f2) s->fds = f2;
        struct work_waiter **w2 = realloc(s->ws, nc * sizeof *s->ws);
        if (w2) s->ws = w2;
        if (!f2 || !w2) return false;
        s->cap = nc;
    }
    s->fds[s->n] = (struct pollfd){.fd = w->fd, .events = POLLIN};
    s->ws[s->n++] = w;
    return true;
}

/* t's two lists of waiters: 0, the requests waiting on its render; 1, the
 * event streams waiting for news. */
static struct work_waiter **watch_list(struct task *t, int which) {
    return which ? &t->sse_waiters : &t->waiters;
}

/* Every waiter with a socket: the tasks' and the frame-range jobs'
 * event streams (shots.c), which wait on no task between frames. */
static void watch_collect(struct watch_set *s) {
    s->n = 0;
    for (struct task *t = task_active; t; t = t->next)
        for (int which = 0; which < 2; which++)
            for (struct work_waiter *w = *watch_list(t, which); w; w = w->next)
                if (w->fd >= 0 && !watch_add(s, w)) return;
    struct work_waiter **l;
    for (int i = 0; watch_shots && (l = watch_shots(i)); i++)
        for (struct work_waiter *w = *l; w; w = w->next)
            if (w->fd >= 0 && !watch_add(s, w)) return;
}

static bool watch_hung_up(const struct pollfd *p) {
    char c;
    return (p->revents & (POLLHUP | POLLERR | POLLNVAL)) ||
           ((p->revents & POLLIN) && recv(p->fd, &c, 1, MSG_PEEK | MSG_DONTWAIT) == 0);
}

/* w off whichever task holds it, onto gone (task.c owns the lists); its
 * task cancelled when nobody else wants it.  Lock held. */
static void watch_drop(struct work_waiter *w, struct task_notify *gone, struct task_notify *n,
                       struct task_notify *sse) {
    work_assert_locked();
    for (struct task *t = task_active; t; t = t->next)
        if (task_unwait(t, w, gone, n, sse)) return;
    if (watch_shots_unwait) watch_shots_unwait(w, gone);
}

/* The waiters whose client hung up, onto gone (their tasks cancelled
 * when nobody else wants them: onto n and sse).  Lock held. */
static void watch_poll(struct watch_set *s, struct task_notify *gone, struct task_notify *n,
                       struct task_notify *sse) {
    work_assert_locked();
    if (s->n == 0 || poll(s->fds, s->n, 0) <= 0) return;
    for (size_t i = 0; i < s->n; i++)
        if (watch_hung_up(&s->fds[i])) watch_drop(s->ws[i], gone, n, sse);
}

/* Every idle event stream, onto ping, to be woken.  Lock held. */
static void watch_ping(struct task_notify *ping) {
    work_assert_locked();
    for (struct task *t = task_active; t; t = t->next) task_notify_add(ping, &t->sse_waiters);
    struct work_waiter **l;
    for (int i = 0; watch_shots && (l = watch_shots(i)); i++) task_notify_add(ping, l);
}

/* Stops a render past --max-render-seconds, its waiters onto n and sse;
 * true when one was.  Lock held. */
static bool watch_deadlines(struct task_notify *n, struct task_notify *sse) {
    work_assert_locked();
    double now = clock_now();
    for (struct task *t = task_active; t; t = t->next)
        if (task_past_deadline(t, now, config.max_render_seconds, n, sse))
            return true; /* t may be freed: no t->next now */
    return false;
}

/* One look round, lock held: what to answer onto gone, n and sse; true
 * when the watcher looks again at once (a deadline or a keep-alive was
 * due), false when it sleeps first. */
/* Once a second the watcher gives freed heap back, without the lock; idle:
 * no render runs, so the core's kept blocks may go too (mem_trim). */
struct watch_trim {
    bool due, idle;
};

static bool watch_round(struct watch_set *s, double *last_expire, double *last_ping,
                        struct task_notify *gone, struct task_notify *n, struct task_notify *sse,
                        struct watch_trim *trim) {
    work_assert_locked();
    watch_collect(s);
    if (clock_now() - *last_expire >= 1.0) {
        *last_expire = clock_now();
        jobs_expire(*last_expire);
        trim->due = true;
        trim->idle = task_active == NULL;
    }
    if (watch_deadlines(n, sse)) return true;
    /* at the drain's start every stream looks whether its job's part in
     * it is over (events.c, shots_events.c); after that a task's end or a
     * frame's wakes them, as ever */
    bool drain_start = task_draining() && !watch_drain_pinged;
    if (drain_start || clock_now() - *last_ping >= EVENTS_PING_SECONDS) {
        watch_drain_pinged |= drain_start;
        *last_ping = clock_now();
        watch_ping(n);
        if (n->list) return true;
    }
    watch_poll(s, gone, n, sse);
    return false;
}

static void watch_sleep(void) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    ts.tv_nsec += WATCH_MS * 1000000L;
    if (ts.tv_nsec >= 1000000000L) {
        ts.tv_sec++;
        ts.tv_nsec -= 1000000000L;
    }
    work_timedwait(&work_cond, &ts);
}

static void *watch_main(void *arg) {
    (void)arg;
    struct watch_set s = {0};
    double last_ping = clock_now(), last_expire = clock_now();
    work_lock_take();
    while (!watch_stopping) {
        struct task_notify gone = {.res = {.gone = true, .status = RAYD_E_CANCELED}};
        struct task_notify n = {0}, sse = {0};
        struct watch_trim trim = {0};
        bool again = watch_round(&s, &last_expire, &last_ping, &gone, &n, &sse, &trim);
        /* n may hold a finished task's image with no waiter to take it (a
         * job stopped by its deadline): task_notify_run drops it */
        bool due = gone.list || n.list || n.res.png || sse.list || sse.res.png;
        if (due || trim.due) { /* without the lock */
            work_lock_give();
            task_notify_run(&gone);
            task_notify_run(&n);
            task_notify_run(&sse);
            if (trim.due) /* malloc_trim takes a while: here, off every request's path */
                mem_trim(trim.idle);
            if (trim.due && watch_shots_kick) watch_shots_kick();
            work_lock_take();
        }
        if (!again) watch_sleep();
    }
    work_lock_give();
    free(s.fds);
    free(s.ws);
    return NULL;
}

int watch_start(void) {
    if (pthread_create(&watch_thread, NULL, watch_main, NULL)) return -1;
    watch_started = true;
    return 0;
}

void watch_stop(void) {
    work_lock_take();
    watch_stopping = true;
    pthread_cond_broadcast(&work_cond);
    work_lock_give();
    if (watch_started) pthread_join(watch_thread, NULL);
    watch_started = false;
}
