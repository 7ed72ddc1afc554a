/* scenefile.c -- the scene as rayd-client sends it.
 *
 * A server cannot read the client's files (it refuses "file" references
 * unless it was given an asset folder), so before anything is sent every
 * file the scene names is inlined: a mesh "source": {"file": "m.ply"}
 * becomes {"format": "ply", "base64": "..."} (a .gltf, its own .bin and
 * image files inlined as data: URIs by gltf_bundle.c, becomes "text"), an
 * image texture's "file" becomes "png_base64", an environment map's "file"
 * becomes "base64" (the core tells .hdr from OpenEXR by the bytes).
 * Relative names resolve against the scene's folder, as rayd-render does.  The names are
 * confined to that folder as the .gltf bundler confines a .gltf's (gltf_bundle_outside): no
 * absolute path, no ".." component, no symbolic link leading out (the real paths are
 * compared), since a scene from elsewhere must not make the client send, say, ~/.ssh files
 * to a server; the error names the JSON Pointer of the "file" and nothing is sent.  A scene without
 * file references is sent byte for byte as it is on disk, so its id equals `sha256sum scene.json`.
 * The first file that cannot be inlined stops the walk, and the one line
 * said where it failed (the file, its JSON Pointer, the reason) is the
 * whole error: no summary line follows it.
 *
 * The bytes to send are then parsed by the core exactly as a server will
 * parse them (rayd_scene_parse with the default limits): a bad scene is
 * reported here with its JSON Pointer, before any network traffic (an error
 * inside an inlined file is put back at the "file" key the scene has, so
 * the pointer is rayd-render's, not one of the sent text's), and the
 * image size for the tiling comes from rayd_scene_info.  The scene id is the
 * SHA-256 of those bytes (OpenSSL's EVP), the same hash every node computes.
 */
#include "client.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <limits.h>
#include <stdbool.h>
#include <openssl/evp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include <rayd/rayd.h>

/* The bytes of a file ("-" for stdin), or NULL with the reason in err. */
static char *scenefile_read(const char *path, size_t *len, struct rayd_error *err) {
    char *buf = NULL;
    return rayd_read_file(path, (size_t)1 << 30, &buf, len, err) == RAYD_OK ? buf : NULL;
}

struct scenefile_walk {
    const char *scene;   /* the scene's name, for messages */
    const char *dir;     /* the scene's folder with a trailing '/', "" for the cwd */
    char real[PATH_MAX]; /* its real path ("" until needed) */
    int count;
    int failed;           /* said; the walk stops */
    struct scenefile *sf; /* where the inlined keys' pointers are noted */
};

/* Memory ran out while the file at where was inlined: said, and the walk
 * stops. */
static void scenefile_no_memory(struct scenefile_walk *w, const char *where) {
    fprintf(stderr, "rayd-client: error: %s: %s: out of memory\n", w->scene, where);
    w->failed = 1;
}

const char *scenefile_format(const char *name) {
    static const char *const ext[][2] = {
        {".obj", "obj"}, {".ply", "ply"}, {".glb", "glb"}, {".gltf", "gltf"}};
    size_t k = strlen(name);
    for (size_t i = 0; i < sizeof ext / sizeof ext[0]; i++) {
        size_t e = strlen(ext[i][0]);
        if (k > e && !strcasecmp(name + k - e, ext[i][0])) return ext[i][1];
    }
    return NULL;
}

/* Why the file path (name, under the scene's folder) may not be sent, or
 * NULL: a name that leads out of the folder, as a .gltf's may not. */
static const char *scenefile_outside(struct scenefile_walk *w, const char *name, const char *path) {
    const char *why = gltf_bundle_outside(name);
    char real[PATH_MAX];
    if (why || !realpath(path, real)) return why; /* a missing file: its read says so */
    if (!w->real[0] && !realpath(w->dir[0] ? w->dir : ".", w->real))
        return "cannot be checked: the scene's folder does not resolve";
    size_t dl = strlen(w->real);
    bool root = dl == 1 && w->real[0] == '/';
    if (!root && (strncmp(real, w->real, dl) || (real[dl] != '/' && real[dl] != '\0')))
        return "leads out of the scene's folder (a symbolic link): only files in it are sent";
    return NULL;
}

