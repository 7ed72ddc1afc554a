/* blob.c -- a PNG shared by reference count.
 *
 * One finished render may answer many requests at once (identical requests
 * join one task) and later ones from the result cache, and libmicrohttpd
 * sends each reply from the same bytes without a copy.  So the bytes live in
 * a blob with an atomic count: the worker that encodes the PNG makes it, the
 * result cache, each waiting request and each response in flight hold a
 * reference, and whoever drops the last frees it -- no lock needed, which is
 * why it sits at the bottom where every layer can reach it.  Its bytes are
 * counted in the one memory budget (mem.c) from its making to its freeing,
 * whoever holds it.
 *
 * A PNG read back from disk is checked before it is served again: every
 * chunk carries a CRC-32 of its type and data, so a file of the right size
 * whose bytes changed (a bad sector, a stray write) fails blob_png_whole.
 */
#include "base/base.h"

#include <stdlib.h>
#include <string.h>
#include <zlib.h>

struct blob *blob_new(void *data, size_t len) {
    struct blob *b = malloc(sizeof *b);
    if (!b) return NULL;
    atomic_init(&b->refs, 1);
    b->data = data;
    b->len = len;
    atomic_init(&b->kind, MEM_RESULTS);
    mem_force(MEM_RESULTS, len + sizeof *b);
    return b;
}

struct blob *blob_ref(struct blob *b) {
    if (b) atomic_fetch_add(&b->refs, 1);
    return b;
}

void blob_unref(struct blob *b) {
    if (b && atomic_fetch_sub(&b->refs, 1) == 1) {
        mem_release((enum mem_kind)atomic_load(&b->kind), b->len + sizeof *b);
        rayd_free(b->data);
        free(b);
    }
}

void blob_kind(struct blob *b, enum mem_kind kind) {
    int old = atomic_exchange(&b->kind, (int)kind);
    if (old != (int)kind) mem_move((enum mem_kind)old, kind, b->len + sizeof *b);
}

/* The big-endian 32-bit number at p. */
static uint32_t blob_be32(const unsigned char *p) {
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

bool blob_png_whole(const unsigned char *p, size_t n, const char **why) {
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    *why = "no PNG signature";
    if (n < sizeof sig || memcmp(p, sig, sizeof sig)) return false;
    for (size_t at = sizeof sig; at < n;) {
        *why = "a chunk runs past the end of the file";
        if (n - at < 12 || blob_be32(p + at) > n - at - 12) return false;
        size_t len = blob_be32(p + at);
        uLong crc = crc32(crc32(0L, Z_NULL, 0), p + at + 4, (uInt)(len + 4));
        *why = "a chunk's CRC does not match its bytes";
        if (crc != blob_be32(p + at + 8 + len)) return false;
        if (!memcmp(p + at + 4, "IEND", 4)) {
            *why = "bytes after IEND";
            return at + 12 + len == n;
        }
        at += 12 + len;
    }
    *why = "no IEND chunk";
    return false;
}
