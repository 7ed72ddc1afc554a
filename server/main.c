/* main.c -- rayd: start, serve, drain, stop.
 *
 * Start-up order: options (config.c), the work layer (sched.c: caches, jobs,
 * workers, watcher), the jobs of --data-dir (durable.c), the route labels (router.c), then the
 * listener (http.c); each registers its gauges with metrics.c as it starts.  Only when the socket
 * is bound is the line "rayd listening on http://HOST:PORT" printed and flushed, as the first and
 * only line on stdout, so scripts can start `rayd --port 0` and read the
 * port.  Logs go to stderr.
 *
 * Signals are blocked in every thread and taken synchronously by the main
 * thread with sigwaitinfo, so no work happens in a signal handler.  On the
 * first SIGTERM or SIGINT the server drains:
 *   1. /readyz turns 503 and new work is refused with 503 "draining";
 *   2. running and queued renders get --drain-seconds to finish;
 *   3. whatever is left is cancelled (the core sees it within milliseconds,
 *      whatever one pixel costs) and every suspended connection is
 *      answered (a synchronous render: 503 draining);
 *   4. the listener stays up, answering "draining", until no request has
 *      come for 0.2 s (2 s at most): a client that raced the shutdown -- a
 *      retry after "busy", a connection the kernel had already queued --
 *      gets an answer rather than a reset;
 *   5. the listener stops -- never with a suspended connection -- the pool
 *      is joined, everything is freed, and the exit status is 0.
 *
 * The drain always ends.  From the first signal on, a guard thread takes
 * the signals instead of the main thread (which may be blocked in a join:
 * a connection thread still parsing or building a big scene, which no
 * cancel reaches).  A second SIGTERM or SIGINT ends the process at once:
 * status 0 when every render had been answered already (only the
 * listener's last steps were left), else 128 + the signal (143, 130), as a
 * shell reports a process that signal killed.  And whatever happens,
 * MAIN_STOP_GRACE seconds after --drain-seconds the guard ends the process
 * with status 0, after a warning: the renders were all cancelled and
 * answered by then; only work on connection threads can still be going.
 *
 * SIGHUP, SIGUSR1 and SIGUSR2 are taken the same way and only logged:
 * rayd has no configuration to reload nor a log file to reopen, and their
 * default action would end the process at once, without a drain, dropping
 * every render in flight (an operator's reflexive "reload", a closed
 * terminal).  Changing an option is a restart: SIGTERM, then start again.
 *
 * Layer: main, above everything; the only file that starts and stops the
 * layers, so none of them needs to know another's life cycle.
 */
#include "route/router.h"
#include "net/transport.h"
#include "cluster/cluster.h"
#include "work/work.h"

#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>
#include <fcntl.h>
#include <time.h>
#include <unistd.h>

/* Seconds past --drain-seconds the drain may take at most (cancelled
 * renders stop within milliseconds; this is for the connection threads and
 * the listener's quiet period). */
#define MAIN_STOP_GRACE 8.0

static double main_stop_by;       /* set before the guard starts */
static atomic_bool main_answered; /* every render cancelled and answered */

/* True for SIGTERM and SIGINT, which stop the server; any other signal
 * taken (SIGHUP, SIGUSR1, SIGUSR2) is logged and changes nothing. */
static bool main_stop_signal(int sig) {
    if (sig == SIGTERM || sig == SIGINT) return true;
    if (sig > 0)
        log_info("signal %d ignored: rayd has nothing to reload or reopen (restart it to change "
                 "an option; SIGTERM drains)",
                 sig);
    return false;
}

/* Waits up to seconds for cond() (the guard takes the signals meanwhile). */
static bool main_wait(bool (*cond)(void), double seconds) {
    double end = clock_now() + seconds;
    while (!cond()) {
        if (clock_now() >= end) return false;
        struct timespec ts = {0, 20 * 1000000L};
        nanosleep(&ts, NULL);
    }
    return true;
}

static sigset_t main_guard_set; /* the guard's own copy: it outlives main's frame */

