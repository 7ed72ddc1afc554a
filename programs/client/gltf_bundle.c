/* gltf_bundle.c -- a .gltf made to travel alone: its files become data: URIs.
 *
 * A .gltf is JSON that may name other files: buffers ("uri": "engine.bin")
 * and images ("uri": "tex.png"), relative to the .gltf itself.  rayd-render
 * reads them from disk, but a server sees only the bytes it is sent (and
 * reads files only inside its own --asset-dir), so rayd-client rewrites the
 * JSON before sending it: every buffer and image "uri" that names a file is
 * read from next to the .gltf and replaced by
 * "data:application/octet-stream;base64,..." (an image by "data:image/png"
 * or "image/jpeg", from its mimeType or else its name).  The core decodes a
 * data: URI to the very bytes it would have read, so the server's image is
 * rayd-render's byte for byte.
 *
 * A name is read the way the core reads it (%XX decoded; a URI with a
 * scheme, "://", is refused), and confined to the .gltf's folder, since a
 * model from elsewhere must not make the client send, say, ~/.ssh files to
 * a server: no absolute name, no ".." component, no symbolic link leading
 * out (the real paths are compared), a regular file of at most the core's
 * default max_bytes.  An error names the .gltf, the JSON Pointer of the
 * "uri" (/buffers/0/uri) and the file.  JSON the client cannot parse is
 * left as it is: the core's parse then reports it with line and column.
 * A .gltf given in the scene as "text" or "base64" names files relative to
 * the scene's folder, as rayd-render reads them: the same rewriting, in
 * that folder.
 */
#include "client.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include <rayd/rayd.h>

struct gltf_bundle {
    const char *gltf;   /* the .gltf's name, for messages */
    char dir[PATH_MAX]; /* its folder's real path */
    size_t max;         /* bytes per file and in all */
    size_t total;
    int count;
};

static int gltf_hex(char c) {
    return c >= '0' && c <= '9'   ? c - '0'
           : c >= 'a' && c <= 'f' ? c - 'a' + 10
           : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                  : -1;
}

/* A URI's file name, %XX decoded, into out; NULL when it is one, else why
 * not. */
static const char *gltf_name(const char *uri, char *out, size_t cap) {
    size_t n = 0;
    if (!uri[0]) return "is empty";
    if (strstr(uri, "://")) return "is a URL, not a file next to the .gltf";
    for (const char *c = uri; *c; c++) {
        int ch = (unsigned char)*c;
        if (*c == '%' && gltf_hex(c[1]) >= 0 && gltf_hex(c[2]) >= 0)
            ch = gltf_hex(c[1]) * 16 + gltf_hex(c[2]), c += 2;
        if (ch == 0 || n + 1 >= cap) return "is not a file name";
        out[n++] = (char)ch;
    }
    out[n] = '\0';
    return gltf_bundle_outside(out);
}

const char *gltf_bundle_outside(const char *name) {
    if (!name[0]) return "is empty";
    if (name[0] == '/')
        return "is an absolute path: only files in the folder it is read from are sent";
    for (const char *p = name; p;) {
        const char *slash = strchr(p, '/');
        size_t len = slash ? (size_t)(slash - p) : strlen(p);
        if (len == 2 && p[0] == '.' && p[1] == '.')
            return "has a '..' component: only files in the folder it is read from are sent";
        p = slash ? slash + 1 : NULL;
    }
    return NULL;
}

/* The MIME type of an image's data: URI: its mimeType, else its name's. */
static const char *gltf_mime(const cJSON *item, const char *name, int image) {
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(item, "mimeType");
    if (image && cJSON_IsString(m) && strchr(m->valuestring, '/') && !strpbrk(m->valuestring, ",;"))
        return m->valuestring;
    size_t n = strlen(name);
    if (image && n > 4 && !strcasecmp(name + n - 4, ".png")) return "image/png";
    if (image && ((n > 4 && !strcasecmp(name + n - 4, ".jpg")) ||
                  (n > 5 && !strcasecmp(name + n - 5, ".jpeg"))))
        return "image/jpeg";
    return "application/octet-stream";
}

