/* file.c -- reading whole files, for every program built on the core.
 *
 * Scenes, meshes and textures are read whole.  One function does it for
 * the CLI, the loader's asset files, the tools and the benches: standard
 * input as "-", a size cap checked while reading (so a stream never grows
 * memory past the limit), and only regular files, so a directory or a
 * device named by mistake fails cleanly.
 */
#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "base/error.h"
#include "base/hugemem.h"

enum rayd_status rayd_read_file(const char *path, size_t max, char **out, size_t *len,
                                struct rayd_error *err) {
    bool in = strcmp(path, "-") == 0;
    FILE *f = in ? stdin : fopen(path, "rb");
    if (!f) return err_set(err, RAYD_E_IO, NULL, "cannot open %s: %s", path, strerror(errno));
    struct stat st;
    if (!in && (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode))) {
        fclose(f);
        return err_set(err, RAYD_E_IO, NULL, "%s is not a regular file", path);
    }
    /* a regular file's size is known: one block, on huge pages when big
     * (hugemem.c), read in one go; a stream grows by doubling */
    size_t cap = 1 << 16, n = 0;
    if (!in && (uintmax_t)st.st_size < (uintmax_t)max && (size_t)st.st_size + 1 > cap)
        cap = (size_t)st.st_size + 1;
    char *buf = huge_alloc(cap + 1);
    enum rayd_status rc = RAYD_OK;
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap) break;
        if (n > max) {
            rc = err_set(err, RAYD_E_LIMIT, NULL, "%s is over the limit of %zu bytes", path, max);
            break;
        }
        char *nb = cap < SIZE_MAX / 4 ? realloc(buf, cap * 2 + 1) : NULL;
        if (!nb) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = nb;
        cap *= 2;
    }
    if (rc == RAYD_OK && !buf)
        rc = err_set(err, RAYD_E_NOMEM, NULL, "out of memory reading %s", path);
    if (rc == RAYD_OK && ferror(f)) rc = err_set(err, RAYD_E_IO, NULL, "cannot read %s", path);
    if (rc == RAYD_OK && n > max)
        rc = err_set(err, RAYD_E_LIMIT, NULL, "%s is over the limit of %zu bytes", path, max);
    if (!in) fclose(f);
    if (rc != RAYD_OK) {
        free(buf);
        return rc;
    }
    buf[n] = '\0'; /* a convenience for text; len is what counts */
    *out = buf;
    *len = n;
    return RAYD_OK;
}
