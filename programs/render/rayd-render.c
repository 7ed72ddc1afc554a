/* rayd-render -- the command-line renderer.
 *
 *   rayd-render SCENE.json -o OUT.png|OUT.exr|- [--format png|png16|exr]
 *               [--region X,Y,W,H] [--threads N] [--passes] [--stats] [--quiet]
 *
 * Reads a scene (SCENE may be "-" for standard input), renders it with the
 * core on N threads (default, or 0: the number of cores) and writes an 8-bit
 * sRGB PNG, a 16-bit PNG or a linear float OpenEXR (by --format, else by the
 * output's extension) to a file, or to standard output for "-o -".  With
 * --passes it renders progressively: passes of 1, 2, 4, ... samples up to
 * the scene's (or every K with --pass-step), printing each pass's samples
 * and time; each pass's image is the plain render of that many samples,
 * byte for byte (docs/scene-format.md).  A region writes only that crop; it
 * is byte-identical to the same crop of the full render.  On a terminal a
 * progress line is drawn on stderr from the core's progress callback (see
 * "the progress line" below).  It uses nothing but the public API in
 * include/rayd/rayd.h.
 *
 * The command line follows the convention of the three tools (rayd,
 * rayd-render, rayd-client; README "Command-line conventions"):
 * getopt_long, so "--threads 2" and "--threads=2" are the same; -h/--help
 * to stdout, --version; every error is one line "rayd-render: error: ..."
 * on stderr, which keeps the JSON Pointer or the line and column.
 *
 * An animated scene (docs/scene-format.md "Animation") renders one frame
 * with --frame K, a range with --frames A-B and -o 'shot-%04d.png' (one
 * file a frame, a line a frame on stderr), and a video with --video
 * shot.mp4: each frame's 8-bit pixels piped, raw, to the ffmpeg program,
 * which encodes H.264 in MP4 ("the frames" below says why the program).
 *
 * Exit status: 0 success; 1 a failure: a bad scene, I/O, an internal
 * error; 2 a usage error: the command line is wrong (an unknown option, a
 * bad value, a --region outside the image) and nothing was rendered.
 */
#include <errno.h>
#include <getopt.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "common/common.h"
#include "rayd/rayd.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: rayd-render SCENE.json -o OUT.png [--format png|png16|exr]\n"
            "                   [--region X,Y,W,H] [--threads N] [--png-level N]\n"
            "                   [--passes] [--pass-step K] [--pass-output PATTERN]\n"
            "                   [--exposure EV] [--tonemap clamp|reinhard] [--stats] [--quiet]\n"
            "                   [--frame K | --frames A-B] [--video OUT.mp4]\n"
            "\n"
            "  SCENE.json        scene file (format v1, docs/scene-format.md); '-' reads stdin\n"
            "  -o, --output F    file to write (required); '-' writes standard output;\n"
            "                    F ending in .exr means --format exr; in .jpg, .webp or\n"
            "                    another format's, it is refused without --format;\n"
            "                    .png with --format exr, or .exr with png, is refused\n"
            "  --format F        png (8-bit sRGB, the default), png16 (16-bit sRGB) or exr\n"
            "                    (OpenEXR, linear float RGB, unclamped)\n"
            "  --exposure EV     scale the light by 2^EV before the 8-bit PNG (default 0)\n"
            "  --tonemap C       the 8-bit PNG's curve: clamp (the default: above 1 clips)\n"
            "                    or reinhard (v / (1 + v): highlights compressed)\n"
            "  --passes          render in passes of 1, 2, 4, ... samples up to the scene's,\n"
            "                    printing each pass's samples and times; writes the last\n"
            "  --pass-step K     passes of K, 2K, 3K, ... samples instead (implies --passes)\n"
            "  --pass-output P   also write each pass's image to P, where %%d in P becomes\n"
            "                    the pass's samples (implies --passes)\n"
            "  --frame K         render frame K of an animated scene (default: its first)\n"
            "  --frames A-B      render frames A to B; -o then names each frame's file with a\n"
            "                    %%d, e.g. -o 'shot-%%04d.png' (%%0Nd pads to N digits)\n"
            "  --video F         also write the frames as a video: H.264 in MP4 (.mp4, .mov\n"
            "                    or .mkv), at the scene's fps, through the ffmpeg program;\n"
            "                    without --frames, every frame of the scene; -o optional\n"
            "  --region X,Y,W,H  render only the W x H crop whose top-left pixel is (X, Y)\n"
            "  --threads N       rendering and PNG encoding threads (default 0: every core)\n"
            "  --png-level N     deflate level of the PNG, 0-9 (default: libdeflate's 1 with\n"
            "                    ISA-L every fourth band; 1: ISA-L, the fastest; 0 and 2-9:\n"
            "                    libdeflate's)\n"
            "  --stats           print rays cast, rays per second, the render's wall time and\n"
            "                    the time of each stage (read, parse, decode, build, render,\n"
            "                    encode, write)\n"
            "  -q, --quiet       no progress line and no pass lines on standard error (the\n"
            "                    progress line is drawn only when stderr is a terminal)\n"
            "  -h, --help        this text\n"
            "  --version         print 'rayd-render VERSION'\n"
            "\n"
            "Options take their value as '--opt value' or '--opt=value'.\n"
            "Errors are one line on stderr: 'rayd-render: error: ...'.\n"
            "Exit status: 0 done, 1 failure (bad scene, I/O), 2 usage error (bad command line).\n");
}

