/* rayd.h -- the public C API of the rayd ray-tracing core (librayd.a, librayd.so).
 *
 * This is the only header the server, the clients and the command-line
 * renderer include. Everything behind it is private to core/.
 *
 * Shape of the API
 * ----------------
 * - Handles are opaque: rayd_scene (a parsed, validated and frozen scene with
 *   its acceleration structure built), rayd_image (8-bit sRGB RGB pixels)
 *   and rayd_accum (the linear per-pixel sums of progressive passes).
 * - Every fallible call returns an enum rayd_status and fills an optional
 *   struct rayd_error (code, message, JSON Pointer path, line/column).  The
 *   error struct holds fixed-size buffers: it never allocates and can be
 *   copied between threads.  Out-parameters are written only on success.
 * - A frozen scene is immutable.  Any number of threads may render regions of
 *   one scene at once through a const pointer.
 * - Every *_free accepts NULL.
 *
 * Determinism: every pixel is a pure function of the scene bytes and the
 * pixel's coordinates.  A region render equals the same crop of the full
 * render byte for byte, whatever the tiling or thread count.
 */
#ifndef RAYD_H
#define RAYD_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The version, "MAJOR.MINOR.PATCH".  Its one source is the file VERSION at
 * the top of the source tree: the Makefile passes it to every compile as
 * -DRAYD_VERSION, and `make install` writes it into the installed copy of
 * this header (the line below), so programs built on librayd see it too. */
#ifndef RAYD_VERSION
#define RAYD_VERSION "unknown"
#endif

enum rayd_status {
    RAYD_OK = 0,
    RAYD_E_PARSE,    /* malformed JSON (line and column set) */
    RAYD_E_INVALID,  /* well-formed JSON but not a valid scene (path set) */
    RAYD_E_LIMIT,    /* a value or size over a configured limit (path set) */
    RAYD_E_ARG,      /* bad argument from the caller, e.g. a region outside the image */
    RAYD_E_NOMEM,    /* allocation failed */
    RAYD_E_IO,       /* reading or writing a file failed */
    RAYD_E_CANCELED, /* the cancel flag was raised */
    RAYD_E_INTERNAL  /* a bug in rayd; never caused by input */
};

struct rayd_error {
    enum rayd_status code;
    char message[256]; /* what is wrong, e.g. "must be > 0" */
    char path[256];    /* JSON Pointer of the offending value, "" if none */
    int line, column;  /* 1-based position in the input for RAYD_E_PARSE, else 0 */
};

/* A short stable name for a status: "ok", "invalid_json", "invalid_scene",
 * "too_large", "bad_argument", "out_of_memory", "io_error", "canceled",
 * "internal". */
const char *rayd_status_name(enum rayd_status s);

/* Formats an error the way the command-line tools print it:
 * "/objects/1/radius: must be > 0" or "line 3, column 7: expected ','".
 * Returns buf. */
char *rayd_error_format(const struct rayd_error *err, char *buf, size_t size);

/* ---- limits ------------------------------------------------------------ */

/* The most samples a pixel can take: its exact sums hold at most this many
 * (core/render/render.h), so max_samples may be raised up to it. */
#define RAYD_SAMPLES_MAX 65536

/* Decoded image textures and built meshes shared by the scenes that name
 * the same bytes (rayd_limits.assets): a scene parsed once per frame
 * decodes each image, and decodes and builds each mesh (an OBJ or PLY
 * "source", or inline arrays each of 1000 numbers or more), once while any
 * scene still holds it, not once a frame.  The cache
 * owns nothing: each entry belongs to the scenes that use it, and the last
 * to be freed frees it, so the cache keeps no memory alive that no scene
 * needs.  Safe to share between threads parsing at once. */
typedef struct rayd_asset_cache rayd_asset_cache;

/* A new, empty cache; NULL when out of memory.  hold 0: the entries belong
 * to the scenes alone (a server with scenes alive at once).  hold 1: the
 * cache keeps each entry until it is freed too, for a program that frees
 * one scene before it parses the next (rayd-render, frame after frame). */
rayd_asset_cache *rayd_asset_cache_new(int hold);
/* Lets go of the cache: scenes holding its entries keep them (it is freed
 * with the last).  No parse may be using it. */
void rayd_asset_cache_free(rayd_asset_cache *cache);
enum rayd_asset_kind { RAYD_ASSET_IMAGE, RAYD_ASSET_MESH };
/* Of the entries of kind parses looked up in the cache: how many were
 * found made (hits) and how many were made (misses). */
void rayd_asset_cache_stats(const rayd_asset_cache *cache, enum rayd_asset_kind kind, long *hits,
                            long *misses);

/* Upper bounds on everything a scene author controls.  A scene over any of
 * them is refused with RAYD_E_LIMIT and the path of the offending value. */