/* A file the scene names cannot be opened: said at its "file" key, the
 * name as the scene gives it, as rayd-render says it: "scene.json:
 * /render/environment/file: cannot open "sky.hdr": No such file or
 * directory".  Opened here first, so the reason is errno's own, not
 * rayd_read_file's message taken apart; what fails after the open (a
 * directory, a file over the limit) is said in that message. */
static bool scenefile_opens(const struct scenefile_walk *w, const char *where, const char *name,
                            const char *path) {
    FILE *f = fopen(path, "rb");
    if (f) {
        fclose(f);
        return true;
    }
    char safe[300];
    fprintf(stderr, "rayd-client: error: %s: %s/file: cannot open \"%s\": %s\n", w->scene, where,
            net_safe(name, safe, sizeof safe), strerror(errno));
    return false;
}

/* The bytes of a "file" a scene names, relative to its folder and confined
 * to it; NULL after saying why.  *path receives the name as opened
 * (malloc'd). */
static char *scenefile_asset(struct scenefile_walk *w, const char *name, const char *where,
                             char **path, size_t *len) {
    size_t n = strlen(w->dir) + strlen(name) + 1;
    *path = malloc(n);
    if (!*path) {
        scenefile_no_memory(w, where);
        return NULL;
    }
    snprintf(*path, n, "%s%s", w->dir, name);
    const char *bad = scenefile_outside(w, name, *path);
    if (bad) {
        char safe[300];
        fprintf(stderr, "rayd-client: error: %s: %s/file: \"%s\" %s\n", w->scene, where,
                net_safe(name, safe, sizeof safe), bad);
        return NULL;
    }
    if (!scenefile_opens(w, where, name, *path)) return NULL;
    struct rayd_error err;
    char *data = scenefile_read(*path, len, &err);
    if (!data)
        fprintf(stderr, "rayd-client: error: %s: %s/file: %s\n", w->scene, where, err.message);
    return data;
}

/* Notes where/newkey as a key that holds the bytes of a "file". */
static void scenefile_note(struct scenefile_walk *w, const char *where, const char *newkey) {
    struct scenefile *sf = w->sf;
    char **more = realloc(sf->inlined, (size_t)(sf->ninlined + 1) * sizeof *more);
    size_t n = strlen(where) + strlen(newkey) + 2;
    char *p = malloc(n);
    if (more) sf->inlined = more;
    if (!more || !p) {
        free(p);
        scenefile_no_memory(w, where);
        return;
    }
    snprintf(p, n, "%s/%s", where, newkey);
    sf->inlined[sf->ninlined++] = p;
}

/* An error's JSON Pointer inside an inlined key, put back at the scene's
 * "file" key: /render/environment/base64 -> /render/environment/file. */
static void scenefile_unmap(const struct scenefile *sf, char *path) {
    for (int i = 0; i < sf->ninlined; i++) {
        const char *p = sf->inlined[i];
        size_t n = strlen(p);
        if (strncmp(path, p, n) || (path[n] != '\0' && path[n] != '/')) continue;
        size_t keep = (size_t)(strrchr(p, '/') - p);
        /* "/file" is no longer than "/text", "/base64" or "/png_base64": in place */
        memmove(path + keep + 5, path + n, strlen(path + n) + 1);
        memcpy(path + keep, "/file", 5);
        return;
    }
}

/* Replaces obj[key] (a file name) by obj[newkey] (its bytes in base64).  A
 * mesh source's .gltf has its own files inlined first (gltf_bundle.c) and
 * then, when that changed it, travels as "text". */
