/* thumbnails.c -- rayd-client thumbnails: a folder of models to small PNGs.
 *
 *   rayd-client thumbnails DIR [-o OUTDIR] [--size N] [--view V] -s SERVER...
 *
 * Every .ply, .obj, .glb and .gltf file of DIR (any case; in name order,
 * not recursing) becomes a scene: the model as a base64 mesh source with a
 * neutral grey material, lit by the studio environment (scenes/studio.hdr,
 * embedded from studio_hdr.h), seen through a camera with "frame": "all"
 * from the chosen view, N x N pixels, a few path-traced samples.  The scene
 * is validated locally (a model that does not load fails here, with the
 * core's message) and rendered by the tile machinery (tiles.c) over the
 * servers, into OUTDIR/NAME.png, NAME being the file's name without its
 * extension.  One line a model on stderr, "rayd-client: thumbnail ..." or
 * "rayd-client: error: ..."; a model that fails does not stop the others.
 * A .gltf's own files (.bin buffers, images) are inlined as data: URIs
 * first (gltf_bundle.c) and it then travels as "text".
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

#include <rayd/rayd.h>

#include "studio_hdr.h"

#define THUMB_SAMPLES 16

/* The mesh source format of a file name, or NULL when it is no model. */
static const char *thumb_format(const char *name)
{
    static const char *const ext[][2] = {
        {".ply", "ply"}, {".obj", "obj"}, {".glb", "glb"}, {".gltf", "gltf"}};
    size_t n = strlen(name);
    for (size_t i = 0; i < sizeof ext / sizeof ext[0]; i++) {
        size_t e = strlen(ext[i][0]);
        if (n > e && !strcasecmp(name + n - e, ext[i][0]))
            return ext[i][1];
    }
    return NULL;
}

/* The scene's JSON text (malloc'd), or NULL, for a model given as key
 * ("base64", or "text" for a .gltf whose files were inlined). */
static char *thumb_scene(const char *format, const char *key, const char *model, int size,
                         const char *view)
{
    cJSON *root = cJSON_CreateObject();
    cJSON *cam = cJSON_AddObjectToObject(root, "camera");
    cJSON_AddStringToObject(cam, "frame", "all");
    cJSON_AddStringToObject(cam, "view", view);
    cJSON_AddNumberToObject(cam, "fov_y", 35);
    cJSON *r = cJSON_AddObjectToObject(root, "render");
    cJSON_AddNumberToObject(r, "width", size);
    cJSON_AddNumberToObject(r, "height", size);
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
    cJSON_AddStringToObject(src, "format", format);
    cJSON_AddStringToObject(src, key, model);
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return text;
}

/* The scene for the model at path into sf: 0, or -1 after saying why. */
static int thumb_load(const char *path, const char *format, int size, const char *view,
                      struct scenefile *sf)
{
    memset(sf, 0, sizeof *sf);
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
    char *enc = files ? data : scenefile_base64((const unsigned char *)data, len);
    if (!files)
        free(data);
    sf->bytes = enc ? thumb_scene(format, files ? "text" : "base64", enc, size, view) : NULL;
    free(enc);
    if (!sf->bytes) {
        fprintf(stderr, "rayd-client: error: %s: out of memory\n", path);
        return -1;
    }
    sf->len = strlen(sf->bytes);
    return scenefile_finish(path, sf);
}

/* One model: 0 when its PNG was written, 1 when not (said). */
static int thumb_one(const struct client_opts *o, const char *dir, const char *name,
                     const char *outdir, int size, const char *view)
{
    const char *format = thumb_format(name);
    size_t n = strlen(name) - strlen(format) - 1;
    char path[4096], out[4096];
    if (snprintf(path, sizeof path, "%s/%s", dir, name) >= (int)sizeof path ||
        snprintf(out, sizeof out, "%s/%.*s.png", outdir, (int)n, name) >= (int)sizeof out) {
        fprintf(stderr, "rayd-client: error: %s: the path is too long\n", name);
        return 1;
    }
    struct scenefile sf;
    if (thumb_load(path, format, size, view, &sf) != 0)
        return 1;
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

static int thumb_filter(const struct dirent *e)
{
    return e->d_name[0] != '.' && thumb_format(e->d_name) != NULL;
}

int thumbnails_run(const struct client_opts *o, const char *dir, const char *outdir, int size,
                   const char *view)
{
    struct dirent **list = NULL;
    int n = scandir(dir, &list, thumb_filter, alphasort);
    if (n < 0) {
        fprintf(stderr, "rayd-client: error: cannot read the folder %s\n", dir);
        return 1;
    }
    if (mkdir(outdir, 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "rayd-client: error: cannot make the folder %s: %s\n", outdir, strerror(errno));
        for (int i = 0; i < n; i++)
            free(list[i]);
        free(list);
        return 1;
    }
    int failed = 0;
    for (int i = 0; i < n; i++) {
        failed += thumb_one(o, dir, list[i]->d_name, outdir, size, view);
        free(list[i]);
    }
    free(list);
    if (n == 0)
        fprintf(stderr, "rayd-client: error: %s has no .ply, .obj, .glb or .gltf model\n", dir);
    return failed || n == 0 ? 1 : 0;
}