struct rayd_limits {
    int max_width;      /* pixels per row */
    int max_height;     /* rows */
    long max_pixels;    /* width * height */
    int max_samples;    /* render.samples: 1024, at most RAYD_SAMPLES_MAX */
    int max_depth;      /* render.max_depth */
    long max_objects;   /* entries of /objects */
    int max_lights;     /* entries of /lights */
    int max_materials;  /* entries of /materials */
    int max_nesting;    /* JSON nesting depth */
    size_t max_bytes;   /* scene text size */
    long max_triangles; /* all meshes together */
    long max_vertices;  /* all meshes together */
    /* Mesh and texture "file" references: NULL (the default) refuses them;
     * otherwise relative paths resolve against asset_dir.  With
     * asset_confine set (rayd --asset-dir), a path must stay inside
     * asset_dir: no absolute path, no "..", no symbolic link leading out
     * (opened with openat2 RESOLVE_BENEATH); rayd-render trusts its scene
     * and does not confine.  A file counts against max_bytes. */
    const char *asset_dir;
    int asset_confine;
    /* Pixels of all the scene's image textures together (each decoded
     * texel is 12 bytes of linear RGB); 0 or above the default (4 x 4096 x
     * 4096) means the default.  rayd lowers it to what its memory budget
     * has room for. */
    long max_texels;
    /* An account of the memory the parse is about to take, or NULL (the
     * default): before it decodes an image (texture or environment), reads
     * a file or builds a mesh and its BVH, the loader calls charge with
     * about the bytes that will hold (charge_arg passed back); once a
     * step's working copy is freed, or a mesh built smaller than charged,
     * it calls it with the negative difference (given back: always
     * RAYD_OK).  RAYD_OK goes on; any other status (RAYD_E_LIMIT: the
     * scene alone is too big, RAYD_E_NOMEM: no room now) is a refusal:
     * the bytes are not taken, and the parse ends with that status, the
     * message written to why (why_len bytes) and the JSON Pointer of the
     * value being loaded -- or, for bytes it can do without (the key of a
     * copy it would share, lim->assets), goes on.  Called on the parsing
     * thread only.  rayd charges its memory budget (--max-memory) with it,
     * so that a scene is counted while it is built, not only once it
     * exists. */
    enum rayd_status (*charge)(void *charge_arg, long long bytes, char *why, size_t why_len);
    void *charge_arg;
    /* Image textures and meshes already made by other scenes (the frames
     * of one animation, say), or NULL (the default): each image's and
     * mesh source's bytes are looked up there first, and what is made is
     * added.  The same texels and triangles either way; the scene's
     * limits hold the same. */
    rayd_asset_cache *assets;
    /* A flag that, once non-zero, ends the parse with RAYD_E_CANCELED within
     * milliseconds: it is looked at between the parse's steps (an image, a
     * file, a mesh's decode) and inside each BVH build.  NULL (the
     * default): none. */
    const atomic_int *cancel;
};

/* Fills lim with the documented defaults (docs/scene-format.md). */
void rayd_limits_default(struct rayd_limits *lim);

/* ---- scenes -------------------------------------------------------------- */

typedef struct rayd_scene rayd_scene;
typedef struct rayd_image rayd_image;

/* Parses, validates and freezes a scene from JSON text (need not be
 * NUL-terminated).  lim may be NULL for the defaults.  On success *out owns a
 * new scene; free it with rayd_scene_free. */
enum rayd_status rayd_scene_parse(const char *json, size_t len, const struct rayd_limits *lim,
                                  rayd_scene **out, struct rayd_error *err);

void rayd_scene_free(rayd_scene *scene);

struct rayd_scene_info {
    int width, height; /* image size in pixels */
    int samples;       /* rays per pixel */
    int max_depth;     /* recursion limit */
    long objects;      /* primitives in the scene */
    int lights;
    size_t bytes; /* memory held by the frozen scene */
    /* Rays one camera sample is expected to cast (the integrator, depth,
     * lights and materials; docs/scene-format.md "Cost"): a render of p
     * pixels at s samples is about p * s * rays_per_sample rays. */
    double rays_per_sample;
    /* Of rayd_scene_parse's time: mesh files read and decoded (OBJ, PLY,
     * base64), and the BVHs (meshes, groups, the scene's) and light buffers
     * built. */
    double decode_seconds, build_seconds;
    /* An animated scene's parse, which a frame-range job makes again for
     * every frame, in rays' worth of work (the unit of rays_per_sample):
     * its text, its objects' BVH, its keyframes evaluated, and what its
     * gltf objects bake (and, animated, build) anew each frame.  Meshes from files and inline
     * arrays are shared from frame to frame and cost nothing here.  0 for
     * a still scene. */
    double frame_work;
    /* 1 when nothing in the scene gives light: no light, no emissive
     * material, a black background and no (or a black) environment.  Every
     * pixel of its render is black; programs warn about it. */
    int unlit;
    /* render.aov: the AOVs (enum rayd_aov bits) the scene asks for, 0 for
     * none. */
    unsigned aov;
    /* render.denoise: 1 when the scene asks for its image denoised
     * (rayd_accum_new_denoised), else 0. */
    int denoise;
    /* render.clamp_indirect and render.filter_glossy (0: off). */
    double clamp_indirect, filter_glossy;
};

void rayd_scene_info(const rayd_scene *scene, struct rayd_scene_info *info);

/* Sets the path tracer's biased controls of a scene no render uses yet
 * (docs/scene-format.md, "Fireflies"): clamp_indirect, the largest
 * luminance an indirect contribution may add (0: no clamp), and
 * filter_glossy, the least roughness of glossy lobes after a diffuse or
 * glossy bounce (0: none); each < 0 leaves the scene's.  RAYD_E_ARG for
 * a value out of range (clamp_indirect above 32768, filter_glossy above
 * 1, or not a number). */
