/* exr.c -- linear float RGB out as OpenEXR, through OpenEXR's C library.
 *
 * With exr_read.c (environment maps in), the only file that includes
 * OpenEXR.  Compositing wants the radiance itself, linear and unclamped,
 * which an 8-bit sRGB PNG cannot carry; EXR
 * is what every compositor reads.  The writer is OpenEXRCore (OpenEXR 3's
 * C API, Debian's libopenexr-dev), not a hand-made one: the format has
 * enough corners (offset tables, compressor framing) that a library its
 * readers are tested against is the safer author.
 *
 * AOVs (render/aov.c) go in the same part as more float channels, under
 * the names compositors look for: albedo.R/G/B, N.X/Y/Z, Z, A, objectId,
 * materialId (a file without them is byte for byte as before).
 *
 * Choices: one scanline part of three 32-bit float channels R, G, B (half
 * floats would round the radiance to 11 bits; float keeps what the render
 * computed, to the float rounding of the average); PIZ compression
 * (wavelet + Huffman, 32 rows a chunk) where it pays, else none.  PIZ is
 * lossless, and faster and smaller than ZIP on a Whitted frame (a fifth to
 * half of the raw floats on scenes/, bench/README.md, "Design records"),
 * whose flat regions repeat the very same floats.  A path-traced image's
 * float mantissas are noise to their last bits: there PIZ saved 0-10% of
 * the bytes in 4-9 times the time of none (128 x 128: 9 ms against 2.3
 * warm, 17 against 4 in a fresh process, half of rayd-render's work at 4
 * samples; 256 x 256: 46 against 5).  Repeats are what tells the two
 * apart: 10-45% of the floats repeat their left neighbour's on the
 * Whitted examples but csg.json (2%: its surfaces are all curved, and PIZ
 * saved it a fifth), 0-1% on the path-traced ones; so an image gets PIZ
 * when one float in 20 does (exr_piz_pays, one pass over the floats), and
 * the same image still gets the same bytes.  Written to memory through
 * the library's write callback, so the server can send it and cache it
 * like a PNG.  The library writes the chunk offset table last, at an
 * earlier offset, so the buffer takes writes at any offset.
 */
#include <openexr.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"
#include "codec/exr_chans.h"
#include "rayd/rayd.h"

struct exr_mem {
    unsigned char *buf;
    size_t len, cap;
    int failed;
    char message[200]; /* the library's last error, if any */
};

static int64_t mem_write(exr_const_context_t ctx, void *user, const void *data, uint64_t sz,
                         uint64_t offset, exr_stream_error_func_ptr_t error_cb) {
    (void)ctx;
    (void)error_cb;
    struct exr_mem *m = user;
    size_t end = (size_t)offset + (size_t)sz;
    if (end > m->cap) {
        size_t cap = m->cap ? m->cap : 65536;
        while (cap < end) cap *= 2;
        unsigned char *p = realloc(m->buf, cap);
        if (!p) {
            m->failed = 1;
            return -1;
        }
        m->buf = p;
        m->cap = cap;
    }
    memcpy(m->buf + offset, data, (size_t)sz);
    if (end > m->len) m->len = end;
    return (int64_t)sz;
}

/* The library reports errors here instead of printing them: the core
 * never prints. */
static void on_error(exr_const_context_t ctx, exr_result_t code, const char *msg) {
    void *user = NULL;
    if (exr_get_user_data(ctx, &user) != EXR_ERR_SUCCESS || !user) return;
    struct exr_mem *m = user;
    snprintf(m->message, sizeof m->message, "%s: %s", exr_get_error_code_as_string(code),
             msg ? msg : "");
}

static enum rayd_status exr_fail(struct exr_mem *m, exr_result_t rv, struct rayd_error *err) {
    if (m->failed) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory for the EXR file");
    return err_set(err, RAYD_E_INTERNAL, NULL, "OpenEXR: %s",
                   m->message[0] ? m->message : exr_get_default_error_message(rv));
}

