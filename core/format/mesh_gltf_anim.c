/* mesh_gltf_anim.c -- glTF node animations: one animation played at one time.
 *
 * What it does: the "gltf" object (scene_json_gltf.c) may ask for one of
 * the file's animations at a time in seconds (gltf_doc_animate).  Before
 * the walk composes the world matrices, each channel of that animation
 * that targets a node's translation, rotation or scale is sampled at that
 * time, and the value replaces the node's own one (struct gl_pose, read by
 * gl_local in mesh_gltf.c).  "weights" (morph targets) is skipped, as morph
 * targets are, and so is a target an extension defines.  A sampler's input
 * is its keyframe times in seconds (floats, increasing), its output the
 * values: LINEAR (the default: rotations slerped), STEP, or CUBICSPLINE
 * (three elements a key: in-tangent, value, out-tangent; the cubic Hermite
 * curve, rotations normalised).  Before the first time the first value
 * holds, after the last the last.  Values are read from the buffers as
 * they are needed: a binary search over the times, so a channel costs
 * O(log n) reads once its sampler is checked.
 *
 * Why a file of its own: the rest of the reader (mesh_gltf.c) is the
 * static geometry every mesh source needs; animation came later, only the
 * "gltf" object plays it, and it alone needs math/keyframe.h.  The two
 * files share struct gl through mesh_gltf_private.h and use each other one
 * way: this file reads accessors with mesh_gltf.c's getters, and the walk
 * reaches gl_animate only through the callback G->animate, which
 * gltf_doc_animate sets together with anim_id (mesh_parse_gltf leaves both
 * unset, so a mesh source never looks at /animations).
 *
 * Invariants:
 *  - every sampler is checked whole before it is sampled: times FLOAT in a
 *    bufferView, finite and strictly increasing (so the search keeps
 *    in[lo] <= t < in[hi] and t1 - t0 > 0), output count = times (x 3 for
 *    CUBICSPLINE), every value finite and within 1e30;
 *  - G->pose has an entry per node, zeroed, and a channel's node index is
 *    checked to be one; channels apply in file order, so of two channels on
 *    one node's path the later wins;
 *  - an animated node must have TRS, not a matrix (gl_local refuses it);
 *  - every error names its value by a JSON Pointer in the glTF document,
 *    as the rest of the reader does, and the buffers the samplers read
 *    count against max_bytes like any other.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "format/mesh_gltf.h"

#include "format/mesh_gltf_private.h"
#include "math/keyframe.h"

struct gl_sampler {
    struct gl_acc in, out;
    int how; /* 0 LINEAR, 1 STEP, 2 CUBICSPLINE */
};

static void gl_elem(const struct gl_acc *a, uint32_t i, int n, double *out) {
    for (int c = 0; c < n; c++) out[c] = gl_value(a, i, c);
}

/* The sampler's value at G->anim_t: n (3 or 4) numbers into out. */
static void gl_sample(const struct gl *G, const struct gl_sampler *sm, int n, bool rot,
                      double *out) {
    uint32_t keys = sm->in.count, per = sm->how == 2 ? 3 : 1, mid = sm->how == 2 ? 1 : 0;
    double t = G->anim_t;
    if (keys == 1 || t <= gl_value(&sm->in, 0, 0)) {
        gl_elem(&sm->out, mid, n, out);
        return;
    }
    if (t >= gl_value(&sm->in, keys - 1, 0)) {
        gl_elem(&sm->out, (keys - 1) * per + mid, n, out);
        return;
    }
    uint32_t lo = 0, hi = keys - 1; /* in[lo] <= t < in[hi] */
    while (hi - lo > 1) {
        uint32_t m = lo + (hi - lo) / 2;
        if (gl_value(&sm->in, m, 0) <= t)
            lo = m;
        else
            hi = m;
    }
    double t0 = gl_value(&sm->in, lo, 0), t1 = gl_value(&sm->in, hi, 0);
    double u = (t - t0) / (t1 - t0), a[4], b[4];
    gl_elem(&sm->out, lo * per + mid, n, a);
    if (sm->how == 1) {
        memcpy(out, a, sizeof *out * (size_t)n);
        return;
    }
    gl_elem(&sm->out, hi * per + mid, n, b);
    if (sm->how == 2) {
        double ma[4], mb[4], d = t1 - t0;
        gl_elem(&sm->out, lo * per + 2, n, ma); /* lo's out-tangent */
        gl_elem(&sm->out, hi * per, n, mb);     /* hi's in-tangent */
        for (int c = 0; c < n; c++) ma[c] *= d, mb[c] *= d;
        kf_hermite(a, ma, b, mb, n, u, out);
    } else if (rot) {
        kf_slerp(a, b, u, out);
    } else {
        for (int c = 0; c < n; c++) out[c] = (1 - u) * a[c] + u * b[c];
    }
    if (rot) {
        double l = sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3]);
        for (int c = 0; c < 4 && l > 0; c++) out[c] /= l;
    }
}