/* A usage error: one line, and the caller exits 2 (nothing was tried);
 * bad_usage says it as an expression whose value is -1.  Integers are read
 * strictly.  The helpers are programs/common's, shared with rayd-client. */
#define say_usage prog_error
#define bad_usage(...) args_bad(__VA_ARGS__)
#define parse_int(s, lo, hi, out) args_long(s, lo, hi, out)

/* X,Y,W,H: four integers in int range (the core checks them against the
 * image). */
static int parse_region(const char *s, struct rayd_region *r) {
    int v[4];
    for (int i = 0; i < 4; i++) {
        char *end;
        errno = 0;
        long x = strtol(s, &end, 10);
        if (errno || end == s || x < -1000000000L || x > 1000000000L) return -1;
        if (*end != (i < 3 ? ',' : '\0')) return -1;
        v[i] = (int)x;
        s = end + 1;
    }
    r->x = v[0];
    r->y = v[1];
    r->w = v[2];
    r->h = v[3];
    return 0;
}

enum format { FMT_PNG, FMT_PNG16, FMT_EXR };

struct args {
    const char *scene, *output;
    struct rayd_region region; /* 0 x 0: the whole image */
    bool region_set;           /* --region given: then never 0 x 0 */
    int threads;
    int png_level;
    int stats, quiet;
    int format; /* enum format; -1 until chosen */
    int passes, pass_step;
    const char *pass_output;
    struct rayd_tone tone; /* the 8-bit PNG's exposure and curve */
    bool frames_set;       /* --frame or --frames given */
    long frame_a, frame_b; /* their frames, inclusive */
    const char *video;     /* --video: the video file, or NULL */
};

/* "png", "png16" or "exr"; -1 for anything else. */
static int format_named(const char *s) {
    return !strcmp(s, "png")     ? FMT_PNG
           : !strcmp(s, "png16") ? FMT_PNG16
           : !strcmp(s, "exr")   ? FMT_EXR
                                 : -1;
}

/* The long options; those without a short letter are numbered from 256. */
enum {
    OPT_FORMAT = 256,
    OPT_REGION,
    OPT_THREADS,
    OPT_PNG_LEVEL,
    OPT_PASSES,
    OPT_PASS_STEP,
    OPT_PASS_OUTPUT,
    OPT_EXPOSURE,
    OPT_TONEMAP,
    OPT_STATS,
    OPT_VERSION,
    OPT_FRAME,
    OPT_FRAMES,
    OPT_VIDEO
};
static const struct option long_options[] = {
    {"output", required_argument, NULL, 'o'},
    {"format", required_argument, NULL, OPT_FORMAT},
    {"region", required_argument, NULL, OPT_REGION},
    {"threads", required_argument, NULL, OPT_THREADS},
    {"png-level", required_argument, NULL, OPT_PNG_LEVEL},
    {"passes", no_argument, NULL, OPT_PASSES},
    {"pass-step", required_argument, NULL, OPT_PASS_STEP},
    {"pass-output", required_argument, NULL, OPT_PASS_OUTPUT},
    {"exposure", required_argument, NULL, OPT_EXPOSURE},
    {"tonemap", required_argument, NULL, OPT_TONEMAP},
    {"stats", no_argument, NULL, OPT_STATS},
    {"quiet", no_argument, NULL, 'q'},
    {"help", no_argument, NULL, 'h'},
    {"version", no_argument, NULL, OPT_VERSION},
    {"frame", required_argument, NULL, OPT_FRAME},
    {"frames", required_argument, NULL, OPT_FRAMES},
    {"video", required_argument, NULL, OPT_VIDEO},
    {NULL, 0, NULL, 0},
};

