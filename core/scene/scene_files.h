/* scene_files.h -- the files a scene read and what each was then
 * (scene_files.c). */
#ifndef SCENE_FILES_H
#define SCENE_FILES_H

#include <stdbool.h>
#include <sys/stat.h>

#include "rayd/rayd.h"

struct scene_file {
    char *path;             /* as opened: the asset directory joined with the name */
    struct rayd_file_id id; /* fstat of the open file, before it was read */
    bool settled;           /* written over RAYD_FILES_SETTLE_NS before the read */
};

/* Records that s read name (relative to dir unless absolute, dir NULL for
 * none) whose open file fstat gave st; false when out of memory. */
bool scene_files_add(rayd_scene *s, const char *dir, const char *name, const struct stat *st);
/* Makes the list one entry per path, the first read of each in read order
 * (a path read with two identities keeps one no stat matches); false when
 * out of memory, the list unchanged. */
bool scene_files_dedupe(rayd_scene *s);
void scene_files_free(rayd_scene *s);

#endif
