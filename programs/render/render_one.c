/* render_one.c -- rayd-render's one image: the render, its file, its times.
 *
 * Given the parsed scene and the options (struct args, render.h), this
 * file renders one image and writes it: the plain 8-bit PNG streamed band
 * by band as the rows are drawn (render_and_write), or passes into an
 * accumulator encoded at the end as png, png16 or OpenEXR (render_passes,
 * with --passes' lines and --pass-output's files).  render_one() chooses
 * between them; render_one_image() gives a video's frame its pixels.
 * Around the render: the terminal progress line, --stats' figures and
 * the errors' wording ("rayd-render: error: ...", and the exit code a
 * core error means).
 *
 * It is the lowest file of rayd-render: rayd-render.c (the command line)
 * and frames.c (ranges of frames, the video) call it; it calls neither,
 * and uses nothing but include/rayd/rayd.h and programs/common/.  Its
 * invariants: every error is said once, here, before the exit code is
 * returned; the progress line is cleared before anything else is written
 * to stderr; the bytes of an image do not depend on --threads or the
 * way it was written (streamed or whole).
 */
#include <errno.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "render.h"

/* A core error: "rayd-render: error: " and its message with the JSON Pointer
 * or line and column.  A bad argument (a --region outside the image) is the
 * command line's fault: 2; anything else (a bad scene, I/O) is 1. */
int render_one_fail(const char *what, const struct rayd_error *err) {
    char msg[600];
    /* the one limit the command line's own option raises says so */
    bool samples = err->code == RAYD_E_LIMIT && !strcmp(err->path, "/render/samples");
    fprintf(stderr, "rayd-render: error: %s%s%s\n", what, rayd_error_format(err, msg, sizeof msg),
            samples ? "; --max-samples raises it (up to 65536)" : "");
    if (err->code != RAYD_E_ARG) return 1;
    fprintf(stderr, "Try 'rayd-render --help'.\n"); /* as every usage error */
    return 2;
}

int render_one_fail_scene(const struct args *a, const struct rayd_error *err) {
    char what[4200];
    /* a bad argument found in the scene (--frame past its /animation) is
     * said at the scene's file, as the scene's own errors are */
    if (err->code == RAYD_E_ARG && !err->path[0]) return render_one_fail("", err);
    snprintf(what, sizeof what, "%s: ", prog_input_name(a->scene));
    return render_one_fail(what, err);
}

void render_one_warn(const rayd_scene *scene) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    if (info.unlit)
        fprintf(stderr, "rayd-render: warning: nothing in the scene gives light (no light, no "
                        "emissive material, a black background and environment): the image "
                        "will be black\n");
}

double render_one_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* The stages' names, in enum stage's order (render.h). */
static const char *const stage_names[ST__COUNT] = {"read",   "parse",  "decode", "build",
                                                   "render", "encode", "write"};

/* The rays the scene's description says the render will cast (the
 * estimate rayd's server admits and schedules by), beside those cast. */
static double estimated_rays(const struct args *a, const rayd_scene *scene) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    double pixels =
        a->region.w > 0 ? (double)a->region.w * a->region.h : (double)info.width * info.height;
    return pixels * info.samples * info.rays_per_sample;
}

/* ps (NULL for passes): the PNG's bands, how many were encoded during the
 * render, and their encoding's time on all threads together. */
static void print_stats(const struct args *a, const rayd_scene *scene,
                        const struct rayd_render_stats *rs, const struct rayd_png_stats *ps,
                        const double *stage, double total) {
    fprintf(stderr, "rays: %llu\nrays estimated: %.0f\nrays/s: %.0f\nwall: %.3f s\nthreads: %d\n",
            (unsigned long long)rs->rays, estimated_rays(a, scene),
            rs->seconds > 0 ? (double)rs->rays / rs->seconds : 0.0, rs->seconds, a->threads);
    for (int i = 0; i < ST__COUNT; i++)
        fprintf(stderr, "time %s: %.4f s\n", stage_names[i], stage[i]);
    fprintf(stderr, "time total: %.4f s\n", total);
    if (ps && ps->bands)
        fprintf(stderr, "encode bands: %d, %d during the render, %.4f s of work on all threads\n",
                ps->bands, ps->bands_early, ps->band_seconds);
}