/* "A-B" (or "K"): frames, each in 0..1000000, A <= B. */
static int parse_frames(const char *s, long *a, long *b) {
    char *end;
    errno = 0;
    *a = strtol(s, &end, 10);
    if (errno || end == s || !(*end == '-' || !*end) || *a < 0 || *a > 1000000) return -1;
    if (!*end) {
        *b = *a;
        return 0;
    }
    const char *s2 = end + 1;
    *b = strtol(s2, &end, 10);
    if (errno || end == s2 || *end || *b < *a || *b > 1000000) return -1;
    return 0;
}

/* The frame options; 0, or -1 after saying why. */
static int set_frame_option(int opt, const char *val, struct args *a) {
    long x = 0, y = 0;
    if (opt == OPT_VIDEO) {
        const char *dot = val ? strrchr(val, '.') : NULL;
        if (!dot || (strcasecmp(dot, ".mp4") && strcasecmp(dot, ".mov") && strcasecmp(dot, ".mkv")))
            return bad_usage("--video writes H.264 in .mp4, .mov or .mkv, not '%s'",
                             val ? val : "");
        a->video = val;
        return 0;
    }
    if (a->frames_set) return bad_usage("give one --frame or --frames");
    if (opt == OPT_FRAME && (!val || parse_int(val, 0, 1000000, &x) != 0))
        return bad_usage("--frame takes a frame number in 0..1000000");
    if (opt == OPT_FRAME) y = x;
    if (opt == OPT_FRAMES && (!val || parse_frames(val, &x, &y) != 0))
        return bad_usage("--frames takes A-B: frame numbers in 0..1000000, A <= B");
    a->frames_set = true;
    a->frame_a = x;
    a->frame_b = y;
    return 0;
}

/* The pass and tone options: val is the option's value (NULL when it was
 * missing).  0, or -1 after saying why. */
static int set_pass_option(int opt, const char *val, struct args *a) {
    long n;
    switch (opt) {
    case OPT_PASSES: a->passes = 1; return 0;
    case OPT_PASS_STEP:
        if (!val || parse_int(val, 1, 1 << 20, &n) != 0)
            return bad_usage("--pass-step takes an integer in 1..1048576");
        a->passes = 1;
        a->pass_step = (int)n;
        return 0;
    case OPT_PASS_OUTPUT: {
        const char *pct = val ? strchr(val, '%') : NULL;
        if (!val || (pct && (pct[1] != 'd' || strchr(pct + 1, '%'))))
            return bad_usage("--pass-output takes a file name with at most one %%d (the pass's "
                             "samples) and no other %%");
        if (!strcmp(val, "-"))
            return bad_usage(
                "--pass-output cannot be standard output (it writes one image a pass)");
        a->passes = 1;
        a->pass_output = val;
        return 0;
    }
    case OPT_EXPOSURE: {
        char *end = NULL;
        double ev = val ? strtod(val, &end) : 0;
        if (!val || end == val || *end || !(ev >= -64 && ev <= 64))
            return bad_usage("--exposure takes stops in -64..64");
        a->tone.exposure = ev;
        return 0;
    }
    case OPT_TONEMAP: {
        int clamp = val && !strcmp(val, "clamp"), reinhard = val && !strcmp(val, "reinhard");
        if (!clamp && !reinhard)
            return bad_usage("--tonemap takes clamp or reinhard, not '%s'", val ? val : "");
        a->tone.curve = reinhard ? RAYD_TONE_REINHARD : RAYD_TONE_CLAMP;
        return 0;
    }
    case OPT_FRAME:
    case OPT_FRAMES:
    case OPT_VIDEO: return set_frame_option(opt, val, a);
    }
    return bad_usage("unknown option");
}

/* One option: val is its value (NULL when it was missing).  0, 1 when the
 * program is done (--help, --version), or -1 after saying why. */
