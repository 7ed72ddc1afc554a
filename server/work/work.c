/* work.c -- the one lock of the server, and the condition it signals.
 *
 * Defined in a file of its own, at the bottom of the work layer, because
 * every other work file takes it (work_private.h states the rules): so no
 * file has to call up into the scheduler just to lock.
 */
#include "work/work_private.h"

pthread_mutex_t work_lock = PTHREAD_MUTEX_INITIALIZER;
pthread_cond_t work_cond = PTHREAD_COND_INITIALIZER;
