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
 * Choices: one scanline part of three 32-bit float channels R, G, B (half
 * floats would round the radiance to 11 bits; float keeps what the render
 * computed, to the float rounding of the average); PIZ compression
 * (wavelet + Huffman, 32 rows a chunk), lossless and deterministic, so the
 * same image gives the same bytes, and both faster and smaller than ZIP on
 * rendered frames (bench/README.md, "Design records"); written to memory
 * through the library's write callback, so the server can send it and cache
 * it like a PNG.  The library writes the chunk offset table last, at an
 * earlier offset, so the buffer takes writes at any offset.
 */
#include <openexr.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"
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

/* The header: one scanline part, w x h, channels R, G, B as float. */
static exr_result_t exr_header(exr_context_t ctx, int w, int h) {
    int part = 0;
    exr_result_t rv = exr_add_part(ctx, "rgb", EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctx, part, w, h, EXR_COMPRESSION_PIZ);
    static const char *const names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3 && rv == EXR_ERR_SUCCESS; c++)
        rv = exr_add_channel(ctx, part, names[c], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1,
                             1);
    if (rv == EXR_ERR_SUCCESS) rv = exr_write_header(ctx);
    return rv;
}

/* Points the pipeline's channels at the rows of rgb from row y0. */
static void exr_point(exr_encode_pipeline_t *enc, const float *rgb, int w, int y0) {
    for (int c = 0; c < enc->channel_count; c++) {
        exr_coding_channel_info_t *ch = &enc->channels[c];
        int k = ch->channel_name[0] == 'R' ? 0 : ch->channel_name[0] == 'G' ? 1 : 2;
        ch->encode_from_ptr = (const uint8_t *)(rgb + (size_t)y0 * (size_t)w * 3 + k);
        ch->user_pixel_stride = 3 * (int32_t)sizeof(float);
        ch->user_line_stride = w * 3 * (int32_t)sizeof(float);
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_bytes_per_element = (int16_t)sizeof(float);
    }
}

/* Encodes and writes every chunk of rows, in order. */
static exr_result_t exr_rows(exr_context_t ctx, const float *rgb, int w, int h) {
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
        exr_point(&enc, rgb, w, y);
        if (!started++) rv = exr_encoding_choose_default_routines(ctx, 0, &enc);
        if (rv == EXR_ERR_SUCCESS) rv = exr_encoding_run(ctx, 0, &enc);
    }
    exr_encoding_destroy(ctx, &enc); /* safe on the initializer's zeros */
    return rv;
}

enum rayd_status rayd_exr_encode(const float *rgb, int w, int h, void **buf, size_t *len,
                                 struct rayd_error *err) {
    if (w <= 0 || h <= 0) return err_set(err, RAYD_E_ARG, NULL, "an EXR needs w, h > 0");
    struct exr_mem m = {0};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.user_data = &m;
    init.write_fn = mem_write;
    init.error_handler_fn = on_error;
    exr_context_t ctx = NULL;
    exr_result_t rv = exr_start_write(&ctx, "memory", EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv == EXR_ERR_SUCCESS) rv = exr_header(ctx, w, h);
    if (rv == EXR_ERR_SUCCESS) rv = exr_rows(ctx, rgb, w, h);
    exr_result_t fin = ctx ? exr_finish(&ctx) : EXR_ERR_SUCCESS;
    if (rv == EXR_ERR_SUCCESS) rv = fin;
    if (rv != EXR_ERR_SUCCESS || m.failed) {
        free(m.buf);
        return exr_fail(&m, rv, err);
    }
    *buf = m.buf;
    *len = m.len;
    return RAYD_OK;
}