enum rayd_status rayd_scene_set_bias(rayd_scene *scene, double clamp_indirect, double filter_glossy,
                                     struct rayd_error *err);

/* ---- frames: animated scenes ----------------------------------------------
 * A scene with an "animation" block (docs/scene-format.md, "Animation") has
 * frames start..end; its keyframes and glTF animations give each frame its
 * camera, lights and transforms.  A scene is loaded at one frame: frame k
 * is a pure function of the scene's bytes and k (the same bytes of every
 * pixel on any node, thread count or tiling).  A server renders a shot by
 * parsing the scene once per frame.  A scene without the block is a still:
 * one frame, 0. */
struct rayd_animation {
    int animated;    /* 1 with an "animation" block, else 0 (one frame, 0) */
    long start, end; /* the frames, inclusive: end - start + 1 of them */
    double fps;      /* frames per second (24 by default; 0 for a still) */
    long frame;      /* the frame this scene shows */
};

/* rayd_scene_parse at frame `frame`: start <= frame <= end, or
 * RAYD_E_ARG (path "/animation") naming the range; for a still scene only
 * frame 0.  rayd_scene_parse is the scene's first frame. */
enum rayd_status rayd_scene_parse_frame(const char *json, size_t len, const struct rayd_limits *lim,
                                        long frame, rayd_scene **out, struct rayd_error *err);
/* The values the keyframes give the camera, the lights and the objects'
 * transforms, checked at every frame first..last (within the scene's
 * frames) by the checks rayd_scene_parse_frame makes, but with no object
 * built and no file read: RAYD_OK, or the error of the first frame that
 * fails, as its parse would give it ("at frame 11, fov_x: ...", the
 * keyframes' pointer).  A frame-range job runs it before its first frame,
 * so a smooth keyframe overshooting a limit late fails it before anything
 * renders.  About 10 us a frame for each thing with keyframes (what a
 * frame's parse spends on them too); lim->cancel is looked at each frame.
 * A still scene: RAYD_OK. */
enum rayd_status rayd_scene_check_frames(const char *json, size_t len,
                                         const struct rayd_limits *lim, long first, long last,
                                         struct rayd_error *err);
/* The scene's frames, and the one it was loaded at. */
void rayd_scene_animation(const rayd_scene *scene, struct rayd_animation *out);

/* ---- the files a scene read ------------------------------------------------
 * A scene may read files (a mesh's, a glTF's buffers and images, a texture's,
 * an environment map's "file"); the scene keeps what each one was when it was
 * read, as make and ccache's direct mode do, so a cache of compiled scenes
 * can tell cheaply (a stat, never a read) that a file changed under it. */

/* A file's identity (stat): equal identities mean an unchanged file. */
struct rayd_file_id {
    unsigned long long dev, ino, size;
    long long mtime_ns; /* modification time, nanoseconds since the epoch */
};

/* What rayd_scene_files_check finds. */
enum rayd_files_state {
    RAYD_FILES_CURRENT,   /* every file is as it was read (or there are none) */
    RAYD_FILES_UNSETTLED, /* as read, but one was written less than
                           * RAYD_FILES_SETTLE_NS before it was read: a later
                           * write within its timestamp's resolution would not
                           * show, so only a new read can be trusted */
    RAYD_FILES_CHANGED    /* one is changed, gone, or no longer the same file */
};
#define RAYD_FILES_SETTLE_NS 1000000000LL

/* The number of files the scene read, each counted once per read. */
int rayd_scene_files(const rayd_scene *scene);
/* File i (0 <= i < rayd_scene_files): the path it was opened by, and its
 * identity then (id may be NULL); NULL when i is out of range. */
const char *rayd_scene_file(const rayd_scene *scene, int i, struct rayd_file_id *id);
/* Stats every file the scene read (by the path it was opened by, following
 * links as the open did) and compares it with the identity it had. */
enum rayd_files_state rayd_scene_files_check(const rayd_scene *scene);

/* ---- rendering ----------------------------------------------------------- */

struct rayd_region {
    int x, y; /* top-left pixel, column and row from the top */
    int w, h; /* size; w == 0 && h == 0 means the whole image */
};

struct rayd_render_stats {
    uint64_t rays;  /* all rays cast: primary, shadow, reflected, refracted */
    double seconds; /* wall time of the render call */
};

/* Called from rendering threads, possibly several at once, after each
 * finished tile: done and total count pixels.  Must be thread-safe. */
typedef void (*rayd_progress_fn)(void *user, long done, long total);

/* Called from rendering threads, possibly several at once, when rows
 * [0, rows) of the region are final: every tile that touches them is
 * drawn.  Each call names more rows than any before it was decided, but
 * calls may run in any order; one of them names the region's height, and
 * all have returned when the render returns.  Work done here
 * (rayd_png_stream_rows: encoding the finished bands) runs beside the
 * tiles other threads draw.  Only rayd_render and rayd_render_image call
 * it (not the passes or sample ranges). */
typedef void (*rayd_rows_fn)(void *user, int rows);

