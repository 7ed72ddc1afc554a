/* video.c -- a frame-range job's frames as an H.264 MP4, made by the
 * `ffmpeg` program, as rayd-render --video makes it.
 *
 * The frames are PNGs already (the job's); they go to a folder of their
 * own under $TMPDIR (frame-000000.png, ...), ffmpeg reads them with its
 * image2 reader and writes out.mp4 there with the options rayd-render
 * uses (libx264, yuv420p, preset veryfast, crf 18, +faststart, an odd
 * width or height padded to even), on one thread (the video thread is one
 * core beside the workers, not all of them: left to choose, ffmpeg took
 * both of the host's cores for 3.4 s of a 100-frame 2048 x 2048 video),
 * and the folder is removed.  ffmpeg is a program, not a library, for the
 * reason rayd-render gives: Debian's
 * package is everywhere, and a crash of the encoder cannot take rayd with
 * it.  Its time is bounded: past the limit it is killed and the video
 * fails saying so.  This runs on the caller's thread and blocks for the
 * encode's time: never call it on an HTTP thread (shots.c has a thread
 * of its own).  Its standard error goes to a file whose last line is the
 * message of a failure.  That message goes to the client (the job's
 * video_failed) without the folder's path, which is the server's business:
 * the whole line, path and all, is in the server's log.
 *
 * A server that stops while a video is made (video_stop) kills its ffmpeg
 * and removes the folder: left running, ffmpeg outlived rayd and wrote its
 * out.mp4 into a folder nobody removed, a folder of frames in $TMPDIR for
 * each restart mid-video.  A rayd killed outright cannot clean up, so the
 * folder's name carries its PID (rayd-video-PID-XXXXXX) and the next
 * server's start removes the folders of PIDs no longer running
 * (video_sweep).
 */
#include "base/base.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

/* Raised by video_stop: no video is begun, and a running ffmpeg is killed. */
static atomic_bool video_stopping;

/* The folders' name before the PID: rayd-video-PID-XXXXXX. */
#define VIDEO_DIR_PREFIX "rayd-video-"

void video_stop(void) { atomic_store(&video_stopping, true); }

/* $TMPDIR, or /tmp. */
static const char *video_tmp(void) {
    const char *base = getenv("TMPDIR");
    return base && *base ? base : "/tmp";
}

/* bytes to path whole; 0, or -1 with errno. */
static int video_write(const char *path, const void *data, size_t len) {
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd < 0) return -1;
    const unsigned char *p = data;
    while (len > 0) {
        ssize_t n = write(fd, p, len);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            close(fd);
            return -1;
        }
        p += n;
        len -= (size_t)n;
    }
    return close(fd);
}

/* path's bytes as a blob, or NULL. */
static struct blob *video_read(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    struct stat st;
    unsigned char *data = NULL;
    size_t got = 0;
    if (fstat(fileno(f), &st) == 0 && st.st_size > 0 && (data = malloc((size_t)st.st_size)))
        got = fread(data, 1, (size_t)st.st_size, f);
    fclose(f);
    struct blob *b = data && got == (size_t)st.st_size ? blob_new(data, got) : NULL;
    if (!b) free(data);
    return b;
}

/* Runs ffmpeg over dir's frames into dir/out.mp4, waiting up to limit
 * seconds: its exit status, -2 when it was killed for time, -3 when
 * killed because the server stops, -1 (errno) when it could not start. */
