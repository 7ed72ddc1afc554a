/* rayd-render -- the command-line renderer.
 *
 *   rayd-render SCENE.json -o OUT.png|OUT.exr [--format png|png16|exr]
 *               [--region X,Y,W,H] [--threads N] [--passes] [--stats]
 *
 * Reads a scene (SCENE may be "-" for standard input), renders it with the
 * core on N threads (default: the number of cores) and writes an 8-bit sRGB
 * PNG, a 16-bit PNG or a linear float OpenEXR (by --format, else by the
 * output's extension).  With --passes it renders progressively: passes of
 * 1, 2, 4, ... samples up to the scene's (or every K with --pass-step),
 * printing each pass's samples and time; each pass's image is the plain
 * render of that many samples, byte for byte (docs/scene-format.md).  A region writes only that crop; it is byte-identical to the same
 * crop of the full render.  It uses nothing but the public API in
 * include/rayd/rayd.h.
 *
 * Exit status: 0 success, 1 I/O or internal failure, 2 bad usage or a bad
 * scene (the message names the JSON Pointer, or the line and column).
 */
#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "rayd/rayd.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: rayd-render SCENE.json -o OUT.png [--format png|png16|exr]\n"
            "                   [--region X,Y,W,H] [--threads N] [--png-level N]\n"
            "                   [--passes] [--pass-step K] [--pass-output PATTERN]\n"
            "                   [--exposure EV] [--tonemap clamp|reinhard] [--stats]\n"
            "\n"
            "  SCENE.json        scene file (format v1, docs/scene-format.md); '-' reads stdin\n"
            "  -o, --output F    file to write (required); F ending in .exr means --format exr\n"
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
            "  --region X,Y,W,H  render only the W x H crop whose top-left pixel is (X, Y)\n"
            "  --threads N       rendering and PNG encoding threads (default: number of cores)\n"
            "  --png-level N     deflate level of the PNG, 0-9 (default 4; 1: ISA-L, fastest)\n"
            "  --stats           print rays cast, rays per second, the render's wall time and\n"
            "                    the time of each stage (read, parse, decode, build, render,\n"
            "                    encode, write)\n"
            "  -h, --help        this text\n");
}

static int parse_int(const char *s, long lo, long hi, long *out) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) return -1;
    *out = v;
    return 0;
}

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
    struct rayd_region region;
    int threads;
    int png_level;
    int stats;
    int format; /* enum format; -1 until chosen */
    int passes, pass_step;
    const char *pass_output;
    struct rayd_tone tone; /* the 8-bit PNG's exposure and curve */
};

/* "png", "png16" or "exr"; -1 for anything else. */
static int format_named(const char *s) {
    return !strcmp(s, "png") ? FMT_PNG : !strcmp(s, "png16") ? FMT_PNG16 : !strcmp(s, "exr") ? FMT_EXR : -1;
}

/* Parses the pass options at argv[*i]; 1 if it was one, 0 if not, -1 bad. */
static int parse_pass_arg(int argc, char **argv, int *i, struct args *a) {
    const char *arg = argv[*i], *val = *i + 1 < argc ? argv[*i + 1] : NULL;
    long n;
    if (!strcmp(arg, "--passes")) {
        a->passes = 1;
        return 1;
    }
    if (!strcmp(arg, "--pass-step")) {
        if (!val || parse_int(val, 1, 1 << 20, &n) != 0)
            return fprintf(stderr, "rayd-render: --pass-step takes an integer in 1..1048576\n"), -1;
        a->passes = 1;
        a->pass_step = (int)n;
        ++*i;
        return 1;
    }
    if (!strcmp(arg, "--pass-output")) {
        const char *pct = val ? strchr(val, '%') : NULL;
        if (!val || (pct && (pct[1] != 'd' || strchr(pct + 1, '%'))))
            return fprintf(stderr, "rayd-render: --pass-output takes a file name with at most "
                                   "one %%d (the pass's samples) and no other %%\n"), -1;
        a->passes = 1;
        a->pass_output = val;
        ++*i;
        return 1;
    }
    if (!strcmp(arg, "--exposure")) {
        char *end = NULL;
        double ev = val ? strtod(val, &end) : 0;
        if (!val || end == val || *end || !(ev >= -64 && ev <= 64))
            return fprintf(stderr, "rayd-render: --exposure takes stops in -64..64\n"), -1;
        a->tone.exposure = ev;
        ++*i;
        return 1;
    }
    if (!strcmp(arg, "--tonemap")) {
        int clamp = val && !strcmp(val, "clamp"), reinhard = val && !strcmp(val, "reinhard");
        if (!clamp && !reinhard)
            return fprintf(stderr, "rayd-render: --tonemap takes clamp or reinhard, not '%s'\n",
                           val ? val : ""), -1;
        a->tone.curve = reinhard ? RAYD_TONE_REINHARD : RAYD_TONE_CLAMP;
        ++*i;
        return 1;
    }
    if (!strcmp(arg, "--format")) {
        if (!val || (a->format = format_named(val)) < 0)
            return fprintf(stderr, "rayd-render: --format takes png, png16 or exr, not '%s'\n",
                           val ? val : ""), -1;
        ++*i;
        return 1;
    }
    return 0;
}