/* ---- the progress line -------------------------------------------------
 *
 * On a terminal (stderr, isatty) and without --quiet, a render shows one
 * line that is redrawn in place: "\r  37%  412/1120 tiles  2.1 s  eta 3.6 s"
 * (with --passes, "pass 3/8" too; the percentage and eta are of the whole
 * run).  The core reports each finished tile through the progress callback
 * of rayd_render_opts, from its rendering threads: a thread that finds the
 * line free and 0.1 s passed since the last drawing (or none yet) redraws it, the others
 * go on at once, so the line costs the render nothing.  The main thread
 * clears it when the render call has returned (its threads are joined), so
 * the pass lines and errors that follow start on a clean line.  Off the
 * terminal nothing is drawn: a log gets no carriage returns. */

#define TILE 32 /* the core's default tile edge, set so tiles can be counted */

struct progress {
    int on;
    double t0;             /* start of the render (of every pass) */
    long tiles;            /* tiles of one pass */
    atomic_long done;      /* tiles finished in this pass */
    atomic_int busy;       /* a thread is drawing */
    _Atomic double last;   /* when the line was drawn */
    int width;             /* characters drawn, to clear; under busy */
    int pass, passes;      /* passes 0: a plain render */
    int from, to, samples; /* this pass's samples, of samples */
};

static void progress_start(struct progress *p, const struct args *a, struct rayd_region r,
                           int passes, int samples) {
    p->on = !a->quiet && isatty(STDERR_FILENO);
    p->t0 = render_one_now();
    atomic_init(&p->last, p->t0 - 1); /* the first tile draws: a short render shows it too */
    p->tiles = (long)((r.w + TILE - 1) / TILE) * ((r.h + TILE - 1) / TILE);
    atomic_init(&p->done, 0);
    atomic_init(&p->busy, 0);
    p->width = 0;
    p->pass = p->passes = p->from = 0;
    p->to = p->samples = samples;
    p->passes = passes;
}

/* The next pass: samples from..to-1. */
static void progress_pass(struct progress *p, int pass, int from, int to) {
    p->pass = pass;
    p->from = from;
    p->to = to;
    atomic_store(&p->done, 0);
}

/* Draws line, padded over what was there. */
static void progress_draw(struct progress *p, const char *line) {
    int n = (int)strlen(line);
    fprintf(stderr, "\r%s%*s", line, p->width > n ? p->width - n : 0, "");
    fflush(stderr);
    if (n > p->width) p->width = n;
}

/* rayd_progress_fn: a tile finished; done and total count pixels. */
static void progress_tile(void *user, long done, long total) {
    struct progress *p = user;
    long tiles = atomic_fetch_add(&p->done, 1) + 1;
    double t = render_one_now();
    if (!p->on || t - atomic_load(&p->last) < 0.1 || atomic_exchange(&p->busy, 1)) return;
    double of_pass = total > 0 ? (double)done / (double)total : 1;
    double f = (p->from + (p->to - p->from) * of_pass) / (p->samples > 0 ? p->samples : 1);
    double secs = t - p->t0;
    char line[160], pass[40] = "", eta[40] = "";
    if (p->passes) snprintf(pass, sizeof pass, "  pass %d/%d", p->pass, p->passes);
    if (f > 0) snprintf(eta, sizeof eta, "  eta %.1f s", secs * (1 - f) / f);
    snprintf(line, sizeof line, "  %3.0f%%%s  %ld/%ld tiles  %.1f s%s", 100 * f, pass, tiles,
             p->tiles, secs, eta);
    progress_draw(p, line);
    atomic_store(&p->last, t);
    atomic_store(&p->busy, 0);
}