/* samplers[i] of the animation at pa: its accessors, checked. */
static enum rayd_status gl_sampler_read(struct gl *G, const cJSON *anim, const struct jp *pa, int i,
                                        int n, struct gl_sampler *sm) {
    static const char *const hows[] = {"LINEAR", "STEP", "CUBICSPLINE"};
    const cJSON *list = gl_get(anim, "samplers");
    struct jp pl = jp_key(pa, "samplers"), ps = jp_index(&pl, i);
    const cJSON *sj = cJSON_IsArray(list) ? cJSON_GetArrayItem(list, i) : NULL;
    if (!cJSON_IsObject(sj)) return gl_fail(G, RAYD_E_INVALID, &ps, "must be a sampler object");
    const cJSON *how = gl_get(sj, "interpolation");
    struct jp ph = jp_key(&ps, "interpolation");
    sm->how = 0;
    if (how) {
        sm->how = -1;
        for (int k = 0; k < 3 && cJSON_IsString(how); k++)
            if (!strcmp(how->valuestring, hows[k])) sm->how = k;
        if (sm->how < 0)
            return gl_fail(G, RAYD_E_INVALID, &ph, "must be LINEAR, STEP or CUBICSPLINE");
    }
    TRY_GL(gl_accessor(G, sj, &ps, "input", 1, false, &sm->in));
    TRY_GL(gl_accessor(G, sj, &ps, "output", n, false, &sm->out));
    struct jp pin = gl_item("accessors", sm->in.id), pout = gl_item("accessors", sm->out.id);
    struct jp pic = jp_key(&pin, "componentType"), poc = jp_key(&pout, "count");
    if (sm->in.ctype != 5126 || !sm->in.p)
        return gl_fail(G, RAYD_E_INVALID, &pic,
                       "an animation's times must be FLOAT (5126) in a bufferView");
    uint64_t want = (uint64_t)sm->in.count * (sm->how == 2 ? 3 : 1);
    if (sm->out.count != want)
        return gl_fail(G, RAYD_E_INVALID, &poc, "must be %llu: the sampler's %u times%s",
                       (unsigned long long)want, sm->in.count,
                       sm->how == 2 ? " x 3 (in-tangent, value, out-tangent)" : "");
    for (uint32_t k = 0; k < sm->in.count; k++) {
        double v = gl_value(&sm->in, k, 0);
        if (!isfinite(v) || (k > 0 && !(v > gl_value(&sm->in, k - 1, 0))))
            return gl_fail(G, RAYD_E_INVALID, &pin,
                           "time %u is %g: times must be finite and increase", k, v);
    }
    for (uint32_t k = 0; k < sm->out.count; k++)
        for (int c = 0; c < n; c++)
            if (!isfinite(gl_value(&sm->out, k, c)) || fabs(gl_value(&sm->out, k, c)) > 1e30)
                return gl_fail(G, RAYD_E_INVALID, &pout, "value %u is not a finite number", k);
    return RAYD_OK;
}