static int parse_args(int argc, char **argv, struct args *a) {
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    a->threads = cores > 0 ? (int)cores : 1;
    a->png_level = -1;
    a->format = -1;
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        const char *val = i + 1 < argc ? argv[i + 1] : NULL;
        long n;
        int p = parse_pass_arg(argc, argv, &i, a);
        if (p < 0) return -1;
        if (p > 0) continue;
        if (!strcmp(arg, "-h") || !strcmp(arg, "--help")) {
            usage(stdout);
            exit(0);
        } else if (!strcmp(arg, "-o") || !strcmp(arg, "--output")) {
            if (!val) return fprintf(stderr, "rayd-render: %s needs a file name\n", arg), -1;
            a->output = argv[++i];
        } else if (!strcmp(arg, "--region")) {
            if (!val || parse_region(val, &a->region) != 0)
                return fprintf(stderr, "rayd-render: --region takes X,Y,W,H (four integers)\n"), -1;
            i++;
        } else if (!strcmp(arg, "--threads")) {
            if (!val || parse_int(val, 1, 1024, &n) != 0)
                return fprintf(stderr, "rayd-render: --threads takes an integer in 1..1024\n"), -1;
            a->threads = (int)n;
            i++;
        } else if (!strcmp(arg, "--png-level")) {
            if (!val || parse_int(val, 0, 9, &n) != 0)
                return fprintf(stderr, "rayd-render: --png-level takes an integer in 0..9\n"), -1;
            a->png_level = (int)n;
            i++;
        } else if (!strcmp(arg, "--stats")) {
            a->stats = 1;
        } else if (arg[0] == '-' && arg[1] != '\0') {
            return fprintf(stderr, "rayd-render: unknown option %s\n", arg), -1;
        } else if (!a->scene) {
            a->scene = arg;
        } else {
            return fprintf(stderr, "rayd-render: more than one scene given (%s)\n", arg), -1;
        }
    }
    if (!a->scene) return fprintf(stderr, "rayd-render: no scene given\n"), -1;
    if (!a->output) return fprintf(stderr, "rayd-render: no output given (-o OUT.png)\n"), -1;
    if (a->region.w == 0 && a->region.h == 0 && (a->region.x || a->region.y))
        return fprintf(stderr, "rayd-render: --region needs W and H > 0\n"), -1;
    size_t olen = strlen(a->output);
    if (a->format < 0) a->format = olen >= 4 && !strcmp(a->output + olen - 4, ".exr") ? FMT_EXR : FMT_PNG;
    return 0;
}

static int fail(const char *what, const struct rayd_error *err) {
    char msg[600];
    fprintf(stderr, "error: %s%s\n", what, rayd_error_format(err, msg, sizeof msg));
    switch (err->code) {
    case RAYD_E_PARSE:
    case RAYD_E_INVALID:
    case RAYD_E_LIMIT:
    case RAYD_E_ARG: return 2;
    default: return 1;
    }
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
    double pixels = a->region.w > 0 ? (double)a->region.w * a->region.h
                                    : (double)info.width * info.height;
    return pixels * info.samples * info.rays_per_sample;
}