static int set_option(int opt, const char *val, struct args *a) {
    long n;
    switch (opt) {
    case 'h': usage(stdout); return 1;
    case OPT_VERSION: printf("rayd-render %s\n", RAYD_VERSION); return 1;
    case 'o':
        if (!val) return bad_usage("-o/--output needs a file name ('-': standard output)");
        a->output = val;
        return 0;
    case 'q': a->quiet = 1; return 0;
    case OPT_STATS: a->stats = 1; return 0;
    case OPT_FORMAT:
        if (!val || (a->format = format_named(val)) < 0)
            return bad_usage("--format takes png, png16 or exr, not '%s'", val ? val : "");
        return 0;
    case OPT_REGION:
        if (!val || parse_region(val, &a->region) != 0)
            return bad_usage("--region takes X,Y,W,H (four integers)");
        a->region_set = true;
        return 0;
    case OPT_THREADS:
        if (!val || parse_int(val, 0, 1024, &n) != 0)
            return bad_usage("--threads takes an integer in 0..1024 (0: every core)");
        a->threads = (int)n;
        return 0;
    case OPT_PNG_LEVEL:
        if (!val || parse_int(val, 0, 9, &n) != 0)
            return bad_usage("--png-level takes an integer in 0..9");
        a->png_level = (int)n;
        return 0;
    }
    return set_pass_option(opt, val, a);
}

/* -o x.png with --format exr (or -o x.exr with a PNG format) would write one
 * format under the other's name; --format wins over a name that says
 * nothing (-o frame, -o -) or names another format (-o x.jpg), but a name
 * that names the other format rayd writes is a mistake, refused. */
static int output_matches_format(const struct args *a) {
    const char *dot = strrchr(a->output, '.');
    bool png_name = dot && !strcasecmp(dot, ".png");
    const char *kind = output_kind(a->output);
    if (png_name && a->format == FMT_EXR)
        return bad_usage("-o %s names a PNG, but --format exr writes OpenEXR: name it .exr",
                         a->output);
    if (kind && !strcmp(kind, "exr") && a->format != FMT_EXR)
        return bad_usage("-o %s names an OpenEXR file, but --format %s writes a PNG: name it .png",
                         a->output, a->format == FMT_PNG16 ? "png16" : "png");
    return 0;
}

/* The command line into a: 0, 1 when done (--help, --version), -1 on a
 * usage error (said).  getopt_long takes "--opt value" and "--opt=value";
 * a missing value goes to the option's own message. */
static int parse_args(int argc, char **argv, struct args *a) {
    a->png_level = -1;
    a->format = -1;
    opterr = 0;
    int opt, rc;
    while ((opt = getopt_long(argc, argv, ":o:qh", long_options, NULL)) != -1) {
        if (opt == '?') return args_unknown(long_options, argv[optind - 1], optopt);
        rc = opt == ':' ? set_option(optopt, NULL, a) : set_option(opt, optarg, a);
        if (rc != 0) return rc;
    }
    for (int i = optind; i < argc; i++) {
        if (a->scene) return bad_usage("more than one scene given (%s)", argv[i]);
        a->scene = argv[i];
    }
    if (a->threads == 0) {
        long cores = sysconf(_SC_NPROCESSORS_ONLN);
        a->threads = cores > 0 ? (int)cores : 1;
    }
    if (!a->scene) return bad_usage("no scene given");
    if (!a->output && !a->video) return bad_usage("no output given (-o OUT.png)");
    if (!a->output) a->output = ""; /* --video alone: no image files */
    if ((a->frames_set || a->video) && a->pass_output)
        return bad_usage("--pass-output cannot be given with --frame, --frames or --video");
    if (!strcmp(a->output, "-") && isatty(STDOUT_FILENO))
        return bad_usage("-o - writes the image to standard output, which is a terminal");
    if (a->region_set && a->region.w == 0 && a->region.h == 0) /* else the whole image */
        return bad_usage("--region needs W and H > 0");
    if (a->format < 0 && !a->output[0]) a->format = FMT_PNG;
    if (a->format < 0) {
        const char *kind = output_kind(a->output);
        if (!kind)
            return bad_usage("-o %s: rayd-render writes PNG (.png) and OpenEXR (.exr), not this "
                             "format (give --format png to write a PNG under this name)",
                             a->output);
        a->format = !strcmp(kind, "exr") ? FMT_EXR : FMT_PNG;
    }
    return output_matches_format(a);
}

