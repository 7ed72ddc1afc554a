/* frames.c -- rayd-render's frame ranges and videos.
 *
 * --frame K, --frames A-B and --video load the scene once per frame
 * (rayd_scene_parse_frame: frame k is a pure function of the scene's bytes
 * and k) and render each as a still, to -o's pattern with the frame's
 * number.  After each frame a line on stderr gives the frame's time and
 * the range's progress and estimate of the time left; at the end, one for
 * the range.
 *
 * The video: each frame's 8-bit pixels (the tone options applied, as the
 * PNG's) are piped raw to the `ffmpeg` program, which encodes H.264
 * (libx264, yuv420p, so any player plays it) in MP4 at the scene's fps.
 * The program rather than libavformat/libavcodec: the encoder then runs
 * in its own process, beside the render and away from rayd-render's memory
 * (a crash or a hang there is an exit status here), rayd-render links no
 * library whose API and ABI change with every FFmpeg release, and the
 * options are the ones every ffmpeg user knows.  The pixels go through a
 * pipe: no temporary files.  H.264's 4:2:0 needs an even width and height:
 * an odd one is padded with one black column or row.  ffmpeg runs on one
 * thread, as the server's does (server/base/video.c): left to itself it
 * takes a count from the machine's cores and writes it into the video, so
 * the same frames made other bytes on another machine.
 *
 * The invariants: one scene is alive at a time (a frame's is freed before
 * the next is parsed), so a long range takes the memory of one frame; a
 * frame is rendered by render_one.c exactly as a still of that frame would
 * be, so frame k of a range and `--frame k` give the same bytes; the range
 * is checked against the scene's frames and the -o pattern before the
 * first frame is rendered (a usage error, exit 2, with nothing written);
 * and ffmpeg is always waited for, killed first when a frame failed, so no
 * child outlives rayd-render.  Data flows one way: rayd-render.c calls
 * frames_run(), this file calls render_one.c, and neither calls back.
 *
 * A signal that ends rayd-render while ffmpeg writes the video's part
 * file would leave that file behind: from its making to its rename it is
 * guarded (common/part_guard.c), ffmpeg its writer, killed first.  The
 * signals are held while ffmpeg is spawned (it starts with the mask from
 * before) and while the part file is renamed or removed.
 */
#include <errno.h>
#include <signal.h>
#include <spawn.h>
#include <malloc.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "render.h"

extern char **environ;

struct video {
    pid_t pid;
    FILE *in; /* ffmpeg's standard input */
    int w, h;
    long frames;
    char *tmp; /* what ffmpeg writes, renamed over the video once whole; NULL: in place */
};

/* The file ffmpeg writes for path, as -o's rule has it (common/output.c):
 * PATH.PID.part beside it, created here new (output_part, O_EXCL: never a
 * name someone else made, such as a link planted in a shared folder) with the mode of
 * the video it replaces, and renamed over it only once the video is
 * whole, so a run that fails or is stopped leaves the video there was.
 * path's extension comes again at the end: ffmpeg takes the format from
 * it.  A name that is no regular file (/dev/null) is written in place:
 * NULL. */
static int video_temp(const char *path, char **tmp) {
    struct stat st;
    *tmp = NULL;
    bool old = lstat(path, &st) == 0;
    if (old && !S_ISREG(st.st_mode)) return 0;
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    int fd = output_part(path, dot && (!slash || dot > slash) ? dot : "", old ? &st : NULL, tmp);
    if (fd >= 0) {
        close(fd);
        return 0;
    }
    return render_one_cannot_write(path, errno); /* *tmp is NULL */
}

