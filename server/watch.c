/* watch.c -- the watcher thread: hung-up clients, expired jobs, idle
 * streams, renders past --max-render-seconds.
 *
 * libmicrohttpd does not watch a suspended connection, so a client that
 * gives up on a long render would otherwise keep a worker busy for nothing.
 * Every WATCH_MS this thread polls the sockets of every waiter (a request
 * waiting on a render, an event stream waiting for news) for a hang-up --
 * POLLHUP, or EOF on a peek -- and answers such a waiter with "gone"; a
 * task nobody wants any more (no waiter, no job) is cancelled.  The same
 * thread, on the same tick, forgets finished jobs past --job-ttl (jobs.c)
 * every EVENTS_PING_SECONDS seconds wakes idle event streams so they send a
 * keep-alive comment, and stops renders that ran past --max-render-seconds
 * (task_past_deadline).  One thread for the four because each is a small
 * periodic look at the same lists under the same lock.  Once a second it
 * also hands freed heap back to the kernel (mem_trim), outside the lock:
 * malloc_trim is too slow for a request's or a worker's path.
 */
#include "work_private.h"

#include <poll.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <time.h>

#define WATCH_MS 50

static pthread_t watch_thread;
static bool watch_started;
static bool watch_stopping; /* lock held */

/* The sockets to poll, lock held. */
struct watch_set {
    struct pollfd *fds;
    struct work_waiter **ws;
    size_t n, cap;
};

static bool watch_add(struct watch_set *s, struct work_waiter *w)
{
    if (s->n == s->cap) {
        size_t nc = s->cap ? s->cap * 2 : 64;
        struct pollfd *f2 = realloc(s->fds, nc * sizeof *s->fds);
        if (f2)
            s->fds = f2;
        struct work_waiter **w2 = realloc(s->ws, nc * sizeof *s->ws);
        if (w2)
            s->ws = w2;
        if (!f2 || !w2)
            return false;
        s->cap = nc;
    }
    s->fds[s->n] = (struct pollfd){.fd = w->fd, .events = POLLIN};
    s->ws[s->n++] = w;
    return true;
}

/* t's two lists of waiters: 0, the requests waiting on its render; 1, the
 * event streams waiting for news. */
static struct work_waiter **watch_list(struct task *t, int which)
{
    return which ? &t->sse_waiters : &t->waiters;
}

static void watch_collect(struct watch_set *s)
{
    s->n = 0;
    for (struct task *t = task_active; t; t = t->next)
        for (int which = 0; which < 2; which++)
            for (struct work_waiter *w = *watch_list(t, which); w; w = w->next)
                if (w->fd >= 0 && !watch_add(s, w))
                    return;
}

static bool watch_hung_up(const struct pollfd *p)
{
    char c;
    return (p->revents & (POLLHUP | POLLERR | POLLNVAL)) ||
           ((p->revents & POLLIN) && recv(p->fd, &c, 1, MSG_PEEK | MSG_DONTWAIT) == 0);
}

/* Unlinks w from whichever list holds it onto gone; cancels its task when
 * nobody else wants it.  Lock held. */
static void watch_drop(struct work_waiter *w, struct task_notify *gone, struct task_notify *n,
                       struct task_notify *sse)
{
    for (struct task *t = task_active; t; t = t->next)
        for (int which = 0; which < 2; which++)
            for (struct work_waiter **pp = watch_list(t, which); *pp; pp = &(*pp)->next)
                if (*pp == w) {
                    *pp = w->next;
                    w->next = gone->list;
                    gone->list = w;
                    if (!t->waiters && t->njobs == 0)
                        task_cancel(t, MC_CLIENT_GONE, n, sse);
                    return;
                }
}

/* Answers the waiters whose client hung up.  Lock held on entry and exit. */
static void watch_poll(struct watch_set *s)
{
    if (s->n == 0 || poll(s->fds, s->n, 0) <= 0)
        return;
    struct task_notify gone = {0}, n = {0}, sse = {0};
    gone.res.gone = true;
    gone.res.status = RAYD_E_CANCELED;
    for (size_t i = 0; i < s->n; i++)
        if (watch_hung_up(&s->fds[i]))
            watch_drop(s->ws[i], &gone, &n, &sse);
    pthread_mutex_unlock(&work_lock);
    task_notify_run(&gone);
    task_notify_run(&n);
    task_notify_run(&sse);
    pthread_mutex_lock(&work_lock);
}

/* Wakes every idle event stream; true when there was one (the lock was
 * released meanwhile).  Lock held. */
static bool watch_ping(void)
{
    struct task_notify ping = {0};
    for (struct task *t = task_active; t; t = t->next)
        task_notify_add(&ping, &t->sse_waiters);
    if (!ping.list)
        return false;
    pthread_mutex_unlock(&work_lock);
    task_notify_run(&ping);
    pthread_mutex_lock(&work_lock);
    return true;
}

/* Stops the renders past --max-render-seconds; true when one was (the
 * lock was released meanwhile).  Lock held. */
static bool watch_deadlines(void)
{
    struct task_notify n = {0}, sse = {0};
    bool any = false;
    double now = clock_now();
    for (struct task *t = task_active; t; t = t->next)
        if (task_past_deadline(t, now, config.max_render_seconds, &n, &sse)) {
            any = true; /* t may be freed: no t->next now */
            break;
        }
    if (!any)
        return false;
    pthread_mutex_unlock(&work_lock);
    task_notify_run(&n);
    task_notify_run(&sse);
    pthread_mutex_lock(&work_lock);
    return true;
}

static void watch_sleep(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    ts.tv_nsec += WATCH_MS * 1000000L;
    if (ts.tv_nsec >= 1000000000L) {
        ts.tv_sec++;
        ts.tv_nsec -= 1000000000L;
    }
    pthread_cond_timedwait(&work_cond, &work_lock, &ts);
}

static void *watch_main(void *arg)
{
    (void)arg;
    struct watch_set s = {0};
    double last_ping = clock_now(), last_expire = clock_now();
    pthread_mutex_lock(&work_lock);
    while (!watch_stopping) {
        if (clock_now() - last_expire >= 1.0) {
            last_expire = clock_now();
            jobs_expire(last_expire);
            bool idle = task_active == NULL;
            pthread_mutex_unlock(&work_lock);
            mem_trim(idle); /* malloc_trim takes a while: here, off every request's path */
            pthread_mutex_lock(&work_lock);
            if (watch_stopping)
                break;
        }
        watch_collect(&s);
        if (watch_deadlines())
            continue;
        if (clock_now() - last_ping >= EVENTS_PING_SECONDS) {
            last_ping = clock_now();
            if (watch_ping())
                continue;
        }
        watch_poll(&s);
        watch_sleep();
    }
    pthread_mutex_unlock(&work_lock);
    free(s.fds);
    free(s.ws);
    return NULL;
}

int watch_start(void)
{
    if (pthread_create(&watch_thread, NULL, watch_main, NULL))
        return -1;
    watch_started = true;
    return 0;
}

void watch_stop(void)
{
    pthread_mutex_lock(&work_lock);
    watch_stopping = true;
    pthread_cond_broadcast(&work_cond);
    pthread_mutex_unlock(&work_lock);
    if (watch_started)
        pthread_join(watch_thread, NULL);
    watch_started = false;
}
