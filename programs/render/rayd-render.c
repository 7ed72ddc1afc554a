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
 * which encodes H.264 in MP4 (frames.c says why the program).
 *
 * The files (render.h declares what they share), each calling only the
 * ones below it:
 *
 *   rayd-render.c  the command line: options, their checks, main
 *   frames.c       --frame, --frames and --video: a frame at a time, the
 *                  frame lines, ffmpeg
 *   render_one.c   one image: the streamed PNG or the passes, the file,
 *                  the progress line, --stats, the errors' wording
 *
 * Exit status: 0 success; 1 a failure: a bad scene, I/O, an internal
 * error; 2 a usage error: the command line is wrong (an unknown option, a
 * bad value, a --region outside the image) and nothing was rendered.
 */
#include <errno.h>
#include <getopt.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "render.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: rayd-render SCENE.json -o OUT.png [--format png|png16|exr]\n"
            "                   [--region X,Y,W,H] [--threads N] [--png-level N]\n"
            "                   [--passes] [--pass-step K] [--pass-output PATTERN]\n"
            "                   [--exposure EV] [--tonemap clamp|reinhard] [--stats] [--quiet]\n"
            "                   [--frame K | --frames A-B] [--video OUT.mp4]\n"
            "                   [--aov LIST] [--alpha] [--max-samples N] [--denoise]\n"
            "                   [--clamp-indirect X] [--filter-glossy X]\n"
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
            "  --aov LIST        also write AOVs: albedo, normal, depth, alpha, object,\n"
            "                    material, id (object and material), all, or none (default:\n"
            "                    the scene's render.aov); an EXR carries them as channels,\n"
            "                    a PNG output OUT.png gets OUT.NAME.png beside it, one each\n"
            "  --alpha           write the 8-bit PNG as RGBA, alpha the pixel's coverage\n"
            "  --max-samples N   allow render.samples up to N, at most 65536 (default\n"
            "                    1024), e.g. for reference images\n"
            "  --denoise         denoise the image (as the scene's render.denoise): an\n"
            "                    a-trous filter guided by albedo, normal, depth, variance\n"
            "  --clamp-indirect X  cap each indirect contribution's luminance at X (biased;\n"
            "                    0: off; the scene's render.clamp_indirect)\n"
            "  --filter-glossy X   least roughness of glossy lobes after a diffuse or glossy\n"
            "                    bounce (biased; 0: off; the scene's render.filter_glossy)\n"
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
            "  -q, --quiet       no progress line, pass lines or frame lines on standard\n"
            "                    error, only errors and warnings (the progress line is drawn\n"
            "                    only when stderr is a terminal)\n"
            "  -h, --help        this text\n"
            "  --version         print 'rayd-render VERSION'\n"
            "\n"
            "Options take their value as '--opt value' or '--opt=value'.\n"
            "Errors are one line on stderr: 'rayd-render: error: ...'.\n"
            "Exit status: 0 done, 1 failure (bad scene, I/O), 2 usage error (bad command line).\n");
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
    OPT_VIDEO,
    OPT_AOV,
    OPT_ALPHA,
    OPT_MAX_SAMPLES,
    OPT_DENOISE,
    OPT_CLAMP_INDIRECT,
    OPT_FILTER_GLOSSY
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
    {"aov", required_argument, NULL, OPT_AOV},
    {"alpha", no_argument, NULL, OPT_ALPHA},
    {"max-samples", required_argument, NULL, OPT_MAX_SAMPLES},
    {"denoise", no_argument, NULL, OPT_DENOISE},
    {"clamp-indirect", required_argument, NULL, OPT_CLAMP_INDIRECT},
    {"filter-glossy", required_argument, NULL, OPT_FILTER_GLOSSY},
    {NULL, 0, NULL, 0},
};

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
    if (opt == OPT_FRAMES && (!val || frame_name_range(val, &x, &y) != 0))
        return bad_usage("--frames takes A-B: frame numbers in 0..1000000, A <= B");
    a->frames_set = true;
    a->frame_a = x;
    a->frame_b = y;
    return 0;
}

/* --clamp-indirect X (0..32768) and --filter-glossy X (0..1); 0, or -1
 * after saying why. */