/* A core error: "rayd-render: error: " and its message with the JSON Pointer
 * or line and column.  A bad argument (a --region outside the image) is the
 * command line's fault: 2; anything else (a bad scene, I/O) is 1. */
static int fail(const char *what, const struct rayd_error *err) {
    char msg[600];
    fprintf(stderr, "rayd-render: error: %s%s\n", what, rayd_error_format(err, msg, sizeof msg));
    if (err->code != RAYD_E_ARG) return 1;
    fprintf(stderr, "Try 'rayd-render --help'.\n"); /* as every usage error */
    return 2;
}

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* The stages of one run, in seconds: what a user waits for, end to end.
 * parse is the JSON and its checks; decode, the mesh files; build, the BVHs
 * and light buffers. */
enum stage { ST_READ, ST_PARSE, ST_DECODE, ST_BUILD, ST_RENDER, ST_ENCODE, ST_WRITE, ST__COUNT };
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
    p->t0 = now();
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
    double t = now();
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
static int fail_render(struct rayd_error *err) {
    if (err->code == RAYD_E_ARG && err->path[0]) {
        char msg[300];
        snprintf(msg, sizeof msg, "--region %s: ", err->path);
        err->path[0] = '\0';
        return fail(msg, err);
    }
    return fail("", err);
}

/* Says that path ("-": standard output) cannot be written, for errno e;
 * returns 1, the exit code. */
static int cannot_write(const char *path, int e) {
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
    double t = now();
    st = rayd_render_image(scene, opts, img, err);
    stage[ST_RENDER] = now() - t;
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
    double t = now();
    int rc = output_put(&fs->out, buf, len);
    fs->seconds += now() - t;
    return rc;
}

/* Finishes the stream straight into a's output (the bands' bytes written
 * from their own buffers, no copy of the file; the file whole or not at
 * all, programs/common/output.c): the bands left are stage[ST_ENCODE],
 * opening, writing and committing stage[ST_WRITE].  0, or 1 with the
 * error said. */
static int write_png(const struct args *a, rayd_png_stream *ps, double *stage,
                     struct rayd_png_stats *st_out) {
    double t = now();
    struct file_sink fs = {.seconds = 0};
    if (output_open(&fs.out, a->output) != 0) {
        int e = errno;
        rayd_png_stream_free(ps);
        return cannot_write(a->output, e);
    }
    double open_s = now() - t;
    struct rayd_error err = {0};
    t = now();
    enum rayd_status st = rayd_png_stream_finish_to(ps, a->threads, file_put, &fs, st_out, &err);
    double finish_s = now() - t;
    t = now();
    int ok = st == RAYD_OK && output_commit(&fs.out) == 0;
    if (st != RAYD_OK) output_abort(&fs.out); /* the temporary file goes; errno stays */
    int e = errno;
    stage[ST_WRITE] = open_s + fs.seconds + (now() - t);
    stage[ST_ENCODE] = finish_s - fs.seconds;
    if (ok) return 0;
    if (st != RAYD_OK && st != RAYD_E_IO) return fail("", &err);
    return cannot_write(a->output, e);
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
    if (rayd_region_check(scene, &a->region, &err) != RAYD_OK) return fail_render(&err);
    rayd_image *img = NULL;
    /* only the rows in flight: the stream deflates each band as it is drawn */
    if (rayd_image_new_window(r.w, r.h, &img, &err) != RAYD_OK) return fail("", &err);
    struct progress prog;
    progress_start(&prog, a, r, 0, 1);
    progress_opts(&prog, &opts);
    rayd_png_stream *stream = NULL;
    struct rayd_png_stats ps = {0};
    enum rayd_status st = render_png(scene, &opts, &prog, img, a->png_level, stage, &stream, &err);
    int rc = st == RAYD_OK ? write_png(a, stream, stage, &ps) : fail_render(&err);
    rayd_image_free(img); /* after the stream, which reads it */
    if (rc != 0) return rc;
    if (a->stats) print_stats(a, scene, &stats, &ps, stage, now() - t0);
    return 0;
}

