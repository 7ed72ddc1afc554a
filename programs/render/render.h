/* render.h -- the internal interfaces of rayd-render.
 *
 * rayd-render is three files, one idea each, and every name a file shares
 * starts with its file's name.  Each calls only the files below it:
 *
 *   rayd-render.c  the command line: options into struct args, main
 *   frames.c       --frame, --frames and --video (frames_run)
 *   render_one.c   one image rendered and written (render_one), with the
 *                  progress line, --stats and the errors' wording
 *
 * From programs/common/ (common.h), shared with rayd-client: the option
 * helpers, prog_error, the image into -o whole or not at all, the output's
 * format by its name.  Only include/rayd/rayd.h crosses from the core.
 */
#ifndef RAYD_RENDER_H
#define RAYD_RENDER_H

#include <stdbool.h>
#include <stddef.h>

#include "common/common.h"
#include "rayd/rayd.h"

/* A usage error: one line, and the caller exits 2 (nothing was tried);
 * bad_usage says it as an expression whose value is -1.  Integers are read
 * strictly.  The helpers are programs/common's, shared with rayd-client. */
#define say_usage prog_error
#define bad_usage(...) args_bad(__VA_ARGS__)
#define parse_int(s, lo, hi, out) args_long(s, lo, hi, out)

enum format { FMT_PNG, FMT_PNG16, FMT_EXR };

/* The command line, as rayd-render.c's parse_args leaves it. */
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
    unsigned aov;          /* --aov: enum rayd_aov bits */
    bool aov_set;          /* --aov given (else the scene's render.aov) */
    bool alpha;            /* --alpha: the 8-bit PNG as RGBA, alpha the coverage */
    int max_samples;       /* --max-samples: render.samples' limit, 0 the default */
    bool denoise;          /* --denoise (or the scene's render.denoise) */
    double clamp_indirect; /* --clamp-indirect, -1 when not given */
    double filter_glossy;  /* --filter-glossy, -1 when not given */
};

/* The stages of one run, in seconds: what a user waits for, end to end.
 * parse is the JSON and its checks; decode, the mesh files; build, the BVHs
 * and light buffers. */
enum stage { ST_READ, ST_PARSE, ST_DECODE, ST_BUILD, ST_RENDER, ST_ENCODE, ST_WRITE, ST__COUNT };

/* ---- render_one.c: one image --------------------------------------------- */

/* --clamp-indirect and --filter-glossy set on a freshly parsed scene; 0,
 * or the exit code after saying why. */
int render_one_bias(const struct args *a, rayd_scene *scene);

/* Renders the parsed scene and writes a->output (--stats printed when
 * asked), timing each stage into stage[] from t0, the start of the run.
 * 0, or the exit code after the error was said. */
int render_one(const struct args *a, const rayd_scene *scene, double *stage, double t0);
/* A video's frame: renders it, writes path unless it is "", and gives its
 * 8-bit pixels in *img (the caller frees them).  0, or the exit code. */
int render_one_image(const struct args *a, const rayd_scene *scene, const char *path,
                     rayd_image **img);
/* "rayd-render: error: WHAT MESSAGE" for a core error; returns 2 for a bad
 * argument (with the "Try" line), else 1. */
int render_one_fail(const char *what, const struct rayd_error *err);
/* The same for the scene's own error (its parse, a frame's): the scene
 * file named first, as a compiler names the file of an error
 * ("rayd-render: error: room.json: /objects/0/radius: must be > 0";
 * standard input is "<stdin>"), so a script rendering many files says
 * which one is wrong.  A bad argument (a --frames range outside the
 * scene's) is the command line's, and is said as render_one_fail says it. */
int render_one_fail_scene(const struct args *a, const struct rayd_error *err);
/* "rayd-render: warning: ..." on stderr (whatever --quiet says) when the
 * scene's render will be black for want of light, so the user sees why. */
void render_one_warn(const rayd_scene *scene);
/* The same, with a region field named as --region's. */
int render_one_fail_region(struct rayd_error *err);
/* "cannot write PATH: strerror(e)"; returns 1. */
int render_one_cannot_write(const char *path, int e);
/* The monotonic clock, in seconds. */
double render_one_now(void);

/* ---- frames.c: frame ranges and videos ------------------------------------ */

/* --frame, --frames or --video for the scene's text (read, not parsed):
 * 0, or the exit code after the error was said. */
int frames_run(const struct args *a, const char *text, size_t len, const struct rayd_limits *lim,
               double t0);

#endif
