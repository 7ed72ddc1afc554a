/* work.c -- the one lock of the server, and the condition it signals.
 *
 * Defined in a file of its own, at the bottom of the work layer, because
 * every other work file takes it (work_private.h states the rules): so no
 * file has to call up into the scheduler just to lock.
 *
 * The lock knows its owner: every work file takes and releases it through
 * work_lock_take / work_lock_give (and waits through work_wait), which
 * note the owning thread, so the "lock held" contracts written on the
 * functions are checked (work_assert_locked), not only stated.  A thread is
 * named by the address of a thread-local byte of its own: unique among the
 * live threads, comparable atomically, with no pthread_t arithmetic.
 */
#include "work/work_private.h"

static pthread_mutex_t work_lock = PTHREAD_MUTEX_INITIALIZER;
pthread_cond_t work_cond = PTHREAD_COND_INITIALIZER;

static _Thread_local char work_me;
static _Atomic(const char *) work_owner; /* &work_me of the holder, NULL free */

void work_lock_take(void) {
    work_assert_unlocked(); /* it is no recursive mutex: this thread would hang */
    pthread_mutex_lock(&work_lock);
    atomic_store_explicit(&work_owner, &work_me, memory_order_relaxed);
}

void work_lock_give(void) {
    work_assert_locked();
    atomic_store_explicit(&work_owner, NULL, memory_order_relaxed);
    pthread_mutex_unlock(&work_lock);
}

bool work_locked(void) {
    return atomic_load_explicit(&work_owner, memory_order_relaxed) == &work_me;
}

void work_wait(pthread_cond_t *c) {
    work_assert_locked();
    atomic_store_explicit(&work_owner, NULL, memory_order_relaxed);
    pthread_cond_wait(c, &work_lock);
    atomic_store_explicit(&work_owner, &work_me, memory_order_relaxed);
}

int work_timedwait(pthread_cond_t *c, const struct timespec *until) {
    work_assert_locked();
    atomic_store_explicit(&work_owner, NULL, memory_order_relaxed);
    int rc = pthread_cond_timedwait(c, &work_lock, until);
    atomic_store_explicit(&work_owner, &work_me, memory_order_relaxed);
    return rc;
}
