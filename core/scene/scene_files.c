/* scene_files.c -- the files a scene read, and whether they changed since.
 *
 * A compiled scene is cached by its text, but the text is not all of it: a
 * mesh, a glTF's buffers and images, a texture or an environment map may be
 * read from a file, and that file may be edited while the text stays the
 * same.  So, as make and ccache's direct mode do, the scene keeps the
 * identity of every file it read -- device, inode, size and modification
 * time in nanoseconds, from fstat of the very file opened, taken before a
 * byte of it is read -- and rayd_scene_files_check compares each with a
 * stat by the same path: a cheap check a cache can make on every hit, never
 * a read.  A file written during the read has a newer time than the one
 * recorded, so it shows as changed.
 *
 * One gap is left by the timestamps themselves: a file's time advances in
 * steps (a clock tick; a second on some file systems), so a write in the
 * same step as the read, not changing the size, would leave the identity
 * as it was.  Like ccache's "file too new", a file whose time was within
 * RAYD_FILES_SETTLE_NS of the read is recorded as unsettled, and a check
 * says so: a cache must not trust such a scene for another request, only a
 * new read once the file has settled.
 *
 * A scene may name one file many times (90,000 textures of one image), and
 * each read records it, so when the scene is frozen the list is made one
 * entry per path (scene_files_dedupe): a check is then one stat per
 * distinct file, not per reference.  Two reads of one path that saw
 * different identities (the file changed between them) keep an identity
 * no stat can match, so the scene shows as changed.
 */
#include "scene/scene_files.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "base/array.h"
#include "scene/scene.h"

static long long ns_of(const struct timespec *t) {
    return (long long)t->tv_sec * 1000000000LL + t->tv_nsec;
}

static struct rayd_file_id file_id(const struct stat *st) {
    return (struct rayd_file_id){.dev = (unsigned long long)st->st_dev,
                                 .ino = (unsigned long long)st->st_ino,
                                 .size = (unsigned long long)st->st_size,
                                 .mtime_ns = ns_of(&st->st_mtim)};
}

static bool same_id(struct rayd_file_id a, struct rayd_file_id b) {
    return a.dev == b.dev && a.ino == b.ino && a.size == b.size && a.mtime_ns == b.mtime_ns;
}

static char *join(const char *dir, const char *name) {
    bool rel = dir && name[0] != '/';
    size_t n = (rel ? strlen(dir) + 1 : 0) + strlen(name) + 1;
    char *p = malloc(n);
    if (p) snprintf(p, n, "%s%s%s", rel ? dir : "", rel ? "/" : "", name);
    return p;
}

bool scene_files_add(rayd_scene *s, const char *dir, const char *name, const struct stat *st) {
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    size_t need = (size_t)s->nfiles + 1;
    if (!array_grow((void **)&s->files, &s->files_cap, need, sizeof *s->files)) return false;
    char *path = join(dir, name);
    if (!path) return false;
    struct scene_file *f = &s->files[s->nfiles++];
    f->path = path;
    f->id = file_id(st);
    f->settled = f->id.mtime_ns <= ns_of(&now) - RAYD_FILES_SETTLE_NS;
    return true;
}

struct file_ref {
    const char *path;
    int i; /* its index in the list */
};

/* By path, then by index: the first read of a path first. */
static int by_path(const void *a, const void *b) {
    const struct file_ref *x = a, *y = b;
    int c = strcmp(x->path, y->path);
    return c ? c : (x->i > y->i) - (x->i < y->i);
}

static int by_index(const void *a, const void *b) {
    const struct file_ref *x = a, *y = b;
    return (x->i > y->i) - (x->i < y->i);
}

bool scene_files_dedupe(rayd_scene *s) {
    int n = s->nfiles;
    if (n < 2) return true;
    struct file_ref *ref = malloc((size_t)n * sizeof *ref);
    if (!ref) return false;
    for (int i = 0; i < n; i++) ref[i] = (struct file_ref){s->files[i].path, i};
    qsort(ref, (size_t)n, sizeof *ref, by_path);
    /* keep the first read of each path, marking it when a later read saw
     * another identity */
    int kept = 0;
    for (int k = 0; k < n;) {
        struct scene_file *first = &s->files[ref[k].i];
        int m = k + 1;
        for (; m < n && !strcmp(ref[m].path, first->path); m++) {
            struct scene_file *dup = &s->files[ref[m].i];
            if (!same_id(dup->id, first->id)) first->id = (struct rayd_file_id){.mtime_ns = -1};
            first->settled &= dup->settled;
            free(dup->path);
        }
        ref[kept++] = ref[k];
        k = m;
    }
    qsort(ref, (size_t)kept, sizeof *ref, by_index); /* back in read order */
    for (int i = 0; i < kept; i++) s->files[i] = s->files[ref[i].i];
    s->nfiles = kept;
    free(ref);
    return true;
}

void scene_files_free(rayd_scene *s) {
    for (int i = 0; i < s->nfiles; i++) free(s->files[i].path);
    free(s->files);
    s->files = NULL;
    s->nfiles = 0;
}

int rayd_scene_files(const rayd_scene *s) { return s->nfiles; }

const char *rayd_scene_file(const rayd_scene *s, int i, struct rayd_file_id *id) {
    if (i < 0 || i >= s->nfiles) return NULL;
    if (id) *id = s->files[i].id;
    return s->files[i].path;
}

enum rayd_files_state rayd_scene_files_check(const rayd_scene *s) {
    enum rayd_files_state state = RAYD_FILES_CURRENT;
    for (int i = 0; i < s->nfiles; i++) {
        const struct scene_file *f = &s->files[i];
        struct stat st;
        if (stat(f->path, &st) != 0) return RAYD_FILES_CHANGED;
        if (!same_id(file_id(&st), f->id)) return RAYD_FILES_CHANGED;
        if (!f->settled) state = RAYD_FILES_UNSETTLED;
    }
    return state;
}