struct rayd_render_opts {
    struct rayd_region region; /* what to render; zero = whole image */
    int threads;               /* worker threads; <= 0 means 1 */
    int tile;                  /* tile edge in pixels; <= 0 means 32 */
    rayd_progress_fn progress; /* may be NULL */
    void *progress_user;
    const atomic_int *cancel;        /* may be NULL; non-zero stops the render */
    struct rayd_render_stats *stats; /* may be NULL; filled on return */
    rayd_rows_fn rows;               /* may be NULL; see rayd_rows_fn */
    void *rows_user;
    /* May be NULL: a ray budget, which many renders may share (a server's
     * tiles of one frame).  Each rendering thread takes the rays it casts
     * from it every 1024 rays or so; a render that takes it below zero, or
     * finds it below zero, stops with RAYD_E_LIMIT (no path).  A render
     * whose rays fit is never stopped, so the outcome does not depend on
     * tiling or threads.  The cancel flag and the budget are looked at
     * within about a thousand rays (and at every pixel sample, and inside
     * a ray's walk through instances and CSG trees): a few milliseconds
     * whatever the scene.  The rays cast up to the stop are counted in
     * stats. */
    atomic_int_least64_t *rays_left;
};

/* Checks a region against the scene's image size: RAYD_OK or RAYD_E_ARG
 * with a message naming the bad field. */
enum rayd_status rayd_region_check(const rayd_scene *scene, const struct rayd_region *region,
                                   struct rayd_error *err);

/* Renders opts->region (or the whole image) into a new image of the region's
 * size.  Safe to call from many threads at once on one scene. */
enum rayd_status rayd_render(const rayd_scene *scene, const struct rayd_render_opts *opts,
                             rayd_image **out, struct rayd_error *err);
/* rayd_render into dst, an image of the region's size made by the caller
 * (so that opts->rows may read it while it is drawn; a window image only
 * through its rayd_png_stream). */
enum rayd_status rayd_render_image(const rayd_scene *scene, const struct rayd_render_opts *opts,
                                   rayd_image *dst, struct rayd_error *err);

/* Renders region into an existing image with its top-left pixel at
 * (dst_x, dst_y) of dst, on the calling thread only.  Calls on disjoint
 * destination rectangles may run in parallel.  rays, if not NULL, is
 * increased by the rays cast. */
enum rayd_status rayd_render_into(const rayd_scene *scene, const struct rayd_region *region,
                                  rayd_image *dst, int dst_x, int dst_y, const atomic_int *cancel,
                                  uint64_t *rays, struct rayd_error *err);
/* rayd_render_into with options: opts->region into dst at (dst_x, dst_y),
 * on the calling thread (threads, tile, progress and rows are not read);
 * opts->cancel, opts->rays_left and opts->stats as rayd_render's. */
enum rayd_status rayd_render_tile(const rayd_scene *scene, const struct rayd_render_opts *opts,
                                  rayd_image *dst, int dst_x, int dst_y, struct rayd_error *err);

/* ---- passes: progressive rendering --------------------------------------- */

/* An accumulator holds, for every pixel of a region, the linear sums of its
 * samples 0..n-1 in double, added in sample-index order, so that the image
 * after a pass of n samples is byte for byte the plain render with
 * "samples": n, for any tiling and thread count (docs/scene-format.md, the
 * pass rule).  The one exception is the sample count 1: a one-sample render
 * traces the pixel centre (the paper's ray), which is not sample 0 of a
 * longer render; so a pass [0, 1) holds the centre image, and the next pass
 * from 1 traces sample 0 again before going on.  Sample counts above
 * render.samples of the scene are allowed. */
typedef struct rayd_accum rayd_accum;

/* A new accumulator, no samples yet, for region (NULL or zero: the whole
 * image) of scene; *out owns it, free with rayd_accum_free. */
enum rayd_status rayd_accum_new(const rayd_scene *scene, const struct rayd_region *region,
                                rayd_accum **out, struct rayd_error *err);
void rayd_accum_free(rayd_accum *acc);
/* Samples summed so far per pixel (0 before the first pass). */
int rayd_accum_samples(const rayd_accum *acc);
/* The accumulator's region, resolved (never zero-sized). */
struct rayd_region rayd_accum_region(const rayd_accum *acc);

/* Adds samples samples_from..samples_to-1 of every pixel.  samples_from
 * must be rayd_accum_samples(acc) and samples_to larger.  opts gives
 * threads, tile, progress, cancel and stats; its region is not read (the
 * accumulator's is rendered).  Canceled, the pass leaves the accumulator
 * half added: it refuses further passes and resolves (RAYD_E_ARG), so take
 * the previous pass's image before starting the next. */
enum rayd_status rayd_render_pass(const rayd_scene *scene, const struct rayd_render_opts *opts,
                                  rayd_accum *acc, int samples_from, int samples_to,
                                  struct rayd_error *err);

/* The 8-bit sRGB image of the sums so far: sum * (1 / n) per channel, then
 * the same sRGB rounding as rayd_render.  *out owns a new image. */
enum rayd_status rayd_accum_image(const rayd_accum *acc, rayd_image **out, struct rayd_error *err);
/* Optional exposure and tone curve for the 8-bit image.  The value shown
 * is curve(average * 2^exposure), then sRGB-encoded.  RAYD_TONE_CLAMP is
 * no curve (values above 1 clip to 255): with exposure 0 it is exactly
 * rayd_accum_image.  RAYD_TONE_REINHARD is v / (1 + v) per channel: no
 * clipping, highlights compressed (1.0 shows as 0.5). */