/* The accumulator's image so far in a's format, into *buf. */
static enum rayd_status encode_accum(const struct args *a, const rayd_accum *acc, void **buf,
                                     size_t *len, struct rayd_error *err) {
    enum rayd_status st;
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
    st = a->format == FMT_EXR ? rayd_exr_encode(lin, r.w, r.h, buf, len, err)
                              : rayd_png16_encode(lin, r.w, r.h, a->png_level, buf, len, err);
    rayd_free(lin);
    return st;
}

/* Encodes the accumulator and writes it to path; 0 on success. */
static int write_accum(const struct args *a, const rayd_accum *acc, const char *path) {
    struct rayd_error err = {0};
    void *buf = NULL;
    size_t len = 0;
    if (encode_accum(a, acc, &buf, &len, &err) != RAYD_OK) return fail("", &err);
    int rc = write_or_say(path, buf, len);
    rayd_free(buf);
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
        if (st != RAYD_OK) return fail("", &err);
        stats->rays += one.rays;
        stats->seconds += one.seconds;
        from = to;
        if (a->passes && !a->quiet)
            fprintf(stderr, "pass %d: %d samples, %.3f s, %.3f s since the first\n", count + 1, to,
                    one.seconds, stats->seconds);
        if (a->pass_output) {
            char path[4096];
            pass_path(a->pass_output, to, path, sizeof path);
            if (write_accum(a, acc, path) != 0) return 1;
        }
    }
    return 0;
}

/* The progressive or HDR render: passes into an accumulator, then the last
 * image in a's format. */
static int render_passes(const struct args *a, const rayd_scene *scene, double *stage, double t0) {
    struct rayd_error err = {0};
    rayd_accum *acc = NULL;
    if (rayd_accum_new(scene, &a->region, &acc, &err) != RAYD_OK) return fail_render(&err);
    struct rayd_render_stats stats = {0};
    double t = now();
    int rc = run_passes(a, scene, acc, &stats);
    stage[ST_RENDER] = now() - t;
    t = now();
    if (rc == 0) rc = write_accum(a, acc, a->output);
    stage[ST_ENCODE] = now() - t; /* with the write: one call */
    rayd_accum_free(acc);
    if (rc == 0 && a->stats) print_stats(a, scene, &stats, NULL, stage, now() - t0);
    return rc;
}

/* ---- the frames ----------------------------------------------------------
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
 * an odd one is padded with one black column or row. */

/* pattern with its one %d, %Nd or %0Nd (N < 10) set to k, "%%" as "%".
 * -1 when the pattern has another % or more than one number; 0 when it
 * has none (out is the pattern), 1 when it has one. */
static int frame_path(const char *pattern, long k, char *out, size_t size) {
    size_t o = 0;
    int numbers = 0;
    for (const char *p = pattern; *p; p++) {
        char piece[32] = {*p, 0};
        if (*p == '%' && p[1] == '%') {
            p++;
        } else if (*p == '%') {
            const char *q = p + 1;
            bool zero = *q == '0';
            int width = 0;
            if (zero) q++;
            if (*q >= '1' && *q <= '9') width = *q++ - '0';
            if (*q != 'd' || numbers++) return -1;
            snprintf(piece, sizeof piece, zero ? "%0*ld" : "%*ld", width, k);
            p = q;
        }
        size_t n = strlen(piece);
        if (o + n >= size) return -1;
        memcpy(out + o, piece, n + 1);
        o += n;
    }
    if (!numbers) snprintf(out, size, "%s", pattern);
    return numbers;
}

extern char **environ;

struct video {
    pid_t pid;
    FILE *in; /* ffmpeg's standard input */
    int w, h;
    long frames;
};

/* Starts ffmpeg encoding w x h RGB frames at fps into path. */
static int video_start(struct video *v, const char *path, int w, int h, double fps) {
    char size[64], rate[64], out[4200];
    snprintf(size, sizeof size, "%dx%d", w, h);
    snprintf(rate, sizeof rate, "%.17g", fps);
    snprintf(out, sizeof out, "%s%s", path[0] == '-' ? "./" : "", path);
    char *argv[] = {"ffmpeg",      "-hide_banner",
                    "-loglevel",   "error",
                    "-nostats",    "-y",
                    "-f",          "rawvideo",
                    "-pix_fmt",    "rgb24",
                    "-video_size", size,
                    "-framerate",  rate,
                    "-i",          "pipe:0",
                    "-vf",         "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                    "-c:v",        "libx264",
                    "-pix_fmt",    "yuv420p",
                    "-preset",     "veryfast",
                    "-crf",        "18",
                    "-movflags",   "+faststart",
                    out,           NULL};
    int fds[2];
    if (pipe(fds) != 0) return cannot_write(path, errno);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[0], STDIN_FILENO);
    posix_spawn_file_actions_addclose(&fa, fds[1]);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    int e = posix_spawnp(&v->pid, "ffmpeg", &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    close(fds[0]);
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
    return v->in ? 0 : cannot_write(path, errno);
}

