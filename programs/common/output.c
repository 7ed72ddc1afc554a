/* output.c -- the image into -o, whole or not at all.
 *
 * `-o FILE` is written as a temporary file in FILE's folder
 * (FILE.PID.part, created new, never someone else's), flushed to the disk
 * (fsync) and renamed over FILE only then: rename is atomic within one
 * file system, so a reader, or a script that checks for the file, sees the
 * old image or the new one, never half of one, and a run that fails (the
 * disk is full, the render is refused) or is interrupted leaves FILE as it
 * was, or absent.  Every failure removes the temporary file, and so does
 * a signal that ends the program meanwhile (part_guard.c); only a run
 * killed outright (SIGKILL) can leave a FILE.PID.part behind, never a torn
 * FILE.  The fsync keeps a crash just after the rename from leaving FILE
 * empty (the rename may reach the disk before the data).
 *
 * Replacing FILE keeps its permission bits; when FILE is a symbolic link,
 * the file it names is replaced and the link stays.  A name that is no
 * regular file (/dev/null, a FIFO, a terminal) cannot be replaced: it is
 * written in place, and "-" is standard output, as in `rayd-render -o -`
 * (every status line goes to stderr, so the image is then the only thing
 * on stdout).
 */
#include "common/common.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

const char *output_name(const char *path) { return strcmp(path, "-") ? path : "standard output"; }

int output_part(const char *target, const char *ext, const struct stat *old, char **tmp) {
    size_t n = strlen(target) + strlen(ext) + 32;
    if (!(*tmp = malloc(n))) return -1;
    for (unsigned i = 0; i < 100; i++) {
        if (i == 0)
            snprintf(*tmp, n, "%s.%ld.part%s", target, (long)getpid(), ext);
        else
            snprintf(*tmp, n, "%s.%ld-%u.part%s", target, (long)getpid(), i, ext);
        int fd = open(*tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0 && old && fchmod(fd, old->st_mode & 07777) != 0) {
            int e = errno;
            close(fd);
            unlink(*tmp); /* ours: made just now */
            errno = e;
            break;
        }
        if (fd >= 0) return fd;
        if (errno != EEXIST) break;
    } /* or EEXIST a hundred times: said as such */
    int e = errno;
    free(*tmp);
    *tmp = NULL;
    errno = e;
    return -1;
}

/* path, or the regular file it names through symbolic links, into
 * o->target; *old its stat when it exists.  0 for a name to replace, 1 for
 * one to write in place (no regular file), -1 with errno. */
static int output_where(struct output *o, const char *path, struct stat *old, int *exists) {
    struct stat st;
    *exists = 0;
    if (lstat(path, &st) != 0) {
        if (errno != ENOENT) return -1;
        o->target = strdup(path); /* a new file */
        return o->target ? 0 : -1;
    }
    if (S_ISLNK(st.st_mode)) {
        if (stat(path, &st) != 0) { /* a link to nothing yet: replace the link */
            o->target = strdup(path);
            return o->target ? 0 : -1;
        }
        if (S_ISREG(st.st_mode)) {
            o->target = realpath(path, NULL);
            *old = st, *exists = 1;
            return o->target ? 0 : -1;
        }
    }
    if (!S_ISREG(st.st_mode)) return 1;
    *old = st, *exists = 1;
    o->target = strdup(path);
    return o->target ? 0 : -1;
}

int output_open(struct output *o, const char *path) {
    memset(o, 0, sizeof *o);
    if (!strcmp(path, "-")) {
        o->f = stdout, o->to_stdout = 1;
        return 0;
    }
    struct stat old;
    int exists, where = output_where(o, path, &old, &exists);
    if (where < 0) goto fail;
    int fd;
    if (where == 1) {
        fd = open(path, O_WRONLY | O_CLOEXEC);
    } else {
        char *tmp = NULL;
        sigset_t held;
        part_guard_hold(&held);
        fd = output_part(o->target, "", exists ? &old : NULL, &tmp);
        o->tmp = tmp; /* ours, for output_abort to remove; NULL when none was made */
        if (tmp) part_guard_arm(tmp);
        part_guard_release(&held);
    }
    if (fd < 0) goto fail;
    if (!(o->f = fdopen(fd, "wb"))) {
        close(fd);
        goto fail;
    }
    return 0;
fail:;
    int e = errno;
    output_abort(o);
    errno = e;
    return -1;
}

int output_put(void *user, const void *buf, size_t len) {
    struct output *o = user;
    if (len && fwrite(buf, 1, len, o->f) != len) return -1;
    o->len += len;
    return 0;
}

int output_commit(struct output *o) {
    if (o->to_stdout) return fflush(stdout) == 0 ? 0 : -1;
    int rc = fflush(o->f);
    if (rc == 0 && o->tmp) rc = fsync(fileno(o->f));
    int e = errno;
    if (fclose(o->f) != 0 && rc == 0) rc = -1, e = errno;
    o->f = NULL;
    sigset_t held;
    part_guard_hold(&held);
    if (rc == 0 && o->tmp && rename(o->tmp, o->target) != 0) rc = -1, e = errno;
    if (rc == 0 && o->tmp) part_guard_disarm(o->tmp);
    part_guard_release(&held);
    if (rc == 0) {
        free(o->tmp), free(o->target);
        o->tmp = o->target = NULL;
        return 0;
    }
    output_abort(o);
    errno = e;
    return -1;
}

void output_abort(struct output *o) {
    int e = errno;
    if (o->f && !o->to_stdout) fclose(o->f);
    o->f = NULL;
    sigset_t held;
    part_guard_hold(&held);
    if (o->tmp) unlink(o->tmp);
    if (o->tmp) part_guard_disarm(o->tmp);
    part_guard_release(&held);
    free(o->tmp), free(o->target);
    o->tmp = o->target = NULL;
    errno = e;
}

int output_write(const char *path, const void *buf, size_t len) {
    struct output o;
    if (output_open(&o, path) == 0) {
        if (output_put(&o, buf, len) == 0 && output_commit(&o) == 0) return 0;
        output_abort(&o);
    }
    prog_error("cannot write %s: %s", output_name(path), strerror(errno));
    return -1;
}

int output_writable(const char *path) {
    if (!strcmp(path, "-")) return 0;
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else
        slash[slash == dir] = 0; /* "/x" is in "/" */
    if (access(dir, W_OK | X_OK) == 0) return 0;
    prog_error("cannot write %s: %s", path, strerror(errno));
    return -1;
}