enum rayd_tone_curve { RAYD_TONE_CLAMP = 0, RAYD_TONE_REINHARD = 1 };
struct rayd_tone {
    double exposure; /* stops: each +1 doubles the light; -64..64 */
    enum rayd_tone_curve curve;
};
/* rayd_accum_image through tone (NULL: none). */
enum rayd_status rayd_accum_image_tone(const rayd_accum *acc, const struct rayd_tone *tone,
                                       rayd_image **out, struct rayd_error *err);
/* The linear radiance so far, unclamped, as float RGB: w * h * 3 floats,
 * rows packed, into a new buffer *out (free with rayd_free); each value is
 * (float)(sum * (1 / n)). */
enum rayd_status rayd_accum_linear(const rayd_accum *acc, float **out, struct rayd_error *err);

/* ---- samples over many nodes ---------------------------------------------- */

/* A pixel's sum is exact whatever its grouping (each sample's radiance is
 * rounded to a multiple of 2^-22, capped at 32768, before it is added; at
 * most 65536 samples): so the sums of disjoint sample ranges, rendered
 * anywhere, added in any order, are bit for bit the sums of one render of
 * all of them, and resolve to its very bytes (PNG and EXR). */

/* Renders samples k0..k1-1 of every pixel of a new accumulator's region
 * (0 <= k0 < k1 <= 65536); it then holds k1 - k0 samples.  [0, 1) of a
 * one-sample scene is its centre image, as rayd_render_pass. */
enum rayd_status rayd_render_sample_range(const rayd_scene *scene,
                                          const struct rayd_render_opts *opts, rayd_accum *acc,
                                          int k0, int k1, struct rayd_error *err);
/* An accumulator of a width x height image and no samples, made without the
 * scene: for adding up the sums of ranges rendered elsewhere. */
enum rayd_status rayd_accum_new_sized(int width, int height, rayd_accum **out,
                                      struct rayd_error *err);
/* The accumulator's sums: w * h * 3 doubles, rows packed; read only. */
const double *rayd_accum_sums(const rayd_accum *acc);
/* Adds sums (w * h * 3 doubles of the accumulator's region) of `samples`
 * more samples, another range's: the ranges must not overlap. */
enum rayd_status rayd_accum_add_sums(rayd_accum *acc, const double *sums, int samples,
                                     struct rayd_error *err);
/* The sums of a sample range as bytes (application/x-rayd-sums): "RAYDSUM1",
 * then width, height, k0, k1 as 32-bit little-endian integers, then each
 * sum as an IEEE 754 double, 64-bit little-endian, rows packed, RGB.  *buf (free with rayd_free)
 * holds *len bytes. */
enum rayd_status rayd_sums_encode(int width, int height, int k0, int k1, const double *sums,
                                  void **buf, size_t *len, struct rayd_error *err);
struct rayd_sums_header {
    int width, height, k0, k1;
};
/* Reads rayd_sums_encode's bytes: the header, and the sums into a new
 * buffer *sums (free with rayd_free).  RAYD_E_PARSE names what is wrong. */
enum rayd_status rayd_sums_decode(const void *buf, size_t len, struct rayd_sums_header *hdr,
                                  double **sums, struct rayd_error *err);

/* ---- AOVs: what each pixel sees, beside its light -------------------------
 * An accumulator may also keep, per pixel, the exact sums of its samples'
 * arbitrary output variables (docs/scene-format.md, "AOVs"): the albedo
 * (reflectance of the first hit that is not a perfect mirror or glass),
 * the shading normal facing the camera, the depth (distance from the
 * camera), alpha (coverage), and the object and material ids of the first
 * hit of the pixel's first sample (-1: none).  They are the same whatever
 * the integrator, and exact like the beauty sums: passes, sample ranges
 * merged, any tiling and thread count give the same bits. */
enum rayd_aov {
    RAYD_AOV_ALBEDO = 1,
    RAYD_AOV_NORMAL = 2,
    RAYD_AOV_DEPTH = 4,
    RAYD_AOV_ALPHA = 8,
    RAYD_AOV_OBJECT = 16,
    RAYD_AOV_MATERIAL = 32
};
#define RAYD_AOV_ALL 63
/* Floats a pixel of rayd_accum_aov_linear: albedo R, G, B; normal X, Y, Z;
 * depth (+infinity where no sample hit); alpha; object id; material id. */
#define RAYD_AOV_FLOATS 10
/* Reads a comma-separated list of AOV names ("albedo,normal,depth,alpha,
 * id", "id" being "object,material"; "all" every one) into *mask; an
 * unknown or empty name, or one whose AOVs an earlier name gave already
 * ("normal,normal", "id,object", "all,depth"), is RAYD_E_ARG naming it.
 * The names of one bit: rayd_aov_name. */
enum rayd_status rayd_aov_parse(const char *list, unsigned *mask, struct rayd_error *err);
const char *rayd_aov_name(unsigned aov);
/* Makes acc keep the AOV sums too; only before its first samples. */
enum rayd_status rayd_accum_aov_enable(rayd_accum *acc, struct rayd_error *err);
/* Whether acc keeps them. */
int rayd_accum_has_aov(const rayd_accum *acc);
/* Adds src's samples (beauty and AOV sums) to dst: the same region size,
 * AOVs in both or neither, sample ranges that do not overlap. */
