/* shots_video.c -- a frame-range job's video: made once every frame is
 * done, on the video thread (videoq.c) from the frames in memory or read
 * back from --data-dir, by ffmpeg (base/video.c), and kept in memory
 * until the budget lets it go (shots.c); then made again from the frames'
 * files when asked for, as after a restart.
 */
#include "work/shots_private.h"

#include <stdio.h>
#include <stdlib.h>

/* Seconds ffmpeg may take for a video of n frames before it is stopped. */
#define SHOTS_VIDEO_SECONDS(n) (60.0 + 2.0 * (n))

/* s's frames (referenced, read from disk if need be), then the video made
 * without the lock and kept (on the video thread, videoq.c). */
static void shots_video_make(void *arg) {
    struct shot *s = arg;
    struct blob **frames = calloc((size_t)s->n, sizeof *frames);
    work_lock_take();
    for (int i = 0; frames && i < s->n; i++) frames[i] = blob_ref(s->f[i].png);
    work_lock_give();
    int missing = -1; /* the first frame not read */
    for (int i = 0; frames && i < s->n; i++) {
        if (!frames[i] && store_on()) frames[i] = store_read_frame(s->id, s->first + i, false);
        if (!frames[i] && missing < 0) missing = i;
    }
    bool whole = frames && missing < 0;
    struct blob *mp4 = NULL;
    char err[200] = "out of memory for the frames";
    if (frames && missing >= 0) /* its file gone from --data-dir, or no memory to read it */
        snprintf(err, sizeof err, "frame %ld could not be read back", s->first + missing);
    enum video_status st = whole ? video_encode(frames, s->n, s->fps > 0 ? s->fps : 24,
                                                SHOTS_VIDEO_SECONDS(s->n), &mp4, err, sizeof err)
                                 : VIDEO_FAILED;
    for (int i = 0; frames && i < s->n; i++) blob_unref(frames[i]);
    free(frames);
    work_lock_take();
    bool evicted = missing >= 0 && s->f[missing].gone != SG_KEPT;
    if (evicted)
        snprintf(err, sizeof err,
                 "frame %ld was let go before the video was made (%s); a video needs every frame: "
                 "render the range again",
                 s->first + missing, s->f[missing].gone == SG_DISK ? "--max-disk" : "--max-memory");
    s->video = mp4;
    s->video_used = clock_now();
    s->video_state = st == VIDEO_OK ? SV_READY : st == VIDEO_NO_FFMPEG ? SV_NO_FFMPEG : SV_FAILED;
    if (evicted) s->video_state = SV_EVICTED; /* never made: its frame is missing */
    snprintf(s->video_error, sizeof s->video_error, "%s", st == VIDEO_OK ? "" : err);
    if (st != VIDEO_OK) log_warn("job %s: no video: %s", s->id, err);
    shots_unref(s);
    work_lock_give();
}

/* s has every frame: its video queued for the video thread (lock held). */
void shots_video_queue(struct shot *s) {
    s->refs++; /* the video's, let go by shots_video_make */
    if (!videoq_add(shots_video_make, s)) {
        s->refs--;
        s->video_state = SV_FAILED;
        snprintf(s->video_error, sizeof s->video_error, "no thread or memory to make the video");
        return;
    }
    s->video_state = SV_MAKING;
}

struct blob *shots_video(const char *id, struct shots_info *info) {
    work_lock_take();
    struct shot *s = shots_find(id);
    struct blob *b = NULL;
    if (s && s->video_state == SV_NONE && s->ndone == s->n && store_on())
        shots_video_queue(s); /* let go for the memory budget: made again from the files */
    if (s) {
        shots_info_of(s, info);
        b = blob_ref(s->video);
        if (b) s->video_used = clock_now(); /* the budget lets go of the least used first */
    }
    work_lock_give();
    if (!s) info->job.id[0] = 0;
    return b;
}
