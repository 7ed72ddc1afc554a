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
 */
#include "base/base.h"

#include <stdlib.h>

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
