/* videoq.c -- the video thread: the frame-range jobs' videos, one at a
 * time, in the order their jobs finished.
 *
 * Making a video runs ffmpeg for up to a minute or more (server/base's
 * video.c), so it has a thread of its own, off the workers, the parse
 * threads and the HTTP threads; one video at a time, since each ffmpeg
 * takes a core of its own.  The thread starts with the first video asked
 * for (a server that makes none has none), and is started again at the
 * next one if it could not be.  What a video is made of is the caller's
 * (shots.c hands in its make function): this file only queues and runs.
 * At the server's stop (videoq_stop) the video being made is given up
 * (video_stop kills its ffmpeg) and those queued run at once to their
 * failure, so each lets go of what it holds; the stop waits for that.
 */
#include "work/work_private.h"

#include <errno.h>
#include <stdlib.h>
#include <time.h>

struct videoq_item {
    void (*make)(void *arg);
    void *arg;
    struct videoq_item *next;
};

static struct videoq_item *videoq_head; /* lock held */
static pthread_cond_t videoq_cond = PTHREAD_COND_INITIALIZER;
static pthread_cond_t videoq_idle = PTHREAD_COND_INITIALIZER; /* the queue ran dry */
static bool videoq_started;
static bool videoq_busy; /* an item's make runs (lock held) */

static void *videoq_thread(void *arg) {
    (void)arg;
    work_lock_take();
    for (;;) {
        while (!videoq_head) {
            pthread_cond_broadcast(&videoq_idle);
            work_wait(&videoq_cond);
        }
        struct videoq_item *q = videoq_head;
        videoq_head = q->next;
        videoq_busy = true;
        work_lock_give();
        q->make(q->arg);
        free(q);
        work_lock_take();
        videoq_busy = false;
    }
    return NULL;
}

bool videoq_add(void (*make)(void *arg), void *arg) {
    work_assert_locked();
    if (!videoq_started) {
        pthread_t t;
        videoq_started = pthread_create(&t, NULL, videoq_thread, NULL) == 0;
        if (videoq_started) pthread_detach(t); /* it lives as long as the process */
    }
    struct videoq_item *q = videoq_started ? calloc(1, sizeof *q) : NULL;
    if (!q) return false;
    q->make = make;
    q->arg = arg;
    struct videoq_item **p = &videoq_head;
    while (*p) p = &(*p)->next;
    *p = q;
    pthread_cond_signal(&videoq_cond);
    return true;
}

void videoq_stop(double seconds) {
    video_stop();
    struct timespec until;
    clock_gettime(CLOCK_REALTIME, &until);
    until.tv_sec += (time_t)seconds;
    work_lock_take();
    while (videoq_started && (videoq_head || videoq_busy) &&
           work_timedwait(&videoq_idle, &until) != ETIMEDOUT)
        ;
    work_lock_give();
}
