/* thumbnails.c -- rayd-client thumbnails: a folder of models to small PNGs.
 *
 *   rayd-client thumbnails DIR [-o OUTDIR] [--size N] [--view V]
 *                          [--turntable N] -s SERVER...
 *
 * Every .ply, .obj, .glb and .gltf file of DIR (any case; in name order,
 * not recursing) becomes a scene: the model as a base64 mesh source with a
 * neutral grey material, lit by the studio environment (scenes/studio.hdr,
 * embedded from studio_hdr.h), seen through a camera with "frame": "all"
 * from the chosen view, N x N pixels, a few path-traced samples.  The scene
 * is validated locally (a model that does not load fails here, with the
 * core's message) and rendered by the tile machinery (tiles.c) over the
 * servers, into OUTDIR/NAME.png, NAME being the file's name without its
 * extension.  One line a PNG on stderr, "rayd-client: thumbnail ..." or
 * "rayd-client: error: ..."; a model that fails does not stop the others.
 * Two models whose names differ only in the extension (a.glb, a.gltf)
 * would write the same PNGs, the second over the first: that is found
 * before anything is rendered, and the later one in name order is skipped
 * with an error line naming both and the PNG, so the run ends with 1 and
 * the PNG is the first one's.  Names that do not clash are kept as NAME.
 * A .gltf's own files (.bin buffers, images) are inlined as data: URIs
 * first (gltf_bundle.c) and it then travels as "text".
 *
 * --turntable N renders N frames a model instead, OUTDIR/NAME-000.png to
 * NAME-(N-1).png: the same view turned about +Y in steps of 360 / N
 * degrees, by "camera": {"azimuth": A} (the view keeps its elevation).
 * Frame 000 is the view's own azimuth, so it is the plain thumbnail byte
 * for byte; the model is read (and its .gltf bundled) once for all frames.
 */
#include "client.h"

#include <cjson/cJSON.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <errno.h>
#include <math.h>

#include <rayd/rayd.h>

#include "studio_hdr.h"

#define THUMB_SAMPLES 16

/* What every model gets: the image's size, the view, the frames. */
struct thumb_look {
    int size;
    const char *view;
    int turntable; /* 0: one NAME.png; N: NAME-000.png ... at N azimuths */
};

/* A model as the scene carries it: "base64" bytes or, for a .gltf whose
 * files were inlined, its JSON as "text". */
struct thumb_model {
    const char *format, *key;
    char *data; /* NUL-terminated, malloc'd */
};

/* The view's own azimuth (camera_frame.c's table), where turntables start. */
static double thumb_view_azimuth(const char *view) {
    return !strcmp(view, "three-quarter") ? 45 : !strcmp(view, "side") ? 90 : 0;
}

/* The scene's JSON text (malloc'd), or NULL; azimuth is NAN for the view's
 * own. */
static char *thumb_scene(const struct thumb_model *m, const struct thumb_look *look,
                         double azimuth) {
    cJSON *root = cJSON_CreateObject();
    cJSON *cam = cJSON_AddObjectToObject(root, "camera");
    cJSON_AddStringToObject(cam, "frame", "all");
    cJSON_AddStringToObject(cam, "view", look->view);
    if (!isnan(azimuth)) cJSON_AddNumberToObject(cam, "azimuth", azimuth);
    cJSON_AddNumberToObject(cam, "fov_y", 35);
    cJSON *r = cJSON_AddObjectToObject(root, "render");
    cJSON_AddNumberToObject(r, "width", look->size);
    cJSON_AddNumberToObject(r, "height", look->size);
    cJSON_AddNumberToObject(r, "samples", THUMB_SAMPLES);
    cJSON_AddNumberToObject(r, "max_depth", 3);
    cJSON_AddStringToObject(r, "integrator", "path");
    cJSON *env = cJSON_AddObjectToObject(r, "environment");
    cJSON_AddStringToObject(env, "base64", studio_hdr_base64);
    cJSON *objs = cJSON_AddArrayToObject(root, "objects");
    cJSON *mesh = cJSON_CreateObject();
    cJSON_AddItemToArray(objs, mesh);
    cJSON_AddStringToObject(mesh, "type", "mesh");
    cJSON *mat = cJSON_AddObjectToObject(mesh, "material");
    const double grey[3] = {0.7, 0.7, 0.7};
    cJSON_AddItemToObject(mat, "color", cJSON_CreateDoubleArray(grey, 3));
    cJSON *src = cJSON_AddObjectToObject(mesh, "source");
    cJSON_AddStringToObject(src, "format", m->format);
    cJSON_AddStringToObject(src, m->key, m->data);
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return text;
}