/* The bytes of name under b->dir, confined there; NULL after saying why. */
static char *gltf_read(struct gltf_bundle *b, const char *ptr, const char *name, size_t *len) {
    char path[PATH_MAX * 2], real[PATH_MAX];
    snprintf(path, sizeof path, "%s/%s", b->dir, name);
    struct stat st;
    const char *why = NULL;
    size_t dl = strlen(b->dir);
    if (!realpath(path, real))
        why = strerror(errno);
    else if (strncmp(real, b->dir, dl) ||
             (real[dl] != '/' && real[dl] != '\0' && !(dl == 1 && b->dir[0] == '/')))
        why = "it leads out of the .gltf's folder";
    else if (stat(real, &st) != 0 || !S_ISREG(st.st_mode))
        why = "not a regular file";
    else if ((size_t)st.st_size > b->max || b->total + (size_t)st.st_size > b->max)
        why = "too large to send";
    if (why) {
        fprintf(stderr, "rayd-client: error: %s: %s: cannot read \"%s\": %s\n", b->gltf, ptr, name,
                why);
        return NULL;
    }
    char *data = NULL;
    struct rayd_error err = {0};
    if (rayd_read_file(real, b->max, &data, len, &err) != RAYD_OK) {
        fprintf(stderr, "rayd-client: error: %s: %s: %s\n", b->gltf, ptr, err.message);
        return NULL;
    }
    b->total += *len;
    return data;
}

/* item's "uri" as a data: URI when it names a file: 0, or -1 (said). */
static int gltf_inline(struct gltf_bundle *b, cJSON *item, const char *ptr, int image) {
    cJSON *uri = cJSON_GetObjectItemCaseSensitive(item, "uri");
    if (!cJSON_IsString(uri) || !strncmp(uri->valuestring, "data:", 5))
        return 0; /* none, a data: URI (as the core tells one), or a wrong type the core reports */
    char name[1024];
    const char *bad = gltf_name(uri->valuestring, name, sizeof name);
    if (bad) {
        fprintf(stderr, "rayd-client: error: %s: %s: \"%s\" %s\n", b->gltf, ptr, uri->valuestring,
                bad);
        return -1;
    }
    size_t len = 0;
    char *data = gltf_read(b, ptr, name, &len);
    if (!data) return -1;
    char *b64 = base64enc((const unsigned char *)data, len);
    free(data);
    const char *mime = gltf_mime(item, name, image);
    size_t n = b64 ? strlen("data:;base64,") + strlen(mime) + strlen(b64) + 1 : 0;
    char *s = n ? malloc(n) : NULL;
    if (s) snprintf(s, n, "data:%s;base64,%s", mime, b64);
    free(b64);
    if (!s || !cJSON_ReplaceItemInObjectCaseSensitive(item, "uri", cJSON_CreateString(s))) {
        free(s);
        fprintf(stderr, "rayd-client: error: %s: %s: out of memory\n", b->gltf, ptr);
        return -1;
    }
    free(s);
    b->count++;
    return 0;
}

/* Every entry of the array root[key]: 0, or -1 (said). */
static int gltf_inline_all(struct gltf_bundle *b, cJSON *root, const char *key, int image) {
    cJSON *arr = cJSON_GetObjectItemCaseSensitive(root, key);
    if (!cJSON_IsArray(arr)) return 0;
    int i = 0;
    for (cJSON *item = arr->child; item; item = item->next, i++) {
        char ptr[64];
        snprintf(ptr, sizeof ptr, "/%s/%d/uri", key, i);
        if (cJSON_IsObject(item) && gltf_inline(b, item, ptr, image) != 0) return -1;
    }
    return 0;
}

int gltf_bundle_in(const char *dir, const char *name, char **json, size_t *len) {
    cJSON *root = cJSON_ParseWithLength(*json, *len);
    if (!cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return 0; /* a .glb's bytes, or JSON the core will report */
    }
    struct gltf_bundle b = {.gltf = name};
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    b.max = lim.max_bytes;
    int rc = 0;
    if (!realpath(dir[0] ? dir : ".", b.dir)) {
        fprintf(stderr, "rayd-client: error: %s: cannot resolve the folder %s: %s\n", name,
                dir[0] ? dir : ".", strerror(errno));
        rc = -1;
    }
    if (rc == 0) rc = gltf_inline_all(&b, root, "buffers", 0);
    if (rc == 0) rc = gltf_inline_all(&b, root, "images", 1);
    if (rc == 0 && b.count) {
        char *s = cJSON_PrintUnformatted(root);
        if (!s) {
            fprintf(stderr, "rayd-client: error: %s: out of memory\n", name);
            rc = -1;
        } else {
            free(*json);
            *json = s;
            *len = strlen(s);
        }
    }
    cJSON_Delete(root);
    return rc < 0 ? -1 : b.count;
}

int gltf_bundle(const char *path, char **json, size_t *len) {
    char dir[PATH_MAX];
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else
        snprintf(dir, sizeof dir, "%.*s", slash == path ? 1 : (int)(slash - path), path);
    return gltf_bundle_in(dir, path, json, len);
}
