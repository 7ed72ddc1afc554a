/* scenefiles.c -- what a cached scene is besides its text: the files it
 * read, and the version that names them.
 *
 * A scene's id is the SHA-256 of its text (clients compute it themselves),
 * but a scene may read files under --asset-dir, and a file edited while the
 * text stays the same must not be answered from the caches with the image
 * of the old file.  So, as make and ccache's direct mode do, the compiled
 * scene keeps every file's identity (device, inode, size, modification time
 * in nanoseconds; rayd_scene_files), and before a cached scene is used it is
 * checked with a stat of each file -- cheap enough for every request, and
 * no file is ever read or hashed to answer from a cache.  The list has one
 * entry per distinct file (the core drops a scene's repeated reads of one
 * path), so a scene naming one texture 90,000 times costs one stat a use;
 * rayd_scene_file_checks_total counts them.  A scene of many files is
 * checked on a parse thread, not the connection's (compile.c).
 *
 * The version of a scene is the key of its results and ETags: its id when
 * it read no file (the keys of such scenes are what they always were), else
 * the SHA-256 of the id and every file's path and identity.  A scene whose
 * files were not settled when read (RAYD_FILES_UNSETTLED: written within a
 * timestamp's resolution of the read, or during it) gets a version no other
 * compile will have, so nothing rendered from it is ever taken for a later
 * compile's.
 *
 * Which check a use needs: a request that brings the text (POST /v1/render,
 * /v1/scenes, /v1/jobs) compiles it again unless every file is as read and
 * settled; a GET by id, which has no text to compile, uses the scene the
 * last POST compiled as long as no file changed (and a changed one makes it
 * unknown here, so the client sends the text again).
 */
#include "work/work_private.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

bool scenefiles_usable(const rayd_scene *scene, bool have_text) {
    int nfiles = rayd_scene_files(scene); /* distinct files: the core keeps one per path */
    if (nfiles == 0) return true;
    metrics_file_checks((unsigned long)nfiles);
    enum rayd_files_state st = rayd_scene_files_check(scene);
    return st == RAYD_FILES_CURRENT || (!have_text && st == RAYD_FILES_UNSETTLED);
}

/* Appends file i's line to buf (of size, *n used); false when it is full. */
static bool scenefiles_line(const rayd_scene *scene, int i, char *buf, size_t size, size_t *n) {
    struct rayd_file_id id;
    const char *path = rayd_scene_file(scene, i, &id);
    int w = snprintf(buf + *n, size - *n, "\n%s %llu %llu %llu %lld", path, id.dev, id.ino, id.size,
                     id.mtime_ns);
    if (w < 0 || (size_t)w >= size - *n) return false;
    *n += (size_t)w;
    return true;
}

bool scenefiles_version(const char *id, const rayd_scene *scene, char out[65]) {
    int nfiles = rayd_scene_files(scene);
    if (nfiles == 0) {
        snprintf(out, 65, "%s", id);
        return true;
    }
    size_t size = 128, n = 0;
    for (int i = 0; i < nfiles; i++) size += strlen(rayd_scene_file(scene, i, NULL)) + 96;
    char *buf = malloc(size);
    if (!buf) return false;
    n = (size_t)snprintf(buf, size, "%s", id);
    bool ok = true;
    for (int i = 0; ok && i < nfiles; i++) ok = scenefiles_line(scene, i, buf, size, &n);
    if (ok && rayd_scene_files_check(scene) != RAYD_FILES_CURRENT) {
        static atomic_ullong unsettled;
        snprintf(buf + n, size - n, "\nunsettled %llu", atomic_fetch_add(&unsettled, 1));
        n += strlen(buf + n);
    }
    ok = ok && cache_hash(buf, n, out);
    free(buf);
    return ok;
}