static void scenefile_inline(struct scenefile_walk *w, cJSON *obj, const char *key,
                             const char *newkey, const char *where, int mesh) {
    cJSON *f = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!cJSON_IsString(f)) return; /* the core reports the wrong type with its path */
    const char *name = f->valuestring;
    const char *format = scenefile_format(name);
    const cJSON *given = cJSON_GetObjectItemCaseSensitive(obj, "format");
    const char *as = cJSON_IsString(given) ? given->valuestring : format;
    int gltf = mesh && as && !strcmp(as, "gltf");
    char *path = NULL;
    size_t len = 0;
    char *data = scenefile_asset(w, name, where, &path, &len);
    int files = data && gltf ? gltf_bundle(path, &data, &len) : 0;
    if (!data || files < 0) { /* said by either */
        free(path);
        free(data);
        w->failed = 1;
        return;
    }
    free(path);
    int text = files > 0;
    char *enc = text ? data : base64enc((const unsigned char *)data, len);
    if (!text) free(data);
    if (!enc) {
        scenefile_no_memory(w, where);
        return;
    }
    /* a mesh without "format" took it from the file name: keep it explicit */
    if (mesh && !given && format) cJSON_AddStringToObject(obj, "format", format);
    cJSON_DeleteItemFromObjectCaseSensitive(obj, key);
    if (!cJSON_AddStringToObject(obj, text ? "text" : newkey, enc)) scenefile_no_memory(w, where);
    free(enc);
    scenefile_note(w, where, text ? "text" : newkey);
    w->count++;
}

/* A mesh source {"format": "gltf", "text": "..."}: a .gltf's JSON whose
 * files are next to the scene (rayd-render reads them there), inlined as
 * data: URIs in place.  Any other source is left alone. */
static void scenefile_gltf_text(struct scenefile_walk *w, cJSON *obj, const char *where) {
    const cJSON *format = cJSON_GetObjectItemCaseSensitive(obj, "format");
    const cJSON *text = cJSON_GetObjectItemCaseSensitive(obj, "text");
    if (!cJSON_IsString(format) || strcmp(format->valuestring, "gltf") || !cJSON_IsString(text))
        return;
    char name[1200];
    snprintf(name, sizeof name, "%s: %s/text", w->scene, where);
    size_t len = strlen(text->valuestring);
    char *data = strdup(text->valuestring);
    if (!data) {
        scenefile_no_memory(w, where);
        return;
    }
    int files = gltf_bundle_in(w->dir, name, &data, &len); /* < 0: said */
    if (files > 0 && !cJSON_ReplaceItemInObjectCaseSensitive(obj, "text", cJSON_CreateString(data)))
        scenefile_no_memory(w, where);
    free(data);
    if (files < 0)
        w->failed = 1;
    else
        w->count += files > 0;
}

/* Visits every object of the tree: mesh sources hold "file" beside
 * "format"/"text"/"base64" under a "source" key; image textures are objects
 * with "type": "image"; the environment is the object at "environment". */
/* "/key" into dst[0..cap), with "~" and "/" escaped as "~0" and "~1"
 * (RFC 6901), as the core names the key in its errors. */
static void scenefile_key(char *dst, size_t cap, const char *key) {
    size_t n = 0;
    if (cap < 2) return;
    dst[n++] = '/';
    for (; *key && n + 3 < cap; key++) {
        if (*key == '~' || *key == '/') {
            dst[n++] = '~';
            dst[n++] = *key == '~' ? '0' : '1';
        } else {
            dst[n++] = *key;
        }
    }
    dst[n] = '\0';
}

static void scenefile_walk(struct scenefile_walk *w, cJSON *node, const char *key, char *ptr,
                           size_t ptrlen) {
    if (w->failed) return; /* the scene is not sent: one error is the whole story */
    if (cJSON_IsObject(node)) {
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(node, "type");
        if (key && !strcmp(key, "source") && cJSON_GetObjectItemCaseSensitive(node, "file"))
            scenefile_inline(w, node, "file", "base64", ptr, 1);
        else if (key && !strcmp(key, "source"))
            scenefile_gltf_text(w, node, ptr);
        else if (cJSON_IsString(type) && !strcmp(type->valuestring, "image") &&
                 cJSON_GetObjectItemCaseSensitive(node, "file"))
            scenefile_inline(w, node, "file", "png_base64", ptr, 0);
        else if (key && !strcmp(key, "environment") &&
                 cJSON_GetObjectItemCaseSensitive(node, "file"))
            scenefile_inline(w, node, "file", "base64", ptr, 0);
    }
    if (!cJSON_IsObject(node) && !cJSON_IsArray(node)) return;
    int i = 0;
    for (cJSON *c = node->child; c; c = c->next, i++) {
        size_t len = strlen(ptr);
        if (c->string)
            scenefile_key(ptr + len, ptrlen - len, c->string);
        else
            snprintf(ptr + len, ptrlen - len, "/%d", i);
        scenefile_walk(w, c, c->string, ptr, ptrlen);
        ptr[len] = '\0';
    }
}

