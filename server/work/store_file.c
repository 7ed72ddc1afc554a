/* store_file.c -- the images' files of the jobs on disk, DIR/results/.
 *
 * An image is written whole or not at all: to NAME.tmp, fsynced, renamed
 * into place (the caller fsyncs the folder and only then records it as
 * done, store.c).  A file is never written again once renamed, so an HTTP
 * thread reads it with a plain read (store_read), and serves it only when
 * its bytes are the ones written: a PNG's chunks carry CRCs
 * (rayd_png_whole); an EXR, which carries no checksum of its own, is
 * written with one after it (store_exr_tail).
 */
#include "work/work_private.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

char *store_dir; /* --data-dir (work_private.h): set by store_open, freed by store_stop */

void store_path(char *buf, size_t size, const char *id, long k, bool exr, bool tmp) {
    char frame[24] = "";
    if (k >= 0) snprintf(frame, sizeof frame, "-%ld", k);
    snprintf(buf, size, "%s/results/%s%s.%s%s", store_dir, id, frame, exr ? "exr" : "png",
             tmp ? ".tmp" : "");
}

int store_fsync_dir(const char *path) {
    int fd = open(path, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return -1;
    int rc = fsync(fd);
    close(fd);
    return rc;
}

/* The test knob of the kill -9 matrix: with --test-gate and
 * RAYD_TEST_STORE_STALL=1 the store thread stops for good between writing
 * an image's temporary file and renaming it, so a test can kill rayd
 * there. */
static void store_test_stall(void) {
    const char *v = getenv("RAYD_TEST_STORE_STALL");
    if (config.test_gate_tiles >= -1 && v && !strcmp(v, "1")) {
        log_warn("RAYD_TEST_STORE_STALL: the store stops before a rename, for good");
        for (;;) pause();
    }
}

/* An EXR file under results/ ends with STORE_EXR_TAIL bytes past the
 * image: a mark and the CRC-32 (little-endian) of the image's bytes, so
 * that one read back can be checked as a PNG's chunks are.  EXR readers
 * stop at the image's last chunk (the offset table says where each is),
 * so the file stays an EXR; what is served is the image without them.  A
 * file that does not end with the mark was written by an earlier rayd and
 * is served unchecked, as it was then. */
#define STORE_EXR_MARK "rayd-crc32:"
#define STORE_EXR_TAIL (sizeof STORE_EXR_MARK - 1 + 4) /* the mark, the CRC: 15 */

size_t store_file_bytes(const struct blob *b, bool exr) {
    return b->len + (exr ? STORE_EXR_TAIL : 0);
}

static void store_exr_tail(const unsigned char *data, size_t len, unsigned char tail[]) {
    uint32_t crc = rayd_crc32(data, len);
    memcpy(tail, STORE_EXR_MARK, sizeof STORE_EXR_MARK - 1);
    for (int i = 0; i < 4; i++) tail[sizeof STORE_EXR_MARK - 1 + i] = (unsigned char)(crc >> 8 * i);
}

/* Whether the EXR file of *len bytes at data is whole: its tail's CRC
 * matches (*len then loses the tail), or it has none (an earlier rayd's);
 * false with *why when its bytes changed on disk. */
static bool store_exr_whole(const unsigned char *data, size_t *len, const char **why) {
    if (*len <= STORE_EXR_TAIL ||
        memcmp(data + *len - STORE_EXR_TAIL, STORE_EXR_MARK, sizeof STORE_EXR_MARK - 1))
        return true;
    unsigned char tail[STORE_EXR_TAIL];
    *len -= STORE_EXR_TAIL;
    store_exr_tail(data, *len, tail);
    if (!memcmp(tail, data + *len, STORE_EXR_TAIL)) return true;
    *why = "its CRC-32 does not match its bytes";
    return false;
}

/* n bytes from p to fd, every one. */
static bool store_write_all(int fd, const unsigned char *p, size_t n) {
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return false;
        p += w;
        n -= (size_t)w;
    }
    return true;
}

int store_write_file(const char *id, long k, bool exr, const struct blob *b) {
    char tmp[4200], path[4200];
    store_path(tmp, sizeof tmp, id, k, exr, true);
    store_path(path, sizeof path, id, k, exr, false);
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd < 0) return -1;
    unsigned char tail[STORE_EXR_TAIL];
    if (exr) store_exr_tail(b->data, b->len, tail);
    if (!store_write_all(fd, b->data, b->len) || (exr && !store_write_all(fd, tail, sizeof tail))) {
        close(fd);
        unlink(tmp);
        return -1;
    }
    if (fsync(fd) != 0 || close(fd) != 0) {
        unlink(tmp);
        return -1;
    }
    store_test_stall();
    return rename(tmp, path);
}

struct blob *store_read(const char *id, bool exr) {
    return store_read_frame(id, -1, exr);
}

struct blob *store_read_frame(const char *id, long k, bool exr) {
    char path[4200];
    store_path(path, sizeof path, id, k, exr, false);
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    struct stat st;
    if (fd < 0) {
        log_error("job %s: frame %ld: cannot read %s: %s", id, k, path, strerror(errno));
        return NULL;
    }
    unsigned char *data = NULL;
    size_t got = 0;
    errno = 0;
    if (fstat(fd, &st) == 0 && st.st_size > 0 && (data = malloc((size_t)st.st_size))) {
        while (got < (size_t)st.st_size) {
            ssize_t n = read(fd, data + got, (size_t)st.st_size - got);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) break;
            got += (size_t)n;
        }
    }
    int e = errno;
    close(fd);
    if (!data || got != (size_t)st.st_size) {
        log_error("job %s: frame %ld: cannot read %s whole: %s", id, k, path,
                  !data ? "out of memory, or an empty file"
                  : e   ? strerror(e)
                        : "it is shorter");
        rayd_free(data);
        return NULL;
    }
    const char *why;
    /* the right size, other bytes? (a bad sector) */
    if (exr ? !store_exr_whole(data, &got, &why) : !rayd_png_whole(data, got, &why)) {
        log_error("job %s: frame %ld: %s is damaged (%s): not served", id, k, path, why);
        rayd_free(data);
        return NULL;
    }
    struct blob *b = blob_new(data, got);
    if (!b) rayd_free(data);
    return b;
}
