/* store_dir.c -- the --data-dir folder itself, before jobs.db is opened:
 * its lock, its results/ folder, and the one state in which opening
 * jobs.db would destroy images.
 *
 * A second rayd on the same folder is refused (flock on DIR/lock, which
 * holds the PID of the rayd that has it, so the refusal can name it).
 *
 * SQLite takes a jobs.db that is missing or empty for a new store, and the
 * start-up sweep (store.c) then deletes every file under results/ that no
 * job names: every image there.  A jobs.db gone beside a results/ that
 * still holds images is a mistake (a file deleted, a volume mounted over
 * another, a copy that left the database out), never a fresh start, so
 * rayd does not start on it and deletes nothing; an operator who wants a
 * fresh store moves results/ away too.
 */
#include "work/work_private.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

/* The lock is held by another rayd: say which (the PID it wrote in the
 * lock file) and what to do. */
static void store_dir_locked_out(const char *dir, int fd) {
    char pid[24] = "";
    ssize_t n = pread(fd, pid, sizeof pid - 1, 0);
    pid[n > 0 ? n : 0] = 0;
    pid[strspn(pid, "0123456789")] = 0;
    fprintf(stderr,
            "rayd: error: --data-dir %s: another rayd%s%s%s uses it; give this one a folder of "
            "its own\n",
            dir, *pid ? " (PID " : "", pid, *pid ? ")" : "");
}

int store_dir_lock(const char *dir) {
    char path[4200];
    snprintf(path, sizeof path, "%s/lock", dir);
    int fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0600);
    if (fd < 0 || flock(fd, LOCK_EX | LOCK_NB) != 0) {
        if (fd >= 0 && errno == EWOULDBLOCK)
            store_dir_locked_out(dir, fd);
        else
            fprintf(stderr, "rayd: error: --data-dir %s: %s\n", dir, strerror(errno));
        if (fd >= 0) close(fd);
        return -1;
    }
    char pid[24];
    int len = snprintf(pid, sizeof pid, "%ld\n", (long)getpid());
    if (ftruncate(fd, 0) != 0 || pwrite(fd, pid, (size_t)len, 0) != len)
        log_info("--data-dir: could not write the PID into %s: %s", path, strerror(errno));
    return fd;
}

/* The finished files under results/, those the sweep would delete with no
 * job naming them: not a .tmp (a write cut short), not a folder (the sweep
 * deletes none: a volume's lost+found when results/ is a mount point). */
static long store_dir_images(const char *results) {
    DIR *d = opendir(results);
    if (!d) return 0;
    long n = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        size_t len = strlen(e->d_name);
        if (e->d_name[0] == '.' || (len > 4 && !strcmp(e->d_name + len - 4, ".tmp"))) continue;
        struct stat st;
        bool folder =
            e->d_type == DT_DIR ||
            (e->d_type == DT_UNKNOWN &&
             fstatat(dirfd(d), e->d_name, &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISDIR(st.st_mode));
        if (!folder) n++;
    }
    closedir(d);
    return n;
}

/* results/ a folder, made if missing; -1 after saying why. */
static int store_dir_results(const char *dir, const char *results) {
    struct stat st;
    int made = mkdir(results, 0700) == 0 || errno == EEXIST ? 0 : -1;
    if (!made && stat(results, &st) == 0 && !S_ISDIR(st.st_mode)) { /* a file named results */
        made = -1;
        errno = ENOTDIR;
    }
    if (made)
        fprintf(stderr, "rayd: error: --data-dir %s: cannot make results/: %s\n", dir,
                strerror(errno));
    return made;
}

int store_dir_check(const char *dir) {
    char results[4200], db[4200];
    snprintf(results, sizeof results, "%s/results", dir);
    snprintf(db, sizeof db, "%s/jobs.db", dir);
    struct stat st;
    bool no_db = stat(db, &st) != 0 ? errno == ENOENT : st.st_size == 0;
    long images = no_db ? store_dir_images(results) : 0;
    if (images > 0) {
        fprintf(stderr,
                "rayd: error: --data-dir %s: jobs.db is %s but results/ holds %ld image%s; "
                "rayd does not start and deletes nothing: restore jobs.db, or move results/ "
                "away for a new store\n",
                dir, stat(db, &st) == 0 ? "empty" : "missing", images, images == 1 ? "" : "s");
        return -1;
    }
    return store_dir_results(dir, results);
}