/* Waits for ffmpeg; 0 when it wrote the video.  abort: kill it first. */
static int video_end(struct video *v, const char *path, bool abort) {
    if (!v->pid) return 0;
    if (abort) kill(v->pid, SIGTERM);
    int ok = v->in && fclose(v->in) == 0;
    int status = 0;
    while (waitpid(v->pid, &status, 0) < 0 && errno == EINTR) continue;
    v->pid = 0;
    if (abort) return 1;
    if (ok && WIFEXITED(status) && WEXITSTATUS(status) == 0) return 0;
    fprintf(stderr, "rayd-render: error: ffmpeg could not write %s (%s %d)\n", path,
            WIFEXITED(status) ? "exit status" : "signal",
            WIFEXITED(status) ? WEXITSTATUS(status) : WTERMSIG(status));
    return 1;
}

/* One frame for the video: the passes into an accumulator, the frame's
 * file when there is one, then its 8-bit pixels into ffmpeg. */
static int video_frame(const struct args *a, const rayd_scene *scene, const char *path,
                       struct video *v) {
    struct rayd_error err = {0};
    rayd_accum *acc = NULL;
    if (rayd_accum_new(scene, &a->region, &acc, &err) != RAYD_OK) return fail_render(&err);
    struct rayd_render_stats stats = {0};
    rayd_image *img = NULL;
    int rc = run_passes(a, scene, acc, &stats);
    if (rc == 0 && path[0]) rc = write_accum(a, acc, path);
    if (rc == 0 && rayd_accum_image_tone(acc, &a->tone, &img, &err) != RAYD_OK) rc = fail("", &err);
    rayd_accum_free(acc);
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
    if (frame_path(a->output, k, path, size) < 0)
        return bad_usage("-o %s: a frame's file takes one %%d (or %%0Nd, N < 10) and no other %%",
                         a->output);
    return 0;
}