/* Clears the line; only when no render is running. */
static void progress_clear(struct progress *p) {
    if (!p->width) return;
    fprintf(stderr, "\r%*s\r", p->width, "");
    fflush(stderr);
    p->width = 0;
}

/* opts reporting to p. */
static void progress_opts(struct progress *p, struct rayd_render_opts *opts) {
    opts->tile = TILE;
    opts->progress = progress_tile;
    opts->progress_user = p;
}

/* A core error; a region field is named as the flag's. */
int render_one_fail_region(struct rayd_error *err) {
    if (err->code == RAYD_E_ARG && err->path[0]) {
        char msg[300];
        snprintf(msg, sizeof msg, "--region %s: ", err->path);
        err->path[0] = '\0';
        return render_one_fail(msg, err);
    }
    return render_one_fail("", err);
}

/* Says that path ("-": standard output) cannot be written, for errno e;
 * returns 1, the exit code. */
int render_one_cannot_write(const char *path, int e) {
    prog_error("cannot write %s: %s", output_name(path), strerror(e));
    return 1;
}

/* The whole buffer to path (programs/common/output.c: whole or not at
 * all); 0, or 1 with the error said. */
static int write_or_say(const char *path, const void *buf, size_t len) {
    return output_write(path, buf, len) == 0 ? 0 : 1;
}

/* Renders the scene into img, encoding each band of rows as soon as it is
 * drawn (rayd_png_stream_rows as opts.rows): the stream, not finished, in
 * *out.  stage[ST_RENDER] is the render with the encoding done beside it;
 * the progress line is cleared when the render returns. */
static enum rayd_status render_png(const rayd_scene *scene, struct rayd_render_opts *opts,
                                   struct progress *prog, rayd_image *img, int level, double *stage,
                                   rayd_png_stream **out, struct rayd_error *err) {
    rayd_png_stream *ps = NULL;
    enum rayd_status st = rayd_png_stream_new(img, level, &ps, err);
    if (st != RAYD_OK) return st; /* nothing drawn yet: no progress line */
    opts->rows = rayd_png_stream_rows;
    opts->rows_user = ps;
    double t = render_one_now();
    st = rayd_render_image(scene, opts, img, err);
    stage[ST_RENDER] = render_one_now() - t;
    progress_clear(prog);
    if (st != RAYD_OK) {
        rayd_png_stream_free(ps);
        return st;
    }
    *out = ps;
    return RAYD_OK;
}

/* The output as a sink: its writes timed, for the write stage. */
struct file_sink {
    struct output out;
    double seconds;
};

static int file_put(void *user, const void *buf, size_t len) {
    struct file_sink *fs = user;
    double t = render_one_now();
    int rc = output_put(&fs->out, buf, len);
    fs->seconds += render_one_now() - t;
    return rc;
}

/* Finishes the stream straight into a's output (the bands' bytes written
 * from their own buffers, no copy of the file; the file whole or not at
 * all, programs/common/output.c): the bands left are stage[ST_ENCODE],
 * opening, writing and committing stage[ST_WRITE].  0, or 1 with the
 * error said. */
static int write_png(const struct args *a, rayd_png_stream *ps, double *stage,
                     struct rayd_png_stats *st_out) {
    double t = render_one_now();
    struct file_sink fs = {.seconds = 0};
    if (output_open(&fs.out, a->output) != 0) {
        int e = errno;
        rayd_png_stream_free(ps);
        return render_one_cannot_write(a->output, e);
    }
    double open_s = render_one_now() - t;
    struct rayd_error err = {0};
    t = render_one_now();
    enum rayd_status st = rayd_png_stream_finish_to(ps, a->threads, file_put, &fs, st_out, &err);
    double finish_s = render_one_now() - t;
    t = render_one_now();
    int ok = st == RAYD_OK && output_commit(&fs.out) == 0;
    if (st != RAYD_OK) output_abort(&fs.out); /* the temporary file goes; errno stays */
    int e = errno;
    stage[ST_WRITE] = open_s + fs.seconds + (render_one_now() - t);
    stage[ST_ENCODE] = finish_s - fs.seconds;
    if (ok) return 0;
    if (st != RAYD_OK && st != RAYD_E_IO) return render_one_fail("", &err);
    return render_one_cannot_write(a->output, e);
}