/* Every channel the file may have, named as compositors expect (Nuke's
 * and Blender's layer.channel, Z and A bare): the table exr_chans.h
 * shares with the reader. */
const struct exr_chan exr_chans[] = {
    {"R", 0, 0},
    {"G", 0, 1},
    {"B", 0, 2},
    {"albedo.R", RAYD_AOV_ALBEDO, 0},
    {"albedo.G", RAYD_AOV_ALBEDO, 1},
    {"albedo.B", RAYD_AOV_ALBEDO, 2},
    {"N.X", RAYD_AOV_NORMAL, 3},
    {"N.Y", RAYD_AOV_NORMAL, 4},
    {"N.Z", RAYD_AOV_NORMAL, 5},
    {"Z", RAYD_AOV_DEPTH, 6},
    {"A", RAYD_AOV_ALPHA, 7},
    {"objectId", RAYD_AOV_OBJECT, 8},
    {"materialId", RAYD_AOV_MATERIAL, 9},
};
const size_t exr_nchans = sizeof exr_chans / sizeof exr_chans[0];

/* The header: one scanline part, w x h, channels R, G, B and the AOVs of
 * mask as float, compressed how. */
static exr_result_t exr_header(exr_context_t ctx, int w, int h, unsigned mask,
                               exr_compression_t how) {
    int part = 0;
    exr_result_t rv = exr_add_part(ctx, "rgb", EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS) rv = exr_initialize_required_attr_simple(ctx, part, w, h, how);
    for (size_t c = 0; c < exr_nchans && rv == EXR_ERR_SUCCESS; c++) {
        if (exr_chans[c].aov && !(exr_chans[c].aov & mask)) continue;
        bool colour = exr_chans[c].aov <= RAYD_AOV_ALBEDO;
        rv = exr_add_channel(ctx, part, exr_chans[c].name, EXR_PIXEL_FLOAT,
                             colour ? EXR_PERCEPTUALLY_LOGARITHMIC : EXR_PERCEPTUALLY_LINEAR, 1, 1);
    }
    if (rv == EXR_ERR_SUCCESS) rv = exr_write_header(ctx);
    return rv;
}

/* The pixels a file's channels come from. */
struct exr_src {
    const float *rgb, *aov; /* aov: RAYD_AOV_FLOATS a pixel, or NULL */
    int w;
};

/* Points the pipeline's channels at the rows of src from row y0. */
static void exr_point(exr_encode_pipeline_t *enc, const struct exr_src *src, int y0) {
    for (int c = 0; c < enc->channel_count; c++) {
        exr_coding_channel_info_t *ch = &enc->channels[c];
        const struct exr_chan *k = &exr_chans[0];
        for (size_t i = 0; i < exr_nchans; i++)
            if (!strcmp(exr_chans[i].name, ch->channel_name)) k = &exr_chans[i];
        int stride = k->aov ? RAYD_AOV_FLOATS : 3;
        const float *base = k->aov ? src->aov : src->rgb;
        ch->encode_from_ptr =
            (const uint8_t *)(base + (size_t)y0 * (size_t)src->w * (size_t)stride + k->at);
        ch->user_pixel_stride = stride * (int32_t)sizeof(float);
        ch->user_line_stride = src->w * stride * (int32_t)sizeof(float);
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_bytes_per_element = (int16_t)sizeof(float);
    }
}

/* Encodes and writes every chunk of rows, in order. */
static exr_result_t exr_rows(exr_context_t ctx, const struct exr_src *src, int h) {
    int32_t lines = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int started = 0;
    for (int y = 0; rv == EXR_ERR_SUCCESS && y < h; y += lines) {
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(ctx, 0, y, &cinfo);
        if (rv != EXR_ERR_SUCCESS) break;
        rv = started ? exr_encoding_update(ctx, 0, &cinfo, &enc)
                     : exr_encoding_initialize(ctx, 0, &cinfo, &enc);
        if (rv != EXR_ERR_SUCCESS) break;
        exr_point(&enc, src, y);
        if (!started++) rv = exr_encoding_choose_default_routines(ctx, 0, &enc);
        if (rv == EXR_ERR_SUCCESS) rv = exr_encoding_run(ctx, 0, &enc);
    }
    exr_encoding_destroy(ctx, &enc); /* safe on the initializer's zeros */
    return rv;
}

