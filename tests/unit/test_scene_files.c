/* test_scene_files.c -- a scene keeps what each file it read was (device,
 * inode, size, modification time) and rayd_scene_files_check tells, with a
 * stat, whether the files are still so: CURRENT while untouched, CHANGED
 * after a rewrite of the same size with only a new time, after another
 * size, after the file is gone; UNSETTLED for a file whose time is not at
 * least RAYD_FILES_SETTLE_NS before the read (here a time in the future,
 * so the test does not depend on how fast it runs).  Every time is set
 * explicitly with utimensat.  A file named many times is one entry (in the
 * order first read), so a check is one stat per distinct file. */
#include <fcntl.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "rayd/rayd.h"

static const char tri[] = "v 0 0 -3\nv 1 0 -3\nv 0 1 -3\nf 1 2 3\n";
static const char tri2[] = "v 0 0 -3\nv 2 0 -3\nv 0 1 -3\nf 1 2 3\n"; /* same size */

/* Writes text to path and sets its modification time to t seconds. */
static bool put(const char *path, const char *text, time_t t) {
    FILE *f = fopen(path, "w");
    if (!f) return false;
    bool ok = fputs(text, f) >= 0;
    ok = fclose(f) == 0 && ok;
    struct timespec ts[2] = {{t, 0}, {t, 0}};
    return ok && utimensat(AT_FDCWD, path, ts, 0) == 0;
}

/* The scene of one mesh read from dir/tri.obj; NULL if it does not parse. */
static rayd_scene *mesh_scene(const char *dir) {
    static const char json[] = "{\"render\": {\"width\": 8, \"height\": 6}, \"objects\": "
                               "[{\"type\": \"mesh\", \"source\": {\"file\": \"tri.obj\"}}]}";
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.asset_dir = dir;
    rayd_scene *s = NULL;
    return rayd_scene_parse(json, strlen(json), &lim, &s, NULL) == RAYD_OK ? s : NULL;
}

static void test_files_checked(void) {
    char dir[] = "/tmp/rayd-files-XXXXXX", path[64];
    CHECK(mkdtemp(dir) != NULL, "a directory");
    snprintf(path, sizeof path, "%s/tri.obj", dir);
    time_t past = time(NULL) - 3600;
    CHECK(put(path, tri, past), "write %s", path);
    rayd_scene *s = mesh_scene(dir);
    CHECK(s != NULL, "the scene parses");
    if (s) {
        struct rayd_file_id id;
        const char *p = rayd_scene_file(s, 0, &id);
        CHECK(rayd_scene_files(s) == 1 && p && !strcmp(p, path), "one file, %s", p ? p : "none");
        CHECK(id.size == sizeof tri - 1 && id.mtime_ns == (long long)past * 1000000000LL,
              "its size %llu and time %lld", id.size, id.mtime_ns);
        CHECK(rayd_scene_file(s, 1, NULL) == NULL, "no second file");
        CHECK(rayd_scene_files_check(s) == RAYD_FILES_CURRENT, "untouched: current");
        CHECK(put(path, tri2, past + 1) && rayd_scene_files_check(s) == RAYD_FILES_CHANGED,
              "same size, new time: changed");
        CHECK(put(path, tri, past) && rayd_scene_files_check(s) == RAYD_FILES_CURRENT,
              "the same bytes and time again: current");
        CHECK(put(path, "v 0 0 -3\nv 1 0 -3\nv 0 1 -3\nv 1 1 -3\nf 1 2 3\nf 2 4 3\n", past) &&
                  rayd_scene_files_check(s) == RAYD_FILES_CHANGED,
              "another size, the same time: changed");
        CHECK(unlink(path) == 0 && rayd_scene_files_check(s) == RAYD_FILES_CHANGED,
              "gone: changed");
        rayd_scene_free(s);
    }
    CHECK(put(path, tri, time(NULL) + 3600), "write %s", path);
    s = mesh_scene(dir);
    CHECK(s && rayd_scene_files_check(s) == RAYD_FILES_UNSETTLED,
          "a time after the read: unsettled");
    rayd_scene_free(s);
    s = NULL;
    static const char none[] = "{\"render\": {\"width\": 8, \"height\": 6}, \"objects\": "
                               "[{\"type\": \"sphere\", \"center\": [0, 0, -3], \"radius\": 1}]}";
    CHECK(rayd_scene_parse(none, strlen(none), NULL, &s, NULL) == RAYD_OK && s &&
              rayd_scene_files(s) == 0 && rayd_scene_files_check(s) == RAYD_FILES_CURRENT,
          "no file: current");
    rayd_scene_free(s);
    unlink(path);
    rmdir(dir);
}

/* A scene naming a.obj, b.obj, a.obj, a.obj, b.obj keeps a then b. */
static void test_files_once(void) {
    char dir[] = "/tmp/rayd-files-XXXXXX", a[64], b[64];
    CHECK(mkdtemp(dir) != NULL, "a directory");
    snprintf(a, sizeof a, "%s/a.obj", dir);
    snprintf(b, sizeof b, "%s/b.obj", dir);
    time_t past = time(NULL) - 3600;
    CHECK(put(a, tri, past) && put(b, tri2, past), "write %s and %s", a, b);
    char json[1024];
    int n =
        snprintf(json, sizeof json, "{\"render\": {\"width\": 8, \"height\": 6}, \"objects\": [");
    const char *names[] = {"a", "b", "a", "a", "b"};
    for (int i = 0; i < 5; i++)
        n += snprintf(json + n, sizeof json - (size_t)n,
                      "%s{\"type\": \"mesh\", \"source\": {\"file\": \"%s.obj\"}}", i ? ", " : "",
                      names[i]);
    snprintf(json + n, sizeof json - (size_t)n, "]}");
    struct rayd_limits lim;
    rayd_limits_default(&lim);
    lim.asset_dir = dir;
    rayd_scene *s = NULL;
    CHECK(rayd_scene_parse(json, strlen(json), &lim, &s, NULL) == RAYD_OK && s, "the scene parses");
    if (s) {
        const char *p0 = rayd_scene_file(s, 0, NULL), *p1 = rayd_scene_file(s, 1, NULL);
        CHECK(rayd_scene_files(s) == 2 && p0 && p1 && !strcmp(p0, a) && !strcmp(p1, b),
              "two files, a then b: %d, %s, %s", rayd_scene_files(s), p0 ? p0 : "-", p1 ? p1 : "-");
        CHECK(rayd_scene_files_check(s) == RAYD_FILES_CURRENT, "current");
        CHECK(put(b, tri, past + 1) && rayd_scene_files_check(s) == RAYD_FILES_CHANGED,
              "the second file changed: changed");
    }
    rayd_scene_free(s);
    unlink(a);
    unlink(b);
    rmdir(dir);
}

int main(void) {
    RUN(test_files_checked);
    RUN(test_files_once);
    CHECK_EXIT();
}