/* Renders the parsed scene and writes the PNG, timing each stage from t0,
 * the start of the run. */
static int render_and_write(const struct args *a, const rayd_scene *scene, double *stage,
                            double t0) {
    struct rayd_error err = {0};
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts opts = {.region = a->region, .threads = a->threads, .stats = &stats};
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    struct rayd_region r = a->region;
    if (r.w == 0 && r.h == 0) r = (struct rayd_region){0, 0, info.width, info.height};
    if (rayd_region_check(scene, &a->region, &err) != RAYD_OK) return render_one_fail_region(&err);
    rayd_image *img = NULL;
    /* only the rows in flight: the stream deflates each band as it is drawn */
    if (rayd_image_new_window(r.w, r.h, &img, &err) != RAYD_OK) return render_one_fail("", &err);
    struct progress prog;
    progress_start(&prog, a, r, 0, 1);
    progress_opts(&prog, &opts);
    rayd_png_stream *stream = NULL;
    struct rayd_png_stats ps = {0};
    enum rayd_status st = render_png(scene, &opts, &prog, img, a->png_level, stage, &stream, &err);
    int rc = st == RAYD_OK ? write_png(a, stream, stage, &ps) : render_one_fail_region(&err);
    rayd_image_free(img); /* after the stream, which reads it */
    if (rc != 0) return rc;
    if (a->stats) print_stats(a, scene, &stats, &ps, stage, render_one_now() - t0);
    return 0;
}

/* The AOVs a asks of scene: --aov's, else the scene's render.aov. */
static unsigned aov_mask(const struct args *a, const rayd_scene *scene) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    return a->aov_set ? a->aov : info.aov;
}

int render_one_bias(const struct args *a, rayd_scene *scene) {
    struct rayd_error err = {0};
    if (rayd_scene_set_bias(scene, a->clamp_indirect, a->filter_glossy, &err) != RAYD_OK)
        return render_one_fail("--", &err);
    return 0;
}

/* Whether the image is denoised: --denoise, or the scene's render.denoise. */
static bool denoised(const struct args *a, const rayd_scene *scene) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    return a->denoise || info.denoise;
}

/* A new accumulator for a's region, keeping AOVs when a asks for any (or
 * for --alpha). */
static enum rayd_status accum_for(const struct args *a, const rayd_scene *scene, rayd_accum **acc,
                                  struct rayd_error *err) {
    if (denoised(a, scene)) return rayd_accum_new_denoised(scene, &a->region, acc, err);
    enum rayd_status st = rayd_accum_new(scene, &a->region, acc, err);
    if (st == RAYD_OK && (aov_mask(a, scene) || a->alpha)) st = rayd_accum_aov_enable(*acc, err);
    return st;
}

/* The 8-bit PNG with its alpha (--alpha): RGBA, alpha the coverage. */
static enum rayd_status encode_rgba(const rayd_accum *acc, void **buf, size_t *len,
                                    struct rayd_error *err) {
    struct rayd_region r = rayd_accum_region(acc);
    uint8_t *rgba = NULL;
    enum rayd_status st = rayd_accum_rgba(acc, &rgba, err);
    if (st == RAYD_OK) st = rayd_png_encode_rgba(rgba, r.w, r.h, buf, len, err);
    rayd_free(rgba);
    return st;
}

/* The accumulator's image so far in a's format, into *buf; an EXR with
 * the AOVs of mask as channels. */