enum rayd_status rayd_accum_merge(rayd_accum *dst, const rayd_accum *src, struct rayd_error *err);
/* The resolved AOVs: w * h * RAYD_AOV_FLOATS floats, rows packed, into a
 * new buffer *out (free with rayd_free). */
enum rayd_status rayd_accum_aov_linear(const rayd_accum *acc, float **out, struct rayd_error *err);
/* An 8-bit picture of one AOV (one bit of enum rayd_aov): albedo as sRGB,
 * normal as (n + 1) / 2, depth as grey focus / (focus + depth) (the
 * camera's focus distance mid-grey, no hit black), alpha as grey, ids as a
 * colour each (no hit black). */
enum rayd_status rayd_accum_aov_image(const rayd_accum *acc, const rayd_scene *scene, unsigned aov,
                                      rayd_image **out, struct rayd_error *err);
/* ---- denoising ------------------------------------------------------------
 * A denoised accumulator renders its region plus the filter's apron (68
 * pixels around it, inside the image) with the AOVs and each pixel's
 * squared luminance, and its resolves (rayd_accum_image, _image_tone,
 * _linear, _rgba) give the region's pixels through rayd's denoiser: an
 * edge-avoiding a-trous wavelet filter guided by albedo, normal, depth
 * and each pixel's variance, fireflies clamped first
 * (docs/scene-format.md, "Denoising").  Its AOV resolves give the
 * region's raw AOVs.  The same bytes for any thread count and tiling: a
 * region is the crop of the denoised whole frame.  It takes passes and
 * sample ranges; it is neither merged nor added to (RAYD_E_ARG). */
#define RAYD_DENOISE_APRON 68 /* the apron's pixels on each side of the region */
/* The filter's work on a pixel of the apron'd region, in rays' worth: what
 * a resolve takes from the ray budget rayd_accum_watch gives it (1.76 us a
 * pixel on one core, about 18 rays at 10^7 a second, rounded up). */
#define RAYD_DENOISE_RAYS 20
enum rayd_status rayd_accum_new_denoised(const rayd_scene *scene, const struct rayd_region *region,
                                         rayd_accum **out, struct rayd_error *err);
/* Whether acc was made by rayd_accum_new_denoised. */
int rayd_accum_denoised(const rayd_accum *acc);
/* Limits for the denoised acc's resolves, as rayd_render_opts gives a
 * render: the filter looks at cancel (may be NULL) and at whether
 * rays_left (may be NULL) is spent every few thousand pixels, and takes
 * RAYD_DENOISE_RAYS a pixel of the apron'd region from rays_left at the
 * end of each of its levels (a fifth each); a resolve stopped ends
 * RAYD_E_CANCELED or RAYD_E_LIMIT.  Both must outlive acc's resolves.
 * Without it a resolve is never stopped. */
void rayd_accum_watch(rayd_accum *acc, const atomic_int *cancel, atomic_int_least64_t *rays_left);
/* A new plain accumulator (*out; free with rayd_accum_free) holding the
 * raw sums of a denoised acc's region, unfiltered, with its AOV sums: its
 * resolves give the image a plain render of the same samples gives (a
 * progressive pass shown raw beside the denoised one).  RAYD_E_ARG for an
 * accumulator not made by rayd_accum_new_denoised. */
enum rayd_status rayd_accum_raw(const rayd_accum *acc, rayd_accum **out, struct rayd_error *err);
/* Likewise, the region's sums filtered (the denoised radiance times the
 * samples) with its raw AOV sums: every resolve of *out gives the bytes
 * the same resolve of acc gives, for one run of the filter however many
 * resolves follow (an 8-bit image and its floats).  Watched as acc's
 * resolves are (rayd_accum_watch). */
enum rayd_status rayd_accum_filtered(const rayd_accum *acc, rayd_accum **out,
                                     struct rayd_error *err);
/* The memory a denoised accumulator of region (inside scene's image) holds
 * for its sums, the filter's apron included (*held), and what a resolve of
 * it allocates on top at its peak (*peak: the filter's buffers over the
 * apron'd pixels, the region's raw view): for a server's memory budget. */
void rayd_accum_denoised_bytes(const rayd_scene *scene, const struct rayd_region *region,
                               size_t *held, size_t *peak);

/* The 8-bit image of the sums with alpha, RGBA (4 bytes a pixel, rows
 * packed, the RGB rayd_accum_image's), into a new buffer *out (free with
 * rayd_free), for rayd_png_encode_rgba. */
enum rayd_status rayd_accum_rgba(const rayd_accum *acc, uint8_t **out, struct rayd_error *err);
/* An 8-bit RGBA PNG of w * h pixels. */
enum rayd_status rayd_png_encode_rgba(const uint8_t *rgba, int w, int h, void **buf, size_t *len,
                                      struct rayd_error *err);
/* rayd_exr_encode with the AOVs of mask as more channels: albedo.R/G/B,
 * N.X/Y/Z, Z, A, objectId, materialId (aov: rayd_accum_aov_linear's). */
enum rayd_status rayd_exr_encode_aov(const float *rgb, const float *aov, unsigned mask, int w,
                                     int h, void **buf, size_t *len, struct rayd_error *err);
