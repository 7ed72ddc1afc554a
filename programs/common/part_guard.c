/* part_guard.c -- part files removed when a signal ends the program.
 *
 * A signal that ends rayd-render or rayd-client while a part file is
 * written (output.c's FILE.PID.part, the video's that ffmpeg writes) would
 * leave that file behind: SIGTERM from a service manager, timeout(1) or
 * kill; SIGINT, Ctrl-C; SIGHUP, the terminal gone.  So from a part file's
 * making to its rename or removal it is guarded: each of those signals
 * whose action is the default is caught (part_guard_on_signal), the child
 * writing the file (ffmpeg) killed and waited for (a live one could make
 * the name again), every guarded file removed, and the process ended by
 * the same signal, its default action back, so the exit status is 128 + N
 * as before.  A signal the program handles itself (rayd-client's Ctrl-C,
 * which cancels its job and returns through output_abort) or ignores (a
 * background job's SIGINT) is left as it is.
 *
 * The handler makes only async-signal-safe calls (kill, waitpid, unlink,
 * sigaction, raise) on what was set before it was armed; the caller holds
 * the signals (part_guard_hold) while it makes, guards, renames, removes
 * or lets go of a part file, so the handler never races those.  The hold
 * is the calling thread's: both programs make, rename and remove their
 * part files while no other thread of theirs runs (the render's and the
 * encoder's threads are joined inside each call), so a signal finds only
 * that thread to run on.  A few
 * files at once (a frame's file beside the video's); the actions are taken
 * over with the first and put back with the last.
 */
#include "common/common.h"

#include <errno.h>
#include <pthread.h>
#include <signal.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#define PART_GUARD_FILES 4
static const int part_guard_sigs[] = {SIGTERM, SIGINT, SIGHUP};
#define PART_GUARD_NSIGS (sizeof part_guard_sigs / sizeof part_guard_sigs[0])
static struct sigaction part_guard_old[PART_GUARD_NSIGS];
static bool part_guard_taken[PART_GUARD_NSIGS];
static char part_guard_files[PART_GUARD_FILES][4200]; /* "" where free */
static int part_guard_n;
static volatile sig_atomic_t part_guard_pid; /* the writing child, 0 when none */

static void part_guard_on_signal(int sig) {
    pid_t pid = (pid_t)part_guard_pid;
    if (pid > 0) {
        kill(pid, SIGKILL);
        while (waitpid(pid, NULL, 0) < 0 && errno == EINTR) continue;
        part_guard_pid = 0; /* reaped: its pid may be another's now */
    }
    for (int i = 0; i < PART_GUARD_FILES; i++)
        if (part_guard_files[i][0]) unlink(part_guard_files[i]);
    /* every one taken back to its default, not only sig (SA_RESETHAND):
     * another held meanwhile must end the process, not run this again */
    struct sigaction dfl;
    memset(&dfl, 0, sizeof dfl);
    dfl.sa_handler = SIG_DFL;
    for (size_t i = 0; i < PART_GUARD_NSIGS; i++)
        if (part_guard_taken[i]) sigaction(part_guard_sigs[i], &dfl, NULL);
    raise(sig); /* held until this returns */
}

void part_guard_hold(sigset_t *old) {
    sigset_t set;
    sigemptyset(&set);
    for (size_t i = 0; i < PART_GUARD_NSIGS; i++) sigaddset(&set, part_guard_sigs[i]);
    pthread_sigmask(SIG_BLOCK, &set, old);
}

void part_guard_release(const sigset_t *old) { pthread_sigmask(SIG_SETMASK, old, NULL); }

/* The signals whose action is the default, caught. */
static void part_guard_take(void) {
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = part_guard_on_signal;
    sa.sa_flags = SA_RESETHAND;
    sigemptyset(&sa.sa_mask);
    for (size_t i = 0; i < PART_GUARD_NSIGS; i++) sigaddset(&sa.sa_mask, part_guard_sigs[i]);
    for (size_t i = 0; i < PART_GUARD_NSIGS; i++) {
        part_guard_taken[i] = sigaction(part_guard_sigs[i], NULL, &part_guard_old[i]) == 0 &&
                              part_guard_old[i].sa_handler == SIG_DFL &&
                              !(part_guard_old[i].sa_flags & SA_SIGINFO);
        if (part_guard_taken[i]) sigaction(part_guard_sigs[i], &sa, NULL);
    }
}

bool part_guard_arm(const char *part) {
    if (strlen(part) >= sizeof part_guard_files[0]) return false;
    for (int i = 0; i < PART_GUARD_FILES; i++)
        if (!part_guard_files[i][0]) {
            if (part_guard_n++ == 0) part_guard_take();
            memcpy(part_guard_files[i], part, strlen(part) + 1);
            return true;
        }
    return false;
}

void part_guard_child(pid_t pid) { part_guard_pid = (sig_atomic_t)pid; }

void part_guard_disarm(const char *part) {
    for (int i = 0; i < PART_GUARD_FILES; i++)
        if (part_guard_files[i][0] && !strcmp(part_guard_files[i], part)) {
            part_guard_files[i][0] = '\0';
            if (--part_guard_n > 0) return;
            for (size_t k = 0; k < PART_GUARD_NSIGS; k++)
                if (part_guard_taken[k]) sigaction(part_guard_sigs[k], &part_guard_old[k], NULL);
            part_guard_pid = 0;
            return;
        }
}