static void print_stats(const struct args *a, const rayd_scene *scene,
                        const struct rayd_render_stats *rs, const double *stage, double total) {
    fprintf(stderr, "rays: %llu\nrays estimated: %.0f\nrays/s: %.0f\nwall: %.3f s\nthreads: %d\n",
            (unsigned long long)rs->rays, estimated_rays(a, scene),
            rs->seconds > 0 ? (double)rs->rays / rs->seconds : 0.0, rs->seconds, a->threads);
    for (int i = 0; i < ST__COUNT; i++)
        fprintf(stderr, "time %s: %.4f s\n", stage_names[i], stage[i]);
    fprintf(stderr, "time total: %.4f s\n", total);
}

/* Writes the whole buffer to path; 0 on success. */
static int write_file(const char *path, const void *buf, size_t len) {
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(buf, 1, len, f) == len;
    if (f && fclose(f) != 0) ok = 0;
    return ok ? 0 : -1;
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

static int write_or_say(const char *path, const void *buf, size_t len) {
    if (write_file(path, buf, len) == 0) return 0;
    fprintf(stderr, "error: cannot write %s: %s\n", path, strerror(errno));
    return 1;
}

/* Renders the parsed scene and writes the PNG, timing each stage from t0,
 * the start of the run. */
static int render_and_write(const struct args *a, const rayd_scene *scene, double *stage,
                            double t0) {
    struct rayd_error err = {0};
    struct rayd_render_stats stats = {0};
    struct rayd_render_opts opts = {.region = a->region, .threads = a->threads, .stats = &stats};
    rayd_image *img = NULL;
    double t = now();
    if (rayd_render(scene, &opts, &img, &err) != RAYD_OK) return fail_render(&err);
    stage[ST_RENDER] = now() - t;
    t = now();
    void *png = NULL;
    size_t len = 0;
    enum rayd_status st = rayd_png_encode_threads(img, a->png_level, a->threads, &png, &len, &err);
    rayd_image_free(img);
    if (st != RAYD_OK) return fail("", &err);
    stage[ST_ENCODE] = now() - t;
    t = now();
    int rc = write_or_say(a->output, png, len);
    rayd_free(png);
    if (rc != 0) return rc;
    stage[ST_WRITE] = now() - t;
    if (a->stats) print_stats(a, scene, &stats, stage, now() - t0);
    return 0;
}

/* The accumulator's image so far in a's format, into *buf. */
static enum rayd_status encode_accum(const struct args *a, const rayd_accum *acc, void **buf,
                                     size_t *len, struct rayd_error *err) {
    enum rayd_status st;
    if (a->format == FMT_PNG) {
        rayd_image *img = NULL;
        st = rayd_accum_image_tone(acc, &a->tone, &img, err);
        if (st == RAYD_OK) st = rayd_png_encode_threads(img, a->png_level, a->threads, buf, len, err);
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
    int count = 0;
    for (int from = 0; from < info.samples; count++) {
        int to = a->passes ? next_end(a, from, info.samples) : info.samples;
        struct rayd_error err = {0};
        if (rayd_render_pass(scene, &opts, acc, from, to, &err) != RAYD_OK) return fail("", &err);
        stats->rays += one.rays;
        stats->seconds += one.seconds;
        from = to;
        if (a->passes)
            fprintf(stderr, "pass %d: %d samples, %.3f s, %.3f s since the first\n", count + 1,
                    to, one.seconds, stats->seconds);
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
static int render_passes(const struct args *a, const rayd_scene *scene, double *stage,
                         double t0) {
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
    if (rc == 0 && a->stats) print_stats(a, scene, &stats, stage, now() - t0);
    return rc;
}

int main(int argc, char **argv) {
    struct args a = {0};
    if (parse_args(argc, argv, &a) != 0) {
        usage(stderr);
        return 2;
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
    int rc = a.passes || a.format != FMT_PNG || toned ? render_passes(&a, scene, stage, t0)
                                                      : render_and_write(&a, scene, stage, t0);
    rayd_scene_free(scene);
    return rc;
}