static int video_ffmpeg(const char *dir, double fps, double limit) {
    char in[4200], out[4200], log[4200], rate[64];
    snprintf(in, sizeof in, "%s/frame-%%06d.png", dir);
    snprintf(out, sizeof out, "%s/out.mp4", dir);
    snprintf(log, sizeof log, "%s/ffmpeg.log", dir);
    snprintf(rate, sizeof rate, "%.17g", fps);
    char *argv[] = {"ffmpeg",     "-hide_banner",
                    "-loglevel",  "error",
                    "-nostats",   "-y",
                    "-framerate", rate,
                    "-i",         in,
                    "-vf",        "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                    "-threads",   "1",
                    "-c:v",       "libx264",
                    "-pix_fmt",   "yuv420p",
                    "-preset",    "veryfast",
                    "-crf",       "18",
                    "-movflags",  "+faststart",
                    out,          NULL};
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, log, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    /* rayd's threads block SIGTERM and SIGINT (main.c waits for them):
     * ffmpeg starts with no signal blocked and every default disposition,
     * so it can be stopped as any program */
    posix_spawnattr_t at;
    sigset_t none, all;
    sigemptyset(&none);
    sigfillset(&all);
    posix_spawnattr_init(&at);
    posix_spawnattr_setsigmask(&at, &none);
    posix_spawnattr_setsigdefault(&at, &all);
    posix_spawnattr_setflags(&at, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
    pid_t pid;
    int e = posix_spawnp(&pid, "ffmpeg", &fa, &at, argv, environ);
    posix_spawnattr_destroy(&at);
    posix_spawn_file_actions_destroy(&fa);
    if (e != 0) {
        errno = e;
        return -1;
    }
    double end = clock_now() + limit;
    int status = 0;
    for (;;) {
        pid_t w = waitpid(pid, &status, WNOHANG);
        if (w == pid) break;
        if (w < 0 && errno != EINTR) return 1;
        bool stop = atomic_load(&video_stopping);
        if (stop || clock_now() > end) {
            kill(pid, SIGKILL);
            waitpid(pid, &status, 0);
            return stop ? -3 : -2;
        }
        struct timespec ts = {0, 20 * 1000000L};
        nanosleep(&ts, NULL);
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

/* The last line ffmpeg wrote to its log, for the error. */
static void video_log_tail(const char *dir, char *buf, size_t size) {
    char path[4200], line[400] = "";
    snprintf(path, sizeof path, "%s/ffmpeg.log", dir);
    FILE *f = fopen(path, "r");
    if (f) {
        char l[400];
        while (fgets(l, sizeof l, f))
            if (l[0] != '\n') snprintf(line, sizeof line, "%s", l);
        fclose(f);
    }
    line[strcspn(line, "\n")] = 0;
    /* cut to buf's size on purpose: the line's end is ffmpeg's detail */
    snprintf(buf, size, "%.*s", size > 0 ? (int)size - 1 : 0, line[0] ? line : "no message");
}

/* line with every "dir/" taken out, so a client reads "frame-%06d.png"
 * where ffmpeg named the server's folder. */
static void video_unpath(char *line, const char *dir) {
    char prefix[4200];
    int n = snprintf(prefix, sizeof prefix, "%s/", dir);
    if (n <= 0 || (size_t)n >= sizeof prefix) return;
    char *at;
    while ((at = strstr(line, prefix))) memmove(at, at + n, strlen(at + n) + 1);
}

/* Removes dir's files and dir. */
static void video_clean(const char *dir, int n) {
    char path[4200];
    for (int i = 0; i < n; i++) {
        snprintf(path, sizeof path, "%s/frame-%06d.png", dir, i);
        unlink(path);
    }
    snprintf(path, sizeof path, "%s/out.mp4", dir);
    unlink(path);
    snprintf(path, sizeof path, "%s/ffmpeg.log", dir);
    unlink(path);
    rmdir(dir);
}

enum video_status video_encode(struct blob *const *frames, int n, double fps, double limit,
                               struct blob **out, char *err, size_t size) {
    *out = NULL;
    if (atomic_load(&video_stopping)) {
        snprintf(err, size, "the server stopped before the video was made");
        return VIDEO_FAILED;
    }
    char dir[4096], path[4200];
    snprintf(dir, sizeof dir, "%s/" VIDEO_DIR_PREFIX "%ld-XXXXXX", video_tmp(), (long)getpid());
    if (!mkdtemp(dir)) {
        snprintf(err, size, "cannot make a folder for the video's frames: %s", strerror(errno));
        return VIDEO_FAILED;
    }
    int written = 0;
    for (; written < n; written++) {
        snprintf(path, sizeof path, "%s/frame-%06d.png", dir, written);
        if (atomic_load(&video_stopping)) {
            snprintf(err, size, "the server stopped before the video was made");
            video_clean(dir, written);
            return VIDEO_FAILED;
        }
        if (!frames[written] ||
            video_write(path, frames[written]->data, frames[written]->len) != 0) {
            snprintf(err, size, "cannot write frame %d for the video: %s", written,
                     frames[written] ? strerror(errno) : "its image is gone");
            video_clean(dir, written + 1);
            return VIDEO_FAILED;
        }
    }
    int rc = video_ffmpeg(dir, fps, limit);
    enum video_status st = VIDEO_OK;
    if (rc == -1) {
        snprintf(err, size,
                 "the video needs the ffmpeg program (Debian's ffmpeg package), which could not "
                 "be run: %s",
                 strerror(errno));
        st = VIDEO_NO_FFMPEG;
    } else if (rc == -2) {
        snprintf(err, size, "ffmpeg took more than %.0f s and was stopped", limit);
        st = VIDEO_FAILED;
    } else if (rc == -3) {
        snprintf(err, size, "the server stopped before the video was made");
        st = VIDEO_FAILED;
    } else if (rc != 0) {
        char tail[300];
        video_log_tail(dir, tail, sizeof tail);
        log_warn("ffmpeg failed (status %d) in %s: %s", rc, dir, tail);
        video_unpath(tail, dir);
        snprintf(err, size, "ffmpeg failed (status %d): %s", rc, tail);
        st = rc == 127 ? VIDEO_NO_FFMPEG : VIDEO_FAILED;
    } else {
        snprintf(path, sizeof path, "%s/out.mp4", dir);
        if (!(*out = video_read(path))) {
            snprintf(err, size, "cannot read the video ffmpeg wrote");
            st = VIDEO_FAILED;
        }
    }
    video_clean(dir, n);
    return st;
}

/* The PID in a folder's name after the prefix ("PID-XXXXXX"), or 0. */
static long video_dir_pid(const char *rest) {
    char *end;
    long pid = strtol(rest, &end, 10);
    return pid > 0 && end != rest && *end == '-' && strlen(end + 1) == 6 ? pid : 0;
}

/* Removes dir's files (the folder holds no folders) and dir. */
static void video_remove(const char *dir) {
    DIR *d = opendir(dir);
    if (!d) return;
    char path[4200];
    struct dirent *e;
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0 &&
            snprintf(path, sizeof path, "%s/%s", dir, e->d_name) < (int)sizeof path)
            unlink(path);
    closedir(d);
    rmdir(dir);
}

int video_sweep(void) {
    const char *base = video_tmp();
    DIR *d = opendir(base);
    if (!d) return 0;
    int swept = 0;
    size_t n = strlen(VIDEO_DIR_PREFIX);
    char dir[4200];
    struct dirent *e;
    while ((e = readdir(d))) {
        long pid = strncmp(e->d_name, VIDEO_DIR_PREFIX, n) == 0 ? video_dir_pid(e->d_name + n) : 0;
        /* ESRCH: no such process; EPERM means one runs, someone else's */
        if (pid <= 0 || pid == (long)getpid() || kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue;
        if (snprintf(dir, sizeof dir, "%s/%s", base, e->d_name) >= (int)sizeof dir) continue;
        video_remove(dir);
        swept++;
    }
    closedir(d);
    return swept;
}