static enum rayd_status encode_accum(const struct args *a, const rayd_accum *acc, unsigned mask,
                                     void **buf, size_t *len, struct rayd_error *err) {
    enum rayd_status st;
    if (a->format == FMT_PNG && a->alpha) return encode_rgba(acc, buf, len, err);
    if (a->format == FMT_PNG) {
        rayd_image *img = NULL;
        st = rayd_accum_image_tone(acc, &a->tone, &img, err);
        if (st == RAYD_OK)
            st = rayd_png_encode_threads(img, a->png_level, a->threads, buf, len, err);
        rayd_image_free(img);
        return st;
    }
    struct rayd_region r = rayd_accum_region(acc);
    float *lin = NULL;
    st = rayd_accum_linear(acc, &lin, err);
    if (st != RAYD_OK) return st;
    float *aov = NULL;
    if (a->format == FMT_EXR && mask) st = rayd_accum_aov_linear(acc, &aov, err);
    if (st == RAYD_OK)
        st = a->format == FMT_EXR ? rayd_exr_encode_aov(lin, aov, mask, r.w, r.h, buf, len, err)
                                  : rayd_png16_encode(lin, r.w, r.h, a->png_level, buf, len, err);
    rayd_free(aov);
    rayd_free(lin);
    return st;
}

/* Where AOV name of the PNG path goes: path's extension moved past it,
 * out.png -> out.albedo.png (a path without one: out -> out.albedo.png). */
static void aov_path(const char *path, const char *name, char *out, size_t size) {
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    if (!dot || (slash && dot < slash)) dot = path + strlen(path);
    const char *ext = *dot ? dot : ".png";
    snprintf(out, size, "%.*s.%s%s", (int)(dot - path), path, name, ext);
}

/* Each AOV of mask as an 8-bit PNG beside path; 0 on success. */
static int write_aov_pngs(const struct args *a, const rayd_scene *scene, const rayd_accum *acc,
                          unsigned mask, const char *path) {
    if (mask && !strcmp(path, "-")) {
        prog_error("render.aov asks for AOV files beside -o, which is standard output: give "
                   "--aov none, or -o a file");
        return 1;
    }
    for (unsigned bit = 1; bit <= RAYD_AOV_ALL; bit <<= 1) {
        if (!(mask & bit)) continue;
        struct rayd_error err = {0};
        rayd_image *img = NULL;
        void *buf = NULL;
        size_t len = 0;
        enum rayd_status st = rayd_accum_aov_image(acc, scene, bit, &img, &err);
        if (st == RAYD_OK)
            st = rayd_png_encode_threads(img, a->png_level, a->threads, &buf, &len, &err);
        rayd_image_free(img);
        if (st != RAYD_OK) return render_one_fail("", &err);
        char out[4096];
        aov_path(path, rayd_aov_name(bit), out, sizeof out);
        int rc = write_or_say(out, buf, len);
        rayd_free(buf);
        if (rc != 0) return rc;
    }
    return 0;
}

/* Encodes the accumulator and writes it to path (and, for a PNG, its AOVs
 * beside it); 0 on success. */
static int write_accum(const struct args *a, const rayd_scene *scene, const rayd_accum *acc,
                       const char *path) {
    struct rayd_error err = {0};
    void *buf = NULL;
    size_t len = 0;
    unsigned mask = aov_mask(a, scene);
    if (encode_accum(a, acc, mask, &buf, &len, &err) != RAYD_OK) return render_one_fail("", &err);
    int rc = write_or_say(path, buf, len);
    rayd_free(buf);
    if (rc == 0 && a->format != FMT_EXR) rc = write_aov_pngs(a, scene, acc, mask, path);
    return rc;
}

/* The samples at the end of the pass after done: doubling, or every step. */
static int next_end(const struct args *a, int done, int total) {
    long to = a->pass_step ? (long)done + a->pass_step : done ? 2L * done : 1;
    return to < total ? (int)to : total;
}

/* pattern with its %d (if any) replaced by samples. */
static void pass_path(const char *pattern, int samples, char *out, size_t size) {
    const char *pct = strstr(pattern, "%d");
    if (!pct) {
        snprintf(out, size, "%s", pattern);
        return;
    }
    snprintf(out, size, "%.*s%d%s", (int)(pct - pattern), pattern, samples, pct + 2);
}

