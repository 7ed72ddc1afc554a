/* scene_json_inline.c -- large inline mesh arrays without a cJSON node per
 * number.
 *
 * cJSON spends a malloc'd node of ~60 bytes on each number: a mesh of
 * 327,680 triangles inline is 2 million nodes and most of the load.  So
 * json_check_spans notes the byte spans of the large arrays of plain
 * numbers at a mesh object's "vertices", "indices", "normals" and "uvs",
 * cJSON parses a copy of the text where each is left as "[]", and the mesh
 * loader reads the numbers straight from the original text
 * (format/json_numbers.c) when it meets one of those empty arrays.
 *
 * The k-th array that opens in the text is the k-th array of a pre-order
 * walk of the tree (cJSON keeps document order, and an elided array holds
 * no arrays), so each span is paired with its node by its ordinal; the
 * pairs are then sorted by node for the loader's lookups.
 *
 * Only the mesh loader reads through this table (scene_json_mesh.c,
 * get_flat and get_indices).  An elided array is always a member of an
 * array element with "type": "mesh", which nothing but the mesh loader
 * reads the contents of: the object loader reads the type and the key
 * names first, and a wrong type or key fails there on names alone.  That
 * is why the check pass keeps the fast path to such objects: a triangle's
 * "vertices", a group named "vertices" or a material's keys keep their
 * numbers in the tree.
 */
#include "load/scene_json_inline.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"

void sj_inline_elide(struct sj_inline *in, const char *text, size_t len, char **copy,
                     size_t *copy_len) {
    *copy = NULL;
    in->text = text;
    if (in->spans.n == 0) return;
    char *out = malloc(len);
    in->nodes = calloc(in->spans.n, sizeof *in->nodes);
    if (!out || !in->nodes) {
        free(out);
        in->spans.n = 0; /* every array through cJSON then */
        return;
    }
    size_t from = 0, n = 0;
    for (size_t k = 0; k < in->spans.n; k++) {
        const struct json_span *sp = &in->spans.v[k];
        memcpy(out + n, text + from, sp->open + 1 - from); /* up to and with '[' */
        n += sp->open + 1 - from;
        from = sp->close; /* from ']' on */
    }
    memcpy(out + n, text + from, len - from);
    *copy = out;
    *copy_len = n + len - from;
}

static void match(struct sj_inline *in, const cJSON *v, long *ordinal, size_t *k) {
    if (cJSON_IsArray(v)) {
        if (*k < in->spans.n && in->spans.v[*k].ordinal == *ordinal) {
            in->nodes[*k] = (struct sj_node){v, &in->spans.v[*k]};
            (*k)++;
        }
        (*ordinal)++;
    }
    for (const cJSON *c = v->child; c; c = c->next) match(in, c, ordinal, k);
}

static int cmp_nodes(const void *a, const void *b) {
    uintptr_t x = (uintptr_t)((const struct sj_node *)a)->node;
    uintptr_t y = (uintptr_t)((const struct sj_node *)b)->node;
    return x < y ? -1 : x > y;
}

enum rayd_status sj_inline_match(struct sj_inline *in, const cJSON *root, struct rayd_error *err) {
    if (in->spans.n == 0) return RAYD_OK;
    long ordinal = 0;
    size_t k = 0;
    match(in, root, &ordinal, &k); /* the depth is bounded by json_check */
    if (k != in->spans.n)
        return err_set(err, RAYD_E_INTERNAL, NULL, "inline arrays out of step with the tree");
    qsort(in->nodes, in->spans.n, sizeof *in->nodes, cmp_nodes);
    return RAYD_OK;
}

const struct json_span *sj_inline_span(const struct sj_inline *in, const cJSON *array) {
    if (!in || in->spans.n == 0) return NULL;
    struct sj_node key = {array, NULL};
    const struct sj_node *hit = bsearch(&key, in->nodes, in->spans.n, sizeof key, cmp_nodes);
    return hit ? hit->span : NULL;
}

void sj_inline_free(struct sj_inline *in) {
    free(in->spans.v);
    free(in->nodes);
    memset(in, 0, sizeof *in);
}