/* video_start's, with the signals held (the mask before in held). */
static int video_spawn(struct video *v, const char *path, int w, int h, double fps,
                       const sigset_t *held) {
    char size[64], rate[64], out[4200];
    int rc = video_temp(path, &v->tmp);
    if (rc != 0) return rc;
    if (v->tmp) part_guard_arm(v->tmp);
    const char *to = v->tmp ? v->tmp : path;
    snprintf(size, sizeof size, "%dx%d", w, h);
    snprintf(rate, sizeof rate, "%.17g", fps);
    snprintf(out, sizeof out, "%s%s", to[0] == '-' ? "./" : "", to);
    char *argv[] = {"ffmpeg",      "-hide_banner",
                    "-loglevel",   "error",
                    "-nostats",    "-y",
                    "-f",          "rawvideo",
                    "-pix_fmt",    "rgb24",
                    "-video_size", size,
                    "-framerate",  rate,
                    "-i",          "pipe:0",
                    "-vf",         "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                    "-threads",    "1",
                    "-c:v",        "libx264",
                    "-pix_fmt",    "yuv420p",
                    "-preset",     "veryfast",
                    "-crf",        "18",
                    "-movflags",   "+faststart",
                    out,           NULL};
    int fds[2];
    if (pipe(fds) != 0) return render_one_cannot_write(path, errno);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[0], STDIN_FILENO);
    posix_spawn_file_actions_addclose(&fa, fds[1]);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    posix_spawnattr_t at; /* ffmpeg starts with the mask we had, not ours of now */
    posix_spawnattr_init(&at);
    posix_spawnattr_setsigmask(&at, held);
    posix_spawnattr_setflags(&at, POSIX_SPAWN_SETSIGMASK);
    int e = posix_spawnp(&v->pid, "ffmpeg", &fa, &at, argv, environ);
    posix_spawnattr_destroy(&at);
    posix_spawn_file_actions_destroy(&fa);
    close(fds[0]);
    if (e == 0 && v->tmp) part_guard_child(v->pid);
    if (e != 0) {
        close(fds[1]);
        fprintf(stderr,
                "rayd-render: error: --video needs the ffmpeg program (Debian's ffmpeg "
                "package; make deps installs it): %s\n",
                strerror(e));
        return 1;
    }
    signal(SIGPIPE, SIG_IGN); /* a dead ffmpeg is a write error, said below */
    v->in = fdopen(fds[1], "wb");
    v->w = w;
    v->h = h;
    return v->in ? 0 : render_one_cannot_write(path, errno);
}

/* Starts ffmpeg encoding w x h RGB frames at fps for path. */
static int video_start(struct video *v, const char *path, int w, int h, double fps) {
    sigset_t held;
    part_guard_hold(&held);
    int rc = video_spawn(v, path, w, h, fps, &held);
    part_guard_release(&held);
    return rc;
}

/* Waits for ffmpeg (abort: kills it first), then puts the video in place;
 * 0 when it did. */
static int video_end(struct video *v, const char *path, bool abort) {
    int rc = 1, ok = 0;
    if (v->pid) {
        if (abort) kill(v->pid, SIGTERM);
        ok = v->in && fclose(v->in) == 0;
        siginfo_t si; /* ended, not reaped: a signal until the hold still finds it by its pid */
        while (waitid(P_PID, (id_t)v->pid, &si, WEXITED | WNOWAIT) < 0 && errno == EINTR) continue;
    }
    sigset_t held;
    part_guard_hold(&held);
    if (v->pid) {
        int status = 0;
        while (waitpid(v->pid, &status, 0) < 0 && errno == EINTR) continue;
        v->pid = 0;
        part_guard_child(0); /* reaped: its pid may be another's now */
        if (!abort && ok && WIFEXITED(status) && WEXITSTATUS(status) == 0)
            rc = v->tmp && rename(v->tmp, path) != 0 ? render_one_cannot_write(path, errno) : 0;
        else if (!abort)
            fprintf(stderr, "rayd-render: error: ffmpeg could not write %s (%s %d)\n", path,
                    WIFEXITED(status) ? "exit status" : "signal",
                    WIFEXITED(status) ? WEXITSTATUS(status) : WTERMSIG(status));
    }
    if (rc != 0 && v->tmp) unlink(v->tmp);
    if (v->tmp) part_guard_disarm(v->tmp);
    free(v->tmp);
    v->tmp = NULL;
    part_guard_release(&held);
    return rc;
}

/* One frame for the video: the passes into an accumulator, the frame's
 * file when there is one, then its 8-bit pixels into ffmpeg. */