static int set_bias_option(int opt, const char *val, struct args *a) {
    char *end = NULL;
    double x = val ? strtod(val, &end) : -1;
    bool ok = val && end != val && !*end && x >= 0;
    if (opt == OPT_CLAMP_INDIRECT) {
        if (!ok || !(x <= 32768))
            return bad_usage("--clamp-indirect takes a luminance in 0..32768 (0: off)");
        a->clamp_indirect = x;
    } else {
        if (!ok || !(x <= 1))
            return bad_usage("--filter-glossy takes a roughness in 0..1 (0: off)");
        a->filter_glossy = x;
    }
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
    case OPT_AOV: {
        struct rayd_error err = {0};
        a->aov_set = true;
        a->aov = 0;
        if (val && !strcmp(val, "none")) return 0;
        if (!val || rayd_aov_parse(val, &a->aov, &err) != RAYD_OK)
            return bad_usage("--aov: %s (or none)",
                             val ? err.message : "takes a list of AOVs, e.g. albedo,normal");
        return 0;
    }
    case OPT_ALPHA: a->alpha = true; return 0;
    case OPT_DENOISE: a->denoise = true; return 0;
    case OPT_CLAMP_INDIRECT:
    case OPT_FILTER_GLOSSY: return set_bias_option(opt, val, a);
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
    case 'o': /* "" would render, then fail to write */
        if (!val || !*val) return bad_usage("-o/--output needs a file name ('-': standard output)");
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
    case OPT_MAX_SAMPLES:
        if (!val || parse_int(val, 1, RAYD_SAMPLES_MAX, &n) != 0)
            return bad_usage("--max-samples takes an integer in 1..%d", RAYD_SAMPLES_MAX);
        a->max_samples = (int)n;
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
    a->clamp_indirect = a->filter_glossy = -1;
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
    if (a->aov && !strcmp(a->output, "-") && a->format != FMT_EXR)
        return bad_usage("--aov writes files named after -o (OUT.albedo.png), and -o is standard "
                         "output: name a file, or write an EXR");
    if (a->format < 0) {
        const char *kind = output_kind(a->output);
        if (!kind)
            return bad_usage("-o %s: rayd-render writes PNG (.png) and OpenEXR (.exr), not this "
                             "format (give --format png to write a PNG under this name)",
                             a->output);
        a->format = !strcmp(kind, "exr") ? FMT_EXR : FMT_PNG;
    }
    if (a->alpha && a->format != FMT_PNG)
        return bad_usage("--alpha is for the 8-bit PNG; an EXR carries alpha as its A channel "
                         "(--aov alpha)");
    return output_matches_format(a);
}

int main(int argc, char **argv) {
    struct args a = {0};
    prog_init("rayd-render");
    int rc = parse_args(argc, argv, &a);
    if (rc != 0) {
        if (rc < 0) fprintf(stderr, "Try 'rayd-render --help'.\n");
        return rc < 0 ? 2 : 0;
    }
    /* a folder that is missing is said before the render, not after it (a
     * frame range's file names are made per frame: frames.c writes them) */
    if ((!a.frames_set && a.output[0] && output_writable(a.output) != 0) ||
        (a.video && output_writable(a.video) != 0))
        return 1;
    double stage[ST__COUNT] = {0}, t0 = render_one_now(), t = t0;
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    size_t len;
    char *text = NULL;
    struct rayd_error err = {0};
    if (rayd_read_file(a.scene, lim.max_bytes, &text, &len, &err) != RAYD_OK)
        return render_one_fail("", &err);
    stage[ST_READ] = render_one_now() - t;
    t = render_one_now();
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
    if (a.max_samples) lim.max_samples = a.max_samples;
    if (a.frames_set || a.video) {
        rc = frames_run(&a, text, len, &lim, t0);
        free(text);
        return rc;
    }
    rayd_scene *scene = NULL;
    enum rayd_status st = rayd_scene_parse(text, len, &lim, &scene, &err);
    free(text);
    if (st != RAYD_OK) return render_one_fail_scene(&a, &err);
    render_one_warn(scene);
    if ((rc = render_one_bias(&a, scene)) != 0) {
        rayd_scene_free(scene);
        return rc;
    }

    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    stage[ST_DECODE] = info.decode_seconds;
    stage[ST_BUILD] = info.build_seconds;
    stage[ST_PARSE] = render_one_now() - t - info.decode_seconds - info.build_seconds;
    rc = render_one(&a, scene, stage, t0);
    rayd_scene_free(scene);
    return rc;
}