enum rayd_status rayd_exr_encode(const float *rgb, int w, int h, void **buf, size_t *len,
                                 struct rayd_error *err) {
    return rayd_exr_encode_aov(rgb, NULL, 0, w, h, buf, len, err);
}

/* The file of src's w x h pixels with mask's AOVs, compressed how, into
 * m (m->buf malloc'd even on failure: the caller frees it). */
static exr_result_t exr_write(const struct exr_src *src, int w, int h, unsigned mask,
                              exr_compression_t how, struct exr_mem *m) {
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.user_data = m;
    init.write_fn = mem_write;
    init.error_handler_fn = on_error;
    exr_context_t ctx = NULL;
    exr_result_t rv = exr_start_write(&ctx, "memory", EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv == EXR_ERR_SUCCESS) rv = exr_header(ctx, w, h, mask, how);
    if (rv == EXR_ERR_SUCCESS) rv = exr_rows(ctx, src, h);
    exr_result_t fin = ctx ? exr_finish(&ctx) : EXR_ERR_SUCCESS;
    return rv == EXR_ERR_SUCCESS ? fin : rv;
}

/* Floats of channel k that repeat the one a pixel to their left, in
 * *repeats, of the *pairs compared (bits compared: NaNs count). */
static void exr_repeats(const struct exr_src *src, int h, const struct exr_chan *k, size_t *repeats,
                        size_t *pairs) {
    size_t stride = k->aov ? RAYD_AOV_FLOATS : 3;
    const float *base = (k->aov ? src->aov : src->rgb) + k->at;
    for (int y = 0; y < h; y++) {
        const float *row = base + (size_t)y * (size_t)src->w * stride;
        for (int x = 1; x < src->w; x++) {
            uint32_t a, b;
            memcpy(&a, &row[(size_t)(x - 1) * stride], sizeof a);
            memcpy(&b, &row[(size_t)x * stride], sizeof b);
            *repeats += a == b;
        }
        *pairs += (size_t)src->w - 1;
    }
}

/* Whether PIZ earns its time (the file comment): one float in 20 or more
 * repeats its left neighbour's, over the channels the file has. */
static bool exr_piz_pays(const struct exr_src *src, int h, unsigned mask) {
    size_t repeats = 0, pairs = 0;
    for (size_t c = 0; c < exr_nchans; c++)
        if (!exr_chans[c].aov || (exr_chans[c].aov & mask))
            exr_repeats(src, h, &exr_chans[c], &repeats, &pairs);
    return pairs > 0 && repeats * 20 >= pairs;
}

enum rayd_status rayd_exr_encode_aov(const float *rgb, const float *aov, unsigned mask, int w,
                                     int h, void **buf, size_t *len, struct rayd_error *err) {
    if (w <= 0 || h <= 0) return err_set(err, RAYD_E_ARG, NULL, "an EXR needs w, h > 0");
    if (mask && !aov) return err_set(err, RAYD_E_ARG, NULL, "AOV channels without AOVs");
    mask &= RAYD_AOV_ALL;
    struct exr_src src = {rgb, aov, w};
    struct exr_mem m = {0};
    exr_result_t rv =
        exr_write(&src, w, h, mask,
                  exr_piz_pays(&src, h, mask) ? EXR_COMPRESSION_PIZ : EXR_COMPRESSION_NONE, &m);
    if (rv != EXR_ERR_SUCCESS || m.failed) {
        free(m.buf);
        return exr_fail(&m, rv, err);
    }
    *buf = m.buf;
    *len = m.len;
    return RAYD_OK;
}