/* The model at path into m: 0, or -1 after saying why. */
static int thumb_read(const char *path, const char *format, struct thumb_model *m) {
    struct rayd_error err = {0};
    char *data = NULL;
    size_t len = 0;
    if (rayd_read_file(path, (size_t)1 << 30, &data, &len, &err) != RAYD_OK) {
        fprintf(stderr, "rayd-client: error: %s\n", err.message);
        return -1;
    }
    int files = strcmp(format, "gltf") ? 0 : gltf_bundle(path, &data, &len);
    if (files < 0) {
        free(data);
        return -1;
    }
    m->format = format;
    m->key = files ? "text" : "base64";
    m->data = files ? data : base64enc((const unsigned char *)data, len);
    if (!files) free(data);
    if (!m->data) {
        fprintf(stderr, "rayd-client: error: %s: out of memory\n", path);
        return -1;
    }
    return 0;
}

/* One frame of model m into out: 0 when written, 1 when not (said). */
static int thumb_frame(const struct client_opts *o, const char *path, const struct thumb_model *m,
                       const struct thumb_look *look, double azimuth, const char *out) {
    struct scenefile sf;
    memset(&sf, 0, sizeof sf);
    sf.bytes = thumb_scene(m, look, azimuth);
    if (!sf.bytes) {
        fprintf(stderr, "rayd-client: error: %s: out of memory\n", path);
        return 1;
    }
    sf.len = strlen(sf.bytes);
    if (scenefile_finish(path, &sf) != 0) return 1;
    struct client_opts one = *o;
    one.out = out;
    one.quiet = 1;
    one.what = path; /* a failure is said there, once, naming the model */
    int rc = tiles_render(&one, &sf);
    scenefile_free(&sf);
    if (rc == 0) fprintf(stderr, "rayd-client: thumbnail %s -> %s\n", path, out);
    return rc == 0 ? 0 : 1;
}

/* Frame k of a turntable of n frames: the view's azimuth plus k / n of a
 * turn, kept within [0, 360). */
static double thumb_azimuth(const char *view, int k, int n) {
    double a = thumb_view_azimuth(view) + 360.0 * k / n;
    return a >= 360 ? a - 360 : a;
}

/* The length of a model's name without its extension: the NAME of its
 * NAME.png. */
static int thumb_stem(const char *name) {
    return (int)(strlen(name) - strlen(scenefile_format(name)) - 1);
}

/* One model: 0 when its PNG(s) were written, 1 when not (said).  A
 * turntable stops at the first frame that fails. */
static int thumb_one(const struct client_opts *o, const char *dir, const char *name,
                     const char *outdir, const struct thumb_look *look) {
    const char *format = scenefile_format(name);
    int n = thumb_stem(name);
    char path[4096], out[4096];
    if (snprintf(path, sizeof path, "%s/%s", dir, name) >= (int)sizeof path ||
        snprintf(out, sizeof out, "%s/%.*s-000.png", outdir, n, name) >= (int)sizeof out) {
        fprintf(stderr, "rayd-client: error: %s: the path is too long\n", name);
        return 1;
    }
    struct thumb_model m;
    if (thumb_read(path, format, &m) != 0) return 1;
    int rc = 0;
    if (!look->turntable) {
        /* fits: shorter than the -000.png name checked above */
        if (snprintf(out, sizeof out, "%s/%.*s.png", outdir, n, name) < (int)sizeof out)
            rc = thumb_frame(o, path, &m, look, NAN, out);
    }
    for (int k = 0; k < look->turntable && rc == 0; k++) {
        rc = snprintf(out, sizeof out, "%s/%.*s-%03d.png", outdir, n, name, k) >= (int)sizeof out;
        if (rc == 0)
            rc = thumb_frame(o, path, &m, look, thumb_azimuth(look->view, k, look->turntable), out);
    }
    free(m.data);
    return rc;
}

/* A model of the folder: its name, its stem's length, its place in name
 * order. */
struct thumb_entry {
    const char *name;
    int stem, index;
};

/* By stem, then by name order. */
static int thumb_by_stem(const void *a, const void *b) {
    const struct thumb_entry *x = a, *y = b;
    int c = memcmp(x->name, y->name, (size_t)(x->stem < y->stem ? x->stem : y->stem));
    if (c) return c;
    if (x->stem != y->stem) return x->stem < y->stem ? -1 : 1;
    return x->index - y->index;
}

/* For each model of names (n, in name order) into first[i]: the index of
 * the first model of its stem when that is another one (its PNGs would be
 * written twice), else -1.  Sorted by stem, so a folder of thousands is
 * not compared pair by pair.  0, or -1 when out of memory. */