/* Inlines the files of sf->bytes; on a change sf->bytes is re-serialised.
 * 0, or -1 after saying why in one line. */
static int scenefile_bundle(const char *path, struct scenefile *sf) {
    cJSON *root = cJSON_ParseWithLength(sf->bytes, sf->len);
    if (!root) return 0; /* malformed: the core's parse reports line and column */
    char dir[4096] = "";
    const char *slash = strrchr(path, '/');
    if (slash && (size_t)(slash - path) + 2 < sizeof dir)
        snprintf(dir, sizeof dir, "%.*s/", (int)(slash - path), path);
    struct scenefile_walk w = {prog_input_name(path), dir, "", 0, 0, sf};
    char ptr[1024] = "";
    scenefile_walk(&w, root, NULL, ptr, sizeof ptr);
    int rc = 0;
    if (w.failed) {
        rc = -1;
    } else if (w.count) {
        char *s = cJSON_PrintUnformatted(root);
        if (!s) {
            fprintf(stderr, "rayd-client: error: %s: out of memory\n", w.scene);
            rc = -1;
        } else {
            free(sf->bytes);
            sf->bytes = s;
            sf->len = strlen(s);
            sf->bundled = w.count;
        }
    }
    cJSON_Delete(root);
    return rc;
}

/* Validates sf->bytes with the core, notes the size and samples, and
 * hashes them; name is the scene as messages call it.  0, or -1 after
 * printing why (sf is freed then). */
int scenefile_finish(const char *name, struct scenefile *sf) {
    struct rayd_error err = {0};
    rayd_scene *scene = NULL;
    /* the limits a server's operator may raise (--max-samples, --max-pixels,
     * --max-body) are the server's to say, in its answer: here only their
     * hard ends, so a scene that server takes is not refused before it is sent */
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.max_samples = RAYD_SAMPLES_MAX;
    lim.max_pixels = LONG_MAX;
    lim.max_bytes = (size_t)1 << 30; /* scenefile_read's */
    if (rayd_scene_parse(sf->bytes, sf->len, &lim, &scene, &err) != RAYD_OK) {
        char msg[600];
        scenefile_unmap(sf, err.path);
        fprintf(stderr, "rayd-client: error: %s: %s: %s\n", name, rayd_status_name(err.code),
                rayd_error_format(&err, msg, sizeof msg));
        scenefile_free(sf);
        return -1;
    }
    sf->name = name;
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    struct rayd_animation an;
    rayd_scene_animation(scene, &an);
    sf->animated = an.animated;
    sf->anim_start = an.start, sf->anim_end = an.end;
    rayd_scene_free(scene);
    sf->width = info.width;
    sf->height = info.height;
    sf->samples = info.samples;
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int mdlen = 0;
    if (!EVP_Digest(sf->bytes, sf->len, md, &mdlen, EVP_sha256(), NULL) || mdlen != 32) {
        fprintf(stderr, "rayd-client: error: SHA-256 failed\n");
        scenefile_free(sf);
        return -1;
    }
    for (unsigned i = 0; i < 32; i++) snprintf(sf->id + 2 * i, 3, "%02x", md[i]);
    return 0;
}

int scenefile_load(const char *path, struct scenefile *sf) {
    memset(sf, 0, sizeof *sf);
    struct rayd_error err = {0};
    sf->bytes = scenefile_read(path, &sf->len, &err);
    if (!sf->bytes) {
        fprintf(stderr, "rayd-client: error: %s\n", err.message);
        return -1;
    }
    if (scenefile_bundle(path, sf) != 0) { /* said where, by the file that failed */
        scenefile_free(sf);
        return -1;
    }
    return scenefile_finish(prog_input_name(path), sf);
}

void scenefile_free(struct scenefile *sf) {
    if (!sf) return;
    free(sf->bytes);
    sf->bytes = NULL;
    sf->len = 0;
    for (int i = 0; i < sf->ninlined; i++) free(sf->inlined[i]);
    free(sf->inlined);
    sf->inlined = NULL;
    sf->ninlined = 0;
}