static int video_frame(const struct args *a, const rayd_scene *scene, const char *path,
                       struct video *v) {
    rayd_image *img = NULL;
    int rc = render_one_image(a, scene, path, &img);
    if (rc == 0 && (rayd_image_width(img) != v->w || rayd_image_height(img) != v->h)) {
        fprintf(stderr, "rayd-render: error: --video: every frame must be %d x %d\n", v->w, v->h);
        rc = 1;
    }
    size_t n = (size_t)v->w * (size_t)v->h * 3;
    if (rc == 0 && fwrite(rayd_image_pixels_const(img), 1, n, v->in) != n) {
        fprintf(stderr, "rayd-render: error: ffmpeg stopped taking frames: %s\n", strerror(errno));
        rc = 1;
    }
    rayd_image_free(img);
    return rc;
}

/* Frame k's file name from -o ("" for none). */
static int frame_file(const struct args *a, long k, char *path, size_t size) {
    if (frame_name_path(a->output, k, path, size) < 0)
        return bad_usage("-o %s: " FRAME_NAME_RULE, a->output);
    return 0;
}

/* The command line's frames checked against the scene's: 0, or 2 said. */
static int check_range(const struct args *a, const struct rayd_animation *an, long *from,
                       long *to) {
    *from = a->frames_set ? a->frame_a : an->start;
    *to = a->frames_set ? a->frame_b : an->end;
    if (*to > an->end || *from < an->start) {
        if (an->animated)
            say_usage("%s: /animation: frame %ld is outside the animation's frames %ld-%ld",
                      prog_input_name(a->scene), *to > an->end ? *to : *from, an->start, an->end);
        else
            say_usage("frame %ld: the scene has no /animation, so its one frame is 0",
                      *to > an->end ? *to : *from);
        return 2;
    }
    if (!strcmp(a->output, "-") && *to > *from) {
        say_usage("-o - cannot take a range of frames (one file a frame)");
        return 2;
    }
    char path[4096];
    int numbered = frame_name_path(a->output, *from, path, sizeof path);
    if (numbered < 0 || (numbered == 0 && a->output[0] && *to > *from)) {
        say_usage(
            numbered < 0
                ? "-o %s: " FRAME_NAME_RULE
                : "-o %s: a range of frames needs a file name with %%d, e.g. -o 'shot-%%04d.png'",
            a->output);
        return 2;
    }
    return 0;
}

/* The line after each frame: its time, and the range's progress. */
static void frame_line(const struct args *a, long k, long done, long total, double secs,
                       double t_range, const char *path) {
    if (a->quiet) return;
    double eta = done < total ? t_range / (double)done * (double)(total - done) : 0;
    fprintf(stderr, "frame %ld: %.3f s%s%s  [%ld/%ld frames, %3.0f%%, %.1f s, eta %.1f s]\n", k,
            secs, path[0] ? " -> " : "", path, done, total, 100.0 * (double)done / (double)total,
            t_range, eta);
}

/* Renders frames from..to of the scene text; scene is frame `from`,
 * already parsed, and is freed here.  lim->assets holds the decoded
 * images and the meshes built from files and the scene's text across the
 * frames, so each frame takes them rather than making them again; a
 * frame's scene stays in memory while the next is parsed, which then
 * takes the gltf objects' meshes it baked the same (the cache does not
 * hold those: an animated glTF bakes new ones every frame). */