/* The guard of the drain (see the top): a second stop signal, or the
 * drain's time bound, ends the process at once. */
static void *main_guard(void *arg) {
    const sigset_t *set = arg;
    for (;;) {
        struct timespec ts = {0, 50 * 1000000L};
        int sig = sigtimedwait(set, NULL, &ts);
        if (sig == SIGTERM || sig == SIGINT) {
            bool done = atomic_load(&main_answered);
            log_warn("signal %d during the drain: exiting at once (status %d)", sig,
                     done ? 0 : 128 + sig);
            fflush(stderr);
            _exit(done ? 0 : 128 + sig);
        }
        main_stop_signal(sig); /* SIGHUP and the others: logged */
        if (clock_now() >= main_stop_by) {
            log_warn("drain: not stopped %.0f s after --drain-seconds (work on a connection "
                     "thread?); exiting",
                     MAIN_STOP_GRACE);
            fflush(stderr);
            _exit(0);
        }
    }
    return NULL;
}

static bool main_no_suspended(void) { return http_req_suspended() == 0; }
static bool main_no_requests(void) { return http_req_in_flight() == 0; }
static bool main_quiet(void) {
    return http_req_in_flight() == 0 && clock_now() - http_req_last() >= 0.2;
}

/* A process started with stdin, stdout or stderr closed would hand those
 * numbers to its first sockets, and a log line would go to a client: point
 * any closed one at /dev/null first. */
static void main_std_fds(void) {
    for (int fd = 0; fd <= 2; fd++)
        if (fcntl(fd, F_GETFD) < 0 && errno == EBADF) {
            int n = open("/dev/null", fd == 0 ? O_RDONLY : O_WRONLY);
            if (n >= 0 && n != fd) {
                dup2(n, fd);
                close(n);
            }
        }
}

/* A start that failed once the jobs of --data-dir were back: stopped as a
 * drain stops them, parses and the store first, so the pool's cancels are
 * not written (the jobs stay queued on disk) and the store is marked
 * clean (no attempt counted against them).  Before, a port already in use
 * wrote every restored job as cancelled. */
static void main_unwind(void) {
    compile_stop();
    durable_stop();
    sched_stop();
}

/* The worker pool, the router and the listener, with the signals the
 * main thread waits for blocked in every thread: 0, or 1 after saying why. */
static int main_start(sigset_t *set) {
    metrics_start(config.max_render_seconds);
    sigemptyset(set);
    sigaddset(set, SIGTERM);
    sigaddset(set, SIGINT);
    sigaddset(set, SIGHUP);
    sigaddset(set, SIGUSR1);
    sigaddset(set, SIGUSR2);
    pthread_sigmask(SIG_BLOCK, set, NULL);
    /* shots first: it hands the watcher, jobs.c and the store its hooks,
     * which their threads read from the moment sched_start starts them */
    if (!shots_start((int)config.max_jobs) ||
        sched_start((int)config.threads, (int)config.queue, (int)config.max_jobs)) {
        fprintf(stderr, "rayd: error: cannot start the worker pool\n");
        return 1;
    }
    if (!compile_start()) {
        fprintf(stderr, "rayd: error: cannot start the parse threads\n");
        compile_stop();
        sched_stop();
        return 1;
    }
    if (config.test_gate_tiles >= -1) {
        gate_enable(config.test_gate_tiles);
        log_warn("--test-gate: workers start tiles only as POST /v1/test/gate allows");
    }
    if (durable_start()) { /* --data-dir: its jobs back before anyone can ask */
        durable_stop();
        compile_stop();
        sched_stop();
        return 1;
    }
    router_start();
    if (http_start()) {
        main_unwind();
        return 1;
    }
    if (!cluster_start(http_port())) { /* --redis: the puller and the request thread */
        fprintf(stderr, "rayd: error: cannot start the cluster's threads\n");
        http_stop();
        main_unwind();
        return 1;
    }
    return 0;
}