/* Runs the passes (one pass of every sample without --passes), printing
 * each; writes each pass's image when asked.  stats sums the passes. */
static int run_passes(const struct args *a, const rayd_scene *scene, rayd_accum *acc,
                      struct rayd_render_stats *stats) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    struct rayd_render_stats one = {0};
    struct rayd_render_opts opts = {.threads = a->threads, .stats = &one};
    int passes = 0;
    for (int from = 0; from < info.samples; passes++)
        from = a->passes ? next_end(a, from, info.samples) : info.samples;
    struct progress prog;
    progress_start(&prog, a, rayd_accum_region(acc), a->passes ? passes : 0, info.samples);
    progress_opts(&prog, &opts);
    int count = 0;
    for (int from = 0; from < info.samples; count++) {
        int to = a->passes ? next_end(a, from, info.samples) : info.samples;
        struct rayd_error err = {0};
        progress_pass(&prog, count + 1, from, to);
        enum rayd_status st = rayd_render_pass(scene, &opts, acc, from, to, &err);
        progress_clear(&prog);
        if (st != RAYD_OK) return render_one_fail("", &err);
        stats->rays += one.rays;
        stats->seconds += one.seconds;
        from = to;
        if (a->passes && !a->quiet)
            fprintf(stderr, "pass %d: %d samples, %.3f s, %.3f s since the first\n", count + 1, to,
                    one.seconds, stats->seconds);
        if (a->pass_output) {
            char path[4096];
            pass_path(a->pass_output, to, path, sizeof path);
            if (write_accum(a, scene, acc, path) != 0) return 1;
        }
    }
    return 0;
}

/* The progressive or HDR render: passes into an accumulator, then the last
 * image in a's format. */
static int render_passes(const struct args *a, const rayd_scene *scene, double *stage, double t0) {
    struct rayd_error err = {0};
    rayd_accum *acc = NULL;
    if (accum_for(a, scene, &acc, &err) != RAYD_OK) return render_one_fail_region(&err);
    struct rayd_render_stats stats = {0};
    double t = render_one_now();
    int rc = run_passes(a, scene, acc, &stats);
    stage[ST_RENDER] = render_one_now() - t;
    t = render_one_now();
    if (rc == 0) rc = write_accum(a, scene, acc, a->output);
    stage[ST_ENCODE] = render_one_now() - t; /* with the write: one call */
    rayd_accum_free(acc);
    if (rc == 0 && a->stats) print_stats(a, scene, &stats, NULL, stage, render_one_now() - t0);
    return rc;
}

/* The image of a's options: the streamed 8-bit PNG when nothing asks for
 * more, else passes into an accumulator (--passes, png16, OpenEXR, a tone
 * curve or exposure, AOVs, denoising). */
int render_one(const struct args *a, const rayd_scene *scene, double *stage, double t0) {
    bool toned = a->tone.exposure != 0 || a->tone.curve != RAYD_TONE_CLAMP;
    bool aov = aov_mask(a, scene) || a->alpha;
    return a->passes || a->format != FMT_PNG || toned || aov || denoised(a, scene)
               ? render_passes(a, scene, stage, t0)
               : render_and_write(a, scene, stage, t0);
}

/* A video's frame: the passes into an accumulator, path's file when path
 * is not "", and the 8-bit pixels (a's tone applied) in *img. */
int render_one_image(const struct args *a, const rayd_scene *scene, const char *path,
                     rayd_image **img) {
    struct rayd_error err = {0};
    rayd_accum *acc = NULL;
    if (accum_for(a, scene, &acc, &err) != RAYD_OK) return render_one_fail_region(&err);
    struct rayd_render_stats stats = {0};
    int rc = run_passes(a, scene, acc, &stats);
    if (rc == 0 && path[0]) rc = write_accum(a, scene, acc, path);
    if (rc == 0 && rayd_accum_image_tone(acc, &a->tone, img, &err) != RAYD_OK)
        rc = render_one_fail("", &err);
    rayd_accum_free(acc);
    return rc;
}