static int frames_loop(const struct args *a, const char *text, size_t len,
                       const struct rayd_limits *lim, rayd_scene *scene, long from, long to,
                       double t0) {
    struct video v = {0};
    const struct args *ap = a;
    int rc = 0;
    double t_range = render_one_now();
    if (a->video) {
        struct rayd_scene_info info;
        struct rayd_animation an;
        struct rayd_error err = {0};
        rayd_scene_info(scene, &info);
        rayd_scene_animation(scene, &an);
        struct rayd_region r = a->region;
        if (r.w == 0 && r.h == 0) r = (struct rayd_region){0, 0, info.width, info.height};
        if (rayd_region_check(scene, &a->region, &err) != RAYD_OK)
            rc = render_one_fail_region(&err);
        if (rc == 0) rc = video_start(&v, a->video, r.w, r.h, an.fps > 0 ? an.fps : 24);
    }
    rayd_scene *last = NULL; /* the frame before's, alive while the next is parsed */
    for (long k = from; k <= to && rc == 0; k++) {
        double tf = render_one_now();
        struct rayd_error err = {0};
        bool parsed = scene || rayd_scene_parse_frame(text, len, lim, k, &scene, &err) == RAYD_OK;
        rayd_scene_free(last);
        last = NULL;
        /* the frame's big arrays were freed into the heap, where glibc's
         * rising mmap threshold had put them: given back to the kernel, or
         * the next frame's land beside them and the job grows frame by
         * frame (a 1.3M-triangle glTF: 256 MiB at the 10th frame, not 356) */
        malloc_trim(0);
        if (!parsed) {
            rc = render_one_fail_scene(a, &err);
            break;
        }
        if ((rc = render_one_bias(ap, scene)) != 0) break;
        char path[4096];
        rc = frame_file(a, k, path, sizeof path) ? 2 : 0;
        struct args b = *ap;
        b.output = path;
        double stage[ST__COUNT] = {0};
        if (rc == 0 && a->video)
            rc = video_frame(&b, scene, path, &v);
        else if (rc == 0)
            rc = render_one(&b, scene, stage, t0);
        last = scene;
        scene = NULL;
        if (rc == 0)
            frame_line(a, k, k - from + 1, to - from + 1, render_one_now() - tf,
                       render_one_now() - t_range, path);
    }
    rayd_scene_free(scene);
    rayd_scene_free(last);
    if (a->video && video_end(&v, a->video, rc != 0) != 0 && rc == 0) rc = 1;
    if (rc == 0 && !a->quiet)
        fprintf(stderr, "frames %ld-%ld: %ld frame%s in %.3f s%s%s\n", from, to, to - from + 1,
                to > from ? "s" : "", render_one_now() - t_range, a->video ? " -> " : "",
                a->video ? a->video : "");
    return rc;
}

/* frames_run's, once the first frame is parsed (scene, freed here). */
static int frames_checked(const struct args *a, const char *text, size_t len,
                          const struct rayd_limits *lim, rayd_scene *scene, double t0) {
    render_one_warn(scene);
    struct rayd_animation an;
    rayd_scene_animation(scene, &an);
    long from, to;
    int rc = check_range(a, &an, &from, &to);
    if (rc != 0) {
        fprintf(stderr, "Try 'rayd-render --help'.\n");
        rayd_scene_free(scene);
        return rc;
    }
    struct rayd_error err = {0}; /* a frame past the first that would fail: before any renders */
    if (to > from && rayd_scene_check_frames(text, len, lim, from + 1, to, &err) != RAYD_OK) {
        rayd_scene_free(scene);
        return render_one_fail_scene(a, &err);
    }
    char first[4096]; /* the first frame's file: its folder missing said now, not after it */
    if (a->output[0] && (rc = frame_file(a, from, first, sizeof first)) == 0 &&
        output_writable(first) != 0)
        rc = 1;
    if (rc != 0) {
        rayd_scene_free(scene);
        return rc;
    }
    return frames_loop(a, text, len, lim, scene, from, to, t0);
}

/* --frame, --frames or --video, from the scene's text: parses the first
 * frame, checks the range against the scene's, renders it. */
int frames_run(const struct args *a, const char *text, size_t len, const struct rayd_limits *lim,
               double t0) {
    struct rayd_error err = {0};
    rayd_scene *scene = NULL;
    struct rayd_limits shared = *lim;
    shared.assets = rayd_asset_cache_new(1); /* kept for every frame; NULL: each decodes */
    lim = &shared;
    enum rayd_status st = a->frames_set
                              ? rayd_scene_parse_frame(text, len, lim, a->frame_a, &scene, &err)
                              : rayd_scene_parse(text, len, lim, &scene, &err);
    int rc = st == RAYD_OK ? frames_checked(a, text, len, lim, scene, t0)
                           : render_one_fail_scene(a, &err);
    rayd_asset_cache_free(shared.assets);
    return rc;
}