/* The reverse, for a server that joins EXR tiles: decodes an EXR that
 * rayd_exr_encode_aov wrote of w x h pixels with the AOVs of mask into rgb
 * (w * h * 3 floats) and aov (w * h * RAYD_AOV_FLOATS, written only at the
 * channels of mask; unused when mask is 0), bit for bit; RAYD_E_INVALID,
 * the message saying why, for anything else (another size or channel set,
 * a damaged file). */
enum rayd_status rayd_exr_decode_aov(const void *buf, size_t len, unsigned mask, int w, int h,
                                     float *rgb, float *aov, struct rayd_error *err);

/* rayd_render_into for linear float RGB: region's linear radiance (as
 * rayd_accum_linear gives it after a pass of all render.samples) into dst,
 * a float RGB image dst_w pixels wide, top-left at (dst_x, dst_y), on the
 * calling thread.  For servers that render an HDR frame in tiles. */
enum rayd_status rayd_render_linear_into(const rayd_scene *scene, const struct rayd_region *region,
                                         float *dst, int dst_w, int dst_x, int dst_y,
                                         const atomic_int *cancel, uint64_t *rays,
                                         struct rayd_error *err);
/* rayd_render_linear_into with options, as rayd_render_tile. */
enum rayd_status rayd_render_linear_tile(const rayd_scene *scene,
                                         const struct rayd_render_opts *opts, float *dst, int dst_w,
                                         int dst_x, int dst_y, struct rayd_error *err);

/* ---- images -------------------------------------------------------------- */

/* A new black w x h image; *out owns it. */
enum rayd_status rayd_image_new(int w, int h, rayd_image **out, struct rayd_error *err);
/* A w x h image for one render streamed into a rayd_png_stream: the
 * stream made for it before the render, and every call of the render's
 * rows callback passed on to rayd_png_stream_rows.  It holds only the rows
 * in flight, not the whole frame, so its pixels cannot be read
 * (rayd_image_pixels gives NULL) nor blitted. */
enum rayd_status rayd_image_new_window(int w, int h, rayd_image **out, struct rayd_error *err);
void rayd_image_free(rayd_image *img);
int rayd_image_width(const rayd_image *img);
int rayd_image_height(const rayd_image *img);
/* Row-major RGB, 3 bytes a pixel, rows packed (stride = 3 * width); NULL
 * for a window image. */
uint8_t *rayd_image_pixels(rayd_image *img);
const uint8_t *rayd_image_pixels_const(const rayd_image *img);

/* Copies the whole of src into dst with its top-left at (x, y); src must fit. */
enum rayd_status rayd_image_blit(rayd_image *dst, const rayd_image *src, int x, int y,
                                 struct rayd_error *err);

/* PNG encoding to memory: *buf (malloc'd, free with rayd_free) holds *len
 * bytes of an 8-bit RGB PNG.  level is the deflate level 0-9 (1, the
 * fastest, is ISA-L's; the others libdeflate's), or -1 for the default,
 * libdeflate's 1 with ISA-L for every fourth band (core/codec/png_encode.c). */
enum rayd_status rayd_png_encode(const rayd_image *img, int level, void **buf, size_t *len,
                                 struct rayd_error *err);
/* rayd_png_encode on threads threads (<= 0: every core).  The image is
 * deflated in bands of rows set by its width alone, so the bytes are the
 * same for every thread count. */
enum rayd_status rayd_png_encode_threads(const rayd_image *img, int level, int threads, void **buf,
                                         size_t *len, struct rayd_error *err);
/* What, besides the pixels, makes the bytes rayd_png_encode writes at
 * level: the deflate library, its version and the level it runs at
 * ("libdeflate 1.14 level 1").  Encoders of one name write the same bytes,
 * so a cache key or a strong ETag of a PNG names it. */
const char *rayd_png_encoder(int level);
/* A PNG encoded while its image is still being drawn: each band of rows is
 * deflated as soon as rayd_png_stream_rows says its rows are final, on the
 * thread that says so, so a render's workers encode between tiles and only
 * the last bands wait for the render's end.  The bytes are rayd_png_encode's
 * whatever the order and threads.  img must outlive the stream.  A window
 * image (rayd_image_new_window) takes one stream, made before its render,
 * and is finished only after it. */
typedef struct rayd_png_stream rayd_png_stream;
struct rayd_png_stats {
    int bands;           /* bands of rows in the file */
    int bands_early;     /* of them, deflated before rayd_png_stream_finish */
    double band_seconds; /* spent filtering and deflating, all threads together */
};
enum rayd_status rayd_png_stream_new(const rayd_image *img, int level, rayd_png_stream **out,
                                     struct rayd_error *err);
/* Rows [0, rows) of the image are final (calls may come from any thread
 * and in any order): deflates, on the calling thread, the bands among
 * those rows that no other call has taken.  The signature is
 * rayd_rows_fn's, so it can be given to a render as opts.rows with the
 * stream as opts.rows_user.  Every call must start before finish or free
 * is called (a render's calls have all returned when it returns); calls
 * still running then are waited for, and their bands kept. */