static int thumb_clashes(struct dirent **names, int n, int *first) {
    struct thumb_entry *e = malloc((size_t)(n ? n : 1) * sizeof *e);
    if (!e) return -1;
    for (int i = 0; i < n; i++) {
        e[i] = (struct thumb_entry){names[i]->d_name, thumb_stem(names[i]->d_name), i};
        first[i] = -1;
    }
    qsort(e, (size_t)n, sizeof *e, thumb_by_stem);
    for (int i = 1; i < n; i++) {
        const struct thumb_entry *a = &e[i - 1], *b = &e[i];
        if (a->stem == b->stem && !memcmp(a->name, b->name, (size_t)a->stem))
            first[b->index] = first[a->index] >= 0 ? first[a->index] : a->index;
    }
    free(e);
    return 0;
}

/* The PNGs of the model name as a message names them: OUTDIR/NAME.png,
 * or a turntable's OUTDIR/NAME-000.png ... NAME-002.png. */
static void thumb_outputs(const char *outdir, const char *name, const struct thumb_look *look,
                          char *buf, size_t size) {
    int n = thumb_stem(name);
    if (!look->turntable)
        snprintf(buf, size, "%s/%.*s.png", outdir, n, name);
    else if (look->turntable == 1)
        snprintf(buf, size, "%s/%.*s-000.png", outdir, n, name);
    else
        snprintf(buf, size, "%s/%.*s-000.png ... %.*s-%03d.png", outdir, n, name, n, name,
                 look->turntable - 1);
}

/* Model name is skipped: its PNGs are those of other, earlier in name
 * order (written, or failed: either way not overwritten).  1, after
 * saying so. */
static int thumb_clash(const char *dir, const char *name, const char *other, const char *outdir,
                       const struct thumb_look *look) {
    char out[8192]; /* OUTDIR and the name twice: enough, and only a message if not */
    thumb_outputs(outdir, name, look, out, sizeof out);
    fprintf(stderr,
            "rayd-client: error: %s/%s: skipped: %s/%s, of the same name but for the extension, "
            "writes %s\n",
            dir, name, dir, other, out);
    return 1;
}

static void thumb_free(struct dirent **list, int n) {
    for (int i = 0; i < n; i++) free(list[i]);
    free(list);
}

static int thumb_filter(const struct dirent *e) {
    return e->d_name[0] != '.' && scenefile_format(e->d_name) != NULL;
}

/* The models of the folder in name order, and the folder for their PNGs
 * made: 0, or -1 after saying why (*list freed). */
static int thumb_list(const char *dir, const char *outdir, struct dirent ***list, int *n) {
    *n = scandir(dir, list, thumb_filter, alphasort);
    if (*n < 0) {
        fprintf(stderr, "rayd-client: error: cannot read the folder %s\n", dir);
        return -1;
    }
    if (mkdir(outdir, 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "rayd-client: error: cannot make the folder %s: %s\n", outdir,
                strerror(errno));
        thumb_free(*list, *n);
        return -1;
    }
    return 0;
}

/* path without its trailing slashes ("models/" -> "models", "/" stays),
 * into buf; NULL when it does not fit. */
static const char *thumb_dir(const char *path, char *buf, size_t size) {
    size_t n = strlen(path);
    while (n > 1 && path[n - 1] == '/') n--;
    if (n >= size) return NULL;
    memcpy(buf, path, n);
    buf[n] = '\0';
    return buf;
}

int thumbnails_run(const struct client_opts *o, const char *dir_arg, const char *outdir_arg,
                   int size, const char *view, int turntable) {
    struct thumb_look look = {size, view, turntable};
    /* "models/" as typed: the names printed and written get no second slash */
    char dbuf[4096], obuf[4096];
    const char *dir = thumb_dir(dir_arg, dbuf, sizeof dbuf);
    const char *outdir = thumb_dir(outdir_arg, obuf, sizeof obuf);
    if (!dir || !outdir) {
        fprintf(stderr, "rayd-client: error: %s: the path is too long\n",
                dir ? outdir_arg : dir_arg);
        return 1;
    }
    struct dirent **list = NULL;
    int n = 0;
    if (thumb_list(dir, outdir, &list, &n) != 0) return 1;
    int *first = malloc((size_t)(n ? n : 1) * sizeof *first);
    if (!first || thumb_clashes(list, n, first) != 0) {
        fprintf(stderr, "rayd-client: error: out of memory\n");
        thumb_free(list, n);
        free(first);
        return 1;
    }
    int failed = 0;
    for (int i = 0; i < n; i++)
        failed += first[i] >= 0
                      ? thumb_clash(dir, list[i]->d_name, list[first[i]]->d_name, outdir, &look)
                      : thumb_one(o, dir, list[i]->d_name, outdir, &look);
    thumb_free(list, n);
    free(first);
    if (n == 0)
        fprintf(stderr, "rayd-client: error: %s has no .ply, .obj, .glb or .gltf model\n", dir);
    return failed || n == 0 ? 1 : 0;
}