/* The command line's frames checked against the scene's: 0, or 2 said. */
static int check_range(const struct args *a, const struct rayd_animation *an, long *from,
                       long *to) {
    *from = a->frames_set ? a->frame_a : an->start;
    *to = a->frames_set ? a->frame_b : an->end;
    if (*to > an->end || *from < an->start) {
        if (an->animated)
            say_usage("frame %ld is outside the scene's frames %ld-%ld",
                      *to > an->end ? *to : *from, an->start, an->end);
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
    int numbered = frame_path(a->output, *from, path, sizeof path);
    if (numbered < 0 || (numbered == 0 && a->output[0] && *to > *from)) {
        say_usage(
            numbered < 0
                ? "-o %s: a frame's file takes one %%d (or %%0Nd, N < 10) and no other %%"
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
 * already parsed, and is freed here. */
static int frames_loop(const struct args *a, const char *text, size_t len,
                       const struct rayd_limits *lim, rayd_scene *scene, long from, long to,
                       double t0) {
    struct video v = {0};
    const struct args *ap = a;
    int rc = 0;
    double t_range = now();
    if (a->video) {
        struct rayd_scene_info info;
        struct rayd_animation an;
        struct rayd_error err = {0};
        rayd_scene_info(scene, &info);
        rayd_scene_animation(scene, &an);
        struct rayd_region r = a->region;
        if (r.w == 0 && r.h == 0) r = (struct rayd_region){0, 0, info.width, info.height};
        if (rayd_region_check(scene, &a->region, &err) != RAYD_OK) rc = fail_render(&err);
        if (rc == 0) rc = video_start(&v, a->video, r.w, r.h, an.fps > 0 ? an.fps : 24);
    }
    for (long k = from; k <= to && rc == 0; k++) {
        double tf = now();
        struct rayd_error err = {0};
        if (!scene && rayd_scene_parse_frame(text, len, lim, k, &scene, &err) != RAYD_OK) {
            rc = fail("", &err);
            break;
        }
        char path[4096];
        rc = frame_file(a, k, path, sizeof path) ? 2 : 0;
        struct args b = *ap;
        b.output = path;
        double stage[ST__COUNT] = {0};
        bool toned = a->tone.exposure != 0 || a->tone.curve != RAYD_TONE_CLAMP;
        if (rc == 0 && a->video)
            rc = video_frame(&b, scene, path, &v);
        else if (rc == 0)
            rc = a->passes || a->format != FMT_PNG || toned
                     ? render_passes(&b, scene, stage, t0)
                     : render_and_write(&b, scene, stage, t0);
        rayd_scene_free(scene);
        scene = NULL;
        if (rc == 0)
            frame_line(a, k, k - from + 1, to - from + 1, now() - tf, now() - t_range, path);
    }
    rayd_scene_free(scene);
    if (a->video && video_end(&v, a->video, rc != 0) != 0 && rc == 0) rc = 1;
    if (rc == 0 && !a->quiet)
        fprintf(stderr, "frames %ld-%ld: %ld frame%s in %.3f s%s%s\n", from, to, to - from + 1,
                to > from ? "s" : "", now() - t_range, a->video ? " -> " : "",
                a->video ? a->video : "");
    return rc;
}

static int run_frames(const struct args *a, const char *text, size_t len,
                      const struct rayd_limits *lim, double t0) {
    struct rayd_error err = {0};
    rayd_scene *scene = NULL;
    enum rayd_status st = a->frames_set
                              ? rayd_scene_parse_frame(text, len, lim, a->frame_a, &scene, &err)
                              : rayd_scene_parse(text, len, lim, &scene, &err);
    if (st != RAYD_OK) return fail("", &err);
    struct rayd_animation an;
    rayd_scene_animation(scene, &an);
    long from, to;
    int rc = check_range(a, &an, &from, &to);
    if (rc != 0) {
        fprintf(stderr, "Try 'rayd-render --help'.\n");
        rayd_scene_free(scene);
        return rc;
    }
    return frames_loop(a, text, len, lim, scene, from, to, t0);
}

int main(int argc, char **argv) {
    struct args a = {0};
    prog_init("rayd-render");
    int rc = parse_args(argc, argv, &a);
    if (rc != 0) {
        if (rc < 0) fprintf(stderr, "Try 'rayd-render --help'.\n");
        return rc < 0 ? 2 : 0;
    }
    double stage[ST__COUNT] = {0}, t0 = now(), t = t0;
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    size_t len;
    char *text = NULL;
    struct rayd_error err = {0};
    if (rayd_read_file(a.scene, lim.max_bytes, &text, &len, &err) != RAYD_OK) return fail("", &err);
    stage[ST_READ] = now() - t;
    t = now();
    /* Mesh "file" paths resolve against the scene's folder (the working
     * folder for stdin); the command line trusts its own scene's paths. */
    char dir[4096];
    const char *slash = strrchr(a.scene, '/');
    if (strcmp(a.scene, "-") == 0 || !slash)
        snprintf(dir, sizeof dir, ".");
    else
        snprintf(dir, sizeof dir, "%.*s", (int)(slash - a.scene), a.scene);
    lim.asset_dir = dir[0] ? dir : "/";
    lim.asset_confine = 0;
    if (a.frames_set || a.video) {
        rc = run_frames(&a, text, len, &lim, t0);
        free(text);
        return rc;
    }
    rayd_scene *scene = NULL;
    enum rayd_status st = rayd_scene_parse(text, len, &lim, &scene, &err);
    free(text);
    if (st != RAYD_OK) return fail("", &err);

    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    stage[ST_DECODE] = info.decode_seconds;
    stage[ST_BUILD] = info.build_seconds;
    stage[ST_PARSE] = now() - t - info.decode_seconds - info.build_seconds;
    bool toned = a.tone.exposure != 0 || a.tone.curve != RAYD_TONE_CLAMP;
    rc = a.passes || a.format != FMT_PNG || toned ? render_passes(&a, scene, stage, t0)
                                                  : render_and_write(&a, scene, stage, t0);
    rayd_scene_free(scene);
    return rc;
}
