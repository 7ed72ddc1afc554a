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
    int rc = tiles_render(&one, &sf);
    scenefile_free(&sf);
    if (rc == 0)
        fprintf(stderr, "rayd-client: thumbnail %s -> %s\n", path, out);
    else
        fprintf(stderr, "rayd-client: error: %s: the render failed\n", path);
    return rc == 0 ? 0 : 1;
}

/* Frame k of a turntable of n frames: the view's azimuth plus k / n of a
 * turn, kept within [0, 360). */
static double thumb_azimuth(const char *view, int k, int n) {
    double a = thumb_view_azimuth(view) + 360.0 * k / n;
    return a >= 360 ? a - 360 : a;
}

/* One model: 0 when its PNG(s) were written, 1 when not (said).  A
 * turntable stops at the first frame that fails. */
static int thumb_one(const struct client_opts *o, const char *dir, const char *name,
                     const char *outdir, const struct thumb_look *look) {
    const char *format = scenefile_format(name);
    int n = (int)(strlen(name) - strlen(format) - 1);
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
        snprintf(out, sizeof out, "%s/%.*s.png", outdir, n, name);
        rc = thumb_frame(o, path, &m, look, NAN, out);
    }
    for (int k = 0; k < look->turntable && rc == 0; k++) {
        snprintf(out, sizeof out, "%s/%.*s-%03d.png", outdir, n, name, k);
        rc = thumb_frame(o, path, &m, look, thumb_azimuth(look->view, k, look->turntable), out);
    }
    free(m.data);
    return rc;
}

static int thumb_filter(const struct dirent *e) {
    return e->d_name[0] != '.' && scenefile_format(e->d_name) != NULL;
}

int thumbnails_run(const struct client_opts *o, const char *dir, const char *outdir, int size,
                   const char *view, int turntable) {
    struct thumb_look look = {size, view, turntable};
    struct dirent **list = NULL;
    int n = scandir(dir, &list, thumb_filter, alphasort);
    if (n < 0) {
        fprintf(stderr, "rayd-client: error: cannot read the folder %s\n", dir);
        return 1;
    }
    if (mkdir(outdir, 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "rayd-client: error: cannot make the folder %s: %s\n", outdir,
                strerror(errno));
        for (int i = 0; i < n; i++) free(list[i]);
        free(list);
        return 1;
    }
    int failed = 0;
    for (int i = 0; i < n; i++) {
        failed += thumb_one(o, dir, list[i]->d_name, outdir, &look);
        free(list[i]);
    }
    free(list);
    if (n == 0)
        fprintf(stderr, "rayd-client: error: %s has no .ply, .obj, .glb or .gltf model\n", dir);
    return failed || n == 0 ? 1 : 0;
}