/* The warning when anyone may reach rayd, and the one line on standard
 * output that says where it listens (scripts and tests read it). */
static void main_announce(void) {
    if (!config_loopback(config.bind) && !config.token) {
        fprintf(stderr,
                "\n"
                "************************************************************************\n"
                "* WARNING: rayd listens on %s without --token-file.\n"
                "* Anyone who can reach this address can make it render.\n"
                "* Use --token-file FILE, or bind to 127.0.0.1 behind a proxy.\n"
                "************************************************************************\n\n",
                config.bind);
    }
    const char *host = strchr(config.bind, ':') ? NULL : config.bind;
    const char *scheme = http_tls() ? "https" : "http";
    int w;
    if (host)
        w = printf("rayd listening on %s://%s:%d\n", scheme, host, http_port());
    else
        w = printf("rayd listening on %s://[%s]:%d\n", scheme, config.bind, http_port());
    if (w < 0 || fflush(stdout) != 0) /* stdout closed or full: keep serving */
        log_warn("cannot write the listening line to stdout: %s", strerror(errno));
    log_info("rayd %s: %ld workers, queue %ld, max body %ld, max pixels %ld, cache %ld MiB%s",
             RAYD_VERSION, config.threads, config.queue, config.max_body, config.max_pixels,
             config.cache_mb, config.token ? ", token required" : "");
}

/* After SIGTERM or SIGINT: new work refused, the work in flight given
 * --drain-seconds, the rest cancelled, then the connections answered and
 * the listener stopped; the guard bounds it all (see the top).  Should
 * connections stay suspended, rayd exits here (status 1), without
 * cleanup. */
static void main_drain(int sig, sigset_t *set) {
    log_info("signal %d: draining (up to %ld s)", sig, config.drain_seconds);
    main_stop_by = clock_now() + (double)config.drain_seconds + MAIN_STOP_GRACE;
    pthread_t guard;
    main_guard_set = *set;
    if (pthread_create(&guard, NULL, main_guard, &main_guard_set) == 0) pthread_detach(guard);
    sched_drain();
    cluster_drain();
    if (!main_wait(sched_idle, (double)config.drain_seconds))
        log_info("drain: deadline, cancelling what is left");
    sched_cancel_all();
    main_wait(sched_idle, MAIN_STOP_GRACE / 2);
    main_wait(main_no_suspended, MAIN_STOP_GRACE / 2);
    if (sched_idle() && http_req_suspended() == 0) atomic_store(&main_answered, true);
    main_wait(main_no_requests, 2);
    main_wait(main_quiet, 2);
    if (http_req_suspended() > 0) {
        /* never stop libmicrohttpd with suspended connections */
        log_warn("drain: %ld connections still suspended; exiting without cleanup",
                 http_req_suspended());
        fflush(stderr);
        _exit(1);
    }
    http_stop();
    cluster_stop(); /* before the pool: its renders answer into the puller's items */
    compile_stop();
    durable_stop(); /* what is queued is written; unfinished jobs stay queued on disk */
    sched_stop();
    shots_stop();
}

int main(int argc, char **argv) {
    main_std_fds();
    /* a write to a closed pipe or socket is an error return, never a signal */
    signal(SIGPIPE, SIG_IGN);
    int rc = config_load(argc, argv);
    if (rc == CONFIG_RUN && cluster_configure()) rc = CONFIG_USAGE;
    if (rc != CONFIG_RUN) {
        if (rc == CONFIG_USAGE) fprintf(stderr, "Try 'rayd --help'.\n");
        config_free();
        return rc == CONFIG_DONE ? 0 : rc == CONFIG_FAILED ? 1 : 2;
    }
    sigset_t set;
    if (main_start(&set)) {
        config_free();
        return 1;
    }
    main_announce();
    int sig = 0;
    do sig = sigwaitinfo(&set, NULL);
    while (!main_stop_signal(sig));
    main_drain(sig, &set);
    metrics_free();
    log_info("stopped");
    config_free();
    return 0;
}