/* Channel i of the animation at pa into G->pose. */
static enum rayd_status gl_channel(struct gl *G, const cJSON *anim, const struct jp *pa,
                                   const cJSON *ch, int i) {
    struct jp pl = jp_key(pa, "channels"), pc = jp_index(&pl, i), pt = jp_key(&pc, "target");
    struct jp pp = jp_key(&pt, "path");
    if (!cJSON_IsObject(ch)) return gl_fail(G, RAYD_E_INVALID, &pc, "must be a channel object");
    const cJSON *tg = gl_get(ch, "target"), *path = gl_get(tg, "path");
    if (!cJSON_IsObject(tg)) return gl_fail(G, RAYD_E_INVALID, &pt, "is required (an object)");
    if (!cJSON_IsString(path)) return gl_fail(G, RAYD_E_INVALID, &pp, "is required (a string)");
    int kind = !strcmp(path->valuestring, "translation") ? 0
               : !strcmp(path->valuestring, "rotation")  ? 1
               : !strcmp(path->valuestring, "scale")     ? 2
                                                         : -1;
    if (kind < 0 || !gl_get(tg, "node")) return RAYD_OK; /* weights, or an extension's target */
    double node, smp;
    TRY_GL(gl_int(G, tg, &pt, "node", -1, 0, G->nnodes - 1, &node));
    TRY_GL(gl_int(G, ch, &pc, "sampler", -1, 0, 2147483647.0, &smp));
    const cJSON *list = gl_get(anim, "samplers");
    struct jp psm = jp_key(&pc, "sampler");
    if (!cJSON_IsArray(list) || smp >= cJSON_GetArraySize(list))
        return gl_fail(G, RAYD_E_INVALID, &psm,
                       "%.0f is not an index into the animation's samplers", smp);
    struct gl_sampler sm;
    int n = kind == 1 ? 4 : 3;
    TRY_GL(gl_sampler_read(G, anim, pa, (int)smp, n, &sm));
    struct gl_pose *po = &G->pose[(int)node];
    double v[4];
    gl_sample(G, &sm, n, kind == 1, v);
    if (kind == 0) po->has_t = true, memcpy(po->t, v, sizeof po->t);
    if (kind == 1) po->has_r = true, memcpy(po->r, v, sizeof po->r);
    if (kind == 2) po->has_s = true, memcpy(po->s, v, sizeof po->s);
    return RAYD_OK;
}

static enum rayd_status gl_animate(struct gl *G) {
    const cJSON *anims = gl_get(G->root, "animations");
    struct jp pa = gl_item("animations", G->anim_id), top = {.s = "/animations"};
    const cJSON *anim = cJSON_IsArray(anims) ? cJSON_GetArrayItem(anims, G->anim_id) : NULL;
    if (!cJSON_IsObject(anim))
        return gl_fail(G, RAYD_E_INVALID, cJSON_IsArray(anims) ? &pa : &top,
                       "must be an animation object");
    G->pose = calloc((size_t)G->nnodes + 1, sizeof *G->pose);
    if (!G->pose) return gl_fail(G, RAYD_E_NOMEM, &pa, "out of memory");
    const cJSON *chs = gl_get(anim, "channels");
    struct jp pc = jp_key(&pa, "channels");
    if (!cJSON_IsArray(chs)) return gl_fail(G, RAYD_E_INVALID, &pc, "is required (an array)");
    int i = 0;
    for (const cJSON *ch = chs->child; ch; ch = ch->next, i++)
        TRY_GL(gl_channel(G, anim, &pa, ch, i));
    return RAYD_OK;
}

void gltf_doc_animate(struct gltf_doc *d, int animation, double seconds) {
    d->G.anim_id = animation;
    d->G.anim_t = seconds;
    d->G.animate = gl_animate;
}