void rayd_png_stream_rows(void *stream, int rows);
/* Rows done: how many rows at the top of an image drawn tile by tile are
 * complete, whatever order the tiles finish in -- what a consumer reading
 * the image from the top waits for (rayd_png_stream_rows).  The image is
 * cut into rows of tiles, tiles_x tiles each; the last row of tiles may be
 * shorter than tile pixels (height says where the image ends).  Any thread
 * may report a tile, with no lock of its own: the counts are atomic and a
 * tracker's own mutex orders the rows at the top.  Used by the render's
 * threads (opts.rows) and by the server's workers, one tracker each. */
typedef struct rayd_rows rayd_rows;
/* NULL on no memory (or a size below 1). */
rayd_rows *rayd_rows_new(int tiles_x, int tiles_y, int tile, int height);
/* A tile of row of tiles ty is drawn: when that completes rows at the top
 * that were not before, how many pixel rows are complete now; else 0. */
int rayd_rows_tile_done(rayd_rows *r, int ty);
void rayd_rows_free(rayd_rows *r); /* NULL allowed */
/* Deflates the bands left on threads threads (<= 0: every core), after
 * waiting for the rows calls under way; every row must be final by now.
 * *buf as rayd_png_encode's, stats (may be NULL) filled.  Frees the
 * stream, whatever the outcome. */
enum rayd_status rayd_png_stream_finish(rayd_png_stream *s, int threads, void **buf, size_t *len,
                                        struct rayd_png_stats *stats, struct rayd_error *err);
/* Takes bytes in order; returns 0, or non-zero to say they could not be
 * taken (the rest are then not offered). */
typedef int (*rayd_sink_fn)(void *user, const void *buf, size_t len);
/* rayd_png_stream_finish, the file's bytes handed to sink in order from the
 * bands' own buffers instead of joined in one (no copy of the file, no
 * fresh memory for it): rayd-render writes them straight to its output.
 * A sink's refusal is RAYD_E_IO. */
enum rayd_status rayd_png_stream_finish_to(rayd_png_stream *s, int threads, rayd_sink_fn sink,
                                           void *user, struct rayd_png_stats *stats,
                                           struct rayd_error *err);
/* Frees a stream that will not be finished (a canceled render), after
 * waiting for the rows calls under way; NULL is allowed. */
void rayd_png_stream_free(rayd_png_stream *s);
enum rayd_status rayd_png_write_file(const rayd_image *img, const char *path,
                                     struct rayd_error *err);
/* Whether the len bytes at buf are a whole PNG: its signature, then chunks
 * whose CRCs match their bytes, the last IEND (1); else 0, *why saying
 * what is wrong.  No decode: a check of bytes read back from a disk. */
int rayd_png_whole(const void *buf, size_t len, const char **why);
/* The CRC-32 of gzip, zlib and PNG of the len bytes at buf: a check for
 * files that carry none of their own (an EXR kept on disk). */
uint32_t rayd_crc32(const void *buf, size_t len);
/* Decodes any PNG libpng reads into 8-bit RGB; refuses images over max_pixels
 * (<= 0: the default limit). */
enum rayd_status rayd_png_decode(const void *buf, size_t len, long max_pixels, rayd_image **out,
                                 struct rayd_error *err);
/* rayd_read_file then rayd_png_decode: a PNG file ("-" for stdin) to an image. */
enum rayd_status rayd_png_read_file(const char *path, long max_pixels, rayd_image **out,
                                    struct rayd_error *err);

/* HDR out, from linear float RGB (w * h * 3 floats, rows packed, e.g.
 * rayd_accum_linear's).  *buf (malloc'd, free with rayd_free) holds *len
 * bytes; the same pixels always give the same bytes.
 *
 * rayd_exr_encode: OpenEXR, one scanline part, R, G, B as 32-bit float,
 * linear and unclamped, lossless (written by OpenEXR's library): PIZ
 * compression when one float in 20 repeats its left neighbour's (flat
 * regions), else none (noise, as in a path-traced image, which PIZ cannot
 * shrink but takes 4-9 times as long over). */
enum rayd_status rayd_exr_encode(const float *rgb, int w, int h, void **buf, size_t *len,
                                 struct rayd_error *err);
/* rayd_png16_encode: a 16-bit RGB PNG, each value sRGB-encoded (clamped to
 * [0, 1]) and rounded to 16 bits; level is zlib's, -1 the default (4). */
enum rayd_status rayd_png16_encode(const float *rgb, int w, int h, int level, void **buf,
                                   size_t *len, struct rayd_error *err);

/* Reads a whole file ("-" for standard input) into *out (NUL-terminated
 * for convenience; free with rayd_free), *len bytes.  Over max bytes:
 * RAYD_E_LIMIT, read no further.  Not a regular file, or unreadable:
 * RAYD_E_IO with the reason. */
enum rayd_status rayd_read_file(const char *path, size_t max, char **out, size_t *len,
                                struct rayd_error *err);

/* Frees memory the core handed out (PNG buffers, files). */
void rayd_free(void *p);

/* Gives back to the kernel the freed blocks of whole huge pages the core
 * keeps for the next render of the same size (frames, PNG encoder blocks:
 * up to 32 MB), which no count of a caller shows.  For a server that has
 * gone idle after large renders; thread-safe, cheap when nothing is kept. */
void rayd_memory_trim(void);

#ifdef __cplusplus
}
#endif
#endif /* RAYD_H */
