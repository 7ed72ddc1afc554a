/* exr_read.c -- OpenEXR in: environment maps as linear float RGB.
 *
 * The other file (with exr.c) that includes OpenEXR, for the same reason:
 * OpenEXRCore, the format's own C library, already linked for the output,
 * knows the compressors and their corners.  The file is read from memory
 * (the scene loader has the bytes) through the library's read callback.
 * Only what an environment needs is taken: the first part, channels R, G
 * and B at full resolution, half or float, converted to float by the
 * library; the data window is the image.  The size is checked against the
 * limit from the header, before any pixel memory is taken.
 *
 * Scanline files in every compression but DWA are decoded here.  DWAA and
 * DWAB files (Blender's and Nuke's default for maps) and tiled ones go to
 * exr_imf.cc, the C++ library of the same release, which OpenEXR 3.1's C
 * library cannot stand in for there; the checks above run first all the
 * same.  Deep files are refused, naming what they are.
 */
#include <openexr.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/bytes.h"
#include "codec/exr_chans.h"
#include "codec/exr_imf.h"
#include "codec/exr_read.h"
#include "rayd/rayd.h"

struct exr_src {
    const unsigned char *p;
    size_t len;
    char message[200]; /* the library's last error, if any */
};

static int64_t src_read(exr_const_context_t ctx, void *user, void *buf, uint64_t sz,
                        uint64_t offset, exr_stream_error_func_ptr_t error_cb) {
    (void)ctx;
    (void)error_cb;
    const struct exr_src *s = user;
    if (offset >= s->len) return 0;
    size_t n = s->len - (size_t)offset < sz ? s->len - (size_t)offset : (size_t)sz;
    memcpy(buf, s->p + offset, n);
    return (int64_t)n;
}

static int64_t src_size(exr_const_context_t ctx, void *user) {
    (void)ctx;
    return (int64_t)((const struct exr_src *)user)->len;
}

/* The library reports errors here; the core never prints. */
static void src_error(exr_const_context_t ctx, exr_result_t code, const char *msg) {
    void *user = NULL;
    if (exr_get_user_data(ctx, &user) != EXR_ERR_SUCCESS || !user) return;
    struct exr_src *s = user;
    snprintf(s->message, sizeof s->message, "%s: %s", exr_get_error_code_as_string(code),
             msg ? msg : "");
}

/* The index 0-2 of an R, G or B channel name, or -1. */
static int rgb_index(const char *name) {
    return strcmp(name, "R") == 0   ? 0
           : strcmp(name, "G") == 0 ? 1
           : strcmp(name, "B") == 0 ? 2
                                    : -1;
}

/* Why the part cannot be read as RGB scanlines, or NULL when it can. */
static const char *unsupported(exr_context_t ctx) {
    exr_storage_t st;
    if (exr_get_storage(ctx, 0, &st) != EXR_ERR_SUCCESS ||
        (st != EXR_STORAGE_SCANLINE && st != EXR_STORAGE_TILED))
        return "is a deep OpenEXR file (samples per pixel, for compositing); an environment map "
               "must be a flat image: scanlines or tiles";
    const exr_attr_chlist_t *ch = NULL;
    if (exr_get_channels(ctx, 0, &ch) != EXR_ERR_SUCCESS || !ch) return "has no channel list";
    int seen = 0;
    for (int i = 0; i < ch->num_channels; i++) {
        int k = rgb_index(ch->entries[i].name.str);
        if (k < 0) continue;
        if (ch->entries[i].x_sampling != 1 || ch->entries[i].y_sampling != 1)
            return "has subsampled R, G or B channels; only full-resolution ones are read";
        seen |= 1 << k;
    }
    return seen == 7 ? NULL : "needs the channels R, G and B";
}

/* Whether the pixels go through exr_imf.cc: tiled storage, or a DWA
 * compression, which OpenEXR 3.1's C library cannot decompress. */
static int through_imf(exr_context_t ctx) {
    exr_storage_t st = EXR_STORAGE_SCANLINE;
    exr_compression_t comp = EXR_COMPRESSION_NONE;
    exr_get_storage(ctx, 0, &st);
    exr_get_compression(ctx, 0, &comp);
    return st == EXR_STORAGE_TILED || comp == EXR_COMPRESSION_DWAA || comp == EXR_COMPRESSION_DWAB;
}

/* The memory one chunk of the part takes to decode, width pixels wide:
 * both libraries unpack every channel of a chunk (the C++ one a whole
 * row of tiles), so a header of a few hundred bytes can ask for
 * gigabytes with tiles millions of pixels tall or thousands of channels.
 * In double: the header's numbers may overflow any integer.  *what says
 * what the chunk is. */
static double chunk_bytes(exr_context_t ctx, long width, char *what, size_t what_len) {
    const exr_attr_chlist_t *ch = NULL;
    double px = 0; /* bytes a pixel, all channels */
    int nch = 0;
    if (exr_get_channels(ctx, 0, &ch) == EXR_ERR_SUCCESS && ch) nch = ch->num_channels;
    for (int i = 0; i < nch; i++) px += ch->entries[i].pixel_type == EXR_PIXEL_HALF ? 2 : 4;
    exr_storage_t st = EXR_STORAGE_SCANLINE;
    exr_get_storage(ctx, 0, &st);
    uint32_t tx = 0, ty = 0;
    int32_t lines = 0;
    if (st == EXR_STORAGE_TILED) {
        exr_tile_level_mode_t level;
        exr_tile_round_mode_t round;
        exr_get_tile_descriptor(ctx, 0, &tx, &ty, &level, &round);
        snprintf(what, what_len, "tiles of %u x %u pixels, %d channels", tx, ty, nch);
    } else {
        exr_get_scanlines_per_chunk(ctx, 0, &lines);
        snprintf(what, what_len, "%d lines a chunk, %d channels", lines, nch);
    }
    double rows = st == EXR_STORAGE_TILED ? (double)ty : lines > 0 ? (double)lines : 1;
    double row = px * (double)width * rows, tile = px * tx * (double)ty;
    return row > tile ? row : tile;
}

static bool header_cut(struct exr_src *src) {
    snprintf(src->message, sizeof src->message, "its header is cut short");
    return false;
}

/* Whether every attribute of every header in src fits in the file, else
 * why not in src->message.  The C++ library sizes an attribute's value
 * from the size the file claims before reading it: 465 bytes of a file
 * (found by fuzz_envmap) made it ask for 1.9 GB for one string.  The
 * layout: magic and version (flags 0x1000: several parts), then per part
 * attributes of a name, a type name (both ending in a 0 byte), an int32
 * size and the value, the part's list ending in an empty name; several
 * parts end in an empty header. */
static bool headers_fit(struct exr_src *src) {
    const unsigned char *p = src->p;
    size_t len = src->len, at = 8;
    bool multipart = len >= 8 && (bytes_le32(p + 4) & 0x1000) != 0;
    for (int part = 0;; part++) {
        if (part > 0 && at < len && p[at] == 0) return true; /* the empty header: the end */
        for (;;) {
            size_t name = at, n = at < len ? strnlen((const char *)p + at, len - at) : 0;
            if (at >= len || n == len - at) return header_cut(src);
            at += n + 1;
            if (n == 0) break; /* the part's list ends */
            size_t type = at < len ? strnlen((const char *)p + at, len - at) : 0;
            if (at >= len || type == len - at || len - at - type - 1 < 4) return header_cut(src);
            at += type + 1;
            int32_t size = (int32_t)bytes_le32(p + at);
            at += 4;
            if (size < 0 || (size_t)size > len - at) {
                snprintf(src->message, sizeof src->message,
                         "its header's attribute \"%.40s\" claims %ld bytes; %zu are left in "
                         "the file",
                         (const char *)p + name, (long)size, len - at);
                return false;
            }
            at += (size_t)size;
        }
        if (!multipart) return true;
    }
}

/* The pixels through the C++ library; EXR_ERR_CORRUPT_CHUNK (message in
 * src) when it fails. */
static exr_result_t read_imf(struct exr_src *src, float *rgb, int w, int h) {
    if (!headers_fit(src)) return EXR_ERR_CORRUPT_CHUNK;
    char why[sizeof src->message - 40];
    if (exr_imf_read_rgb(src->p, src->len, rgb, w, h, why, sizeof why) == 0) return EXR_ERR_SUCCESS;
    snprintf(src->message, sizeof src->message, "OpenEXR's C++ library: %s", why);
    return EXR_ERR_CORRUPT_CHUNK;
}

/* Where decoded channels go: RGB (3 floats a pixel) and, when aov is not
 * NULL, the AOVs (RAYD_AOV_FLOATS a pixel), both w wide. */
struct exr_dst {
    float *rgb, *aov;
    int w;
};

/* The table entry of a channel name, or NULL. */
static const struct exr_chan *chan_find(const char *name) {
    for (size_t i = 0; i < exr_nchans; i++)
        if (!strcmp(exr_chans[i].name, name)) return &exr_chans[i];
    return NULL;
}

/* Points a decoder channel at row `row` of dst (NULL: skipped). */
static void chan_point(exr_coding_channel_info_t *ch, const struct exr_dst *dst, size_t row) {
    const struct exr_chan *k = chan_find(ch->channel_name);
    int stride = k && k->aov ? RAYD_AOV_FLOATS : 3;
    float *base = !k ? NULL : k->aov ? dst->aov : dst->rgb;
    ch->decode_to_ptr =
        base ? (uint8_t *)(base + row * (size_t)dst->w * (size_t)stride + k->at) : NULL;
    ch->user_pixel_stride = stride * (int32_t)sizeof(float);
    ch->user_line_stride = dst->w * stride * (int32_t)sizeof(float);
    ch->user_data_type = EXR_PIXEL_FLOAT;
    ch->user_bytes_per_element = (int16_t)sizeof(float);
}

/* Decodes every chunk of rows into dst (from data window row y0). */
static exr_result_t read_rows(exr_context_t ctx, const struct exr_dst *dst, int y0, int y1) {
    int32_t lines = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int started = 0;
    for (int y = y0; rv == EXR_ERR_SUCCESS && y <= y1; y += lines) {
        exr_chunk_info_t ci;
        rv = exr_read_scanline_chunk_info(ctx, 0, y, &ci);
        if (rv != EXR_ERR_SUCCESS) break;
        rv = started ? exr_decoding_update(ctx, 0, &ci, &dec)
                     : exr_decoding_initialize(ctx, 0, &ci, &dec);
        if (rv != EXR_ERR_SUCCESS) break;
        for (int c = 0; c < dec.channel_count; c++)
            chan_point(&dec.channels[c], dst, (size_t)(ci.start_y - y0));
        if (!started++) rv = exr_decoding_choose_default_routines(ctx, 0, &dec);
        if (rv == EXR_ERR_SUCCESS) rv = exr_decoding_run(ctx, 0, &dec);
    }
    exr_decoding_destroy(ctx, &dec);
    return rv;
}

/* Opens the EXR in src (which must outlive *ctx) and reads its data window
 * into *dw; on success *ctx is open for the caller to finish. */
static enum rayd_status exr_open(struct exr_src *src, exr_context_t *ctx, exr_attr_box2i_t *dw,
                                 struct rayd_error *err) {
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.user_data = src;
    init.read_fn = src_read;
    init.size_fn = src_size;
    init.error_handler_fn = src_error;
    *ctx = NULL;
    if (src->len < 4 || memcmp(src->p, "\x76\x2f\x31\x01", 4) != 0)
        return err_set(err, RAYD_E_INVALID, NULL,
                       "is not an OpenEXR image (no OpenEXR magic number)");
    exr_result_t rv = exr_start_read(ctx, "memory", &init);
    if (rv == EXR_ERR_SUCCESS) rv = exr_get_data_window(*ctx, 0, dw);
    if (rv == EXR_ERR_SUCCESS) return RAYD_OK;
    if (*ctx) exr_finish(ctx);
    return err_set(err, RAYD_E_INVALID, NULL, "is not a readable OpenEXR image: %s",
                   src->message[0] ? src->message : exr_get_default_error_message(rv));
}

enum rayd_status exr_read_size(const void *buf, size_t len, long *w, long *h, double *scratch,
                               struct rayd_error *err) {
    struct exr_src src = {buf, len, ""};
    exr_context_t ctx;
    exr_attr_box2i_t dw;
    enum rayd_status st = exr_open(&src, &ctx, &dw, err);
    if (st != RAYD_OK) return st;
    *w = (long)dw.max.x - dw.min.x + 1;
    *h = (long)dw.max.y - dw.min.y + 1;
    char what[96];
    /* the decoders hold a chunk unpacked and its decompressed bytes at once */
    if (scratch) *scratch = 2 * chunk_bytes(ctx, *w, what, sizeof what);
    exr_finish(&ctx);
    return RAYD_OK;
}

/* RAYD_E_LIMIT when a chunk of the part takes more memory to decode than
 * the largest image allowed does decoded (3 floats a pixel). */
static enum rayd_status chunk_within(exr_context_t ctx, long width, long max_pixels,
                                     struct rayd_error *err) {
    char what[96];
    double need = chunk_bytes(ctx, width, what, sizeof what), limit = 12.0 * (double)max_pixels;
    if (need <= limit) return RAYD_OK;
    return err_set(err, RAYD_E_LIMIT, NULL,
                   "one chunk of its pixels (%s) takes %.0f MB to decode; the limit is %.0f MB",
                   what, need / 1048576, limit / 1048576);
}

enum rayd_status exr_read_rgb(const void *buf, size_t len, long max_pixels, float **rgb, int *w,
                              int *h, struct rayd_error *err) {
    struct exr_src src = {buf, len, ""};
    exr_context_t ctx;
    exr_attr_box2i_t dw;
    enum rayd_status st = exr_open(&src, &ctx, &dw, err);
    if (st != RAYD_OK) return st;
    const char *why = unsupported(ctx);
    long ww = (long)dw.max.x - dw.min.x + 1, hh = (long)dw.max.y - dw.min.y + 1;
    if (why)
        st = err_set(err, RAYD_E_INVALID, NULL, "%s", why);
    else if (ww <= 0 || hh <= 0)
        st = err_set(err, RAYD_E_INVALID, NULL, "has an empty data window");
    else if (ww > max_pixels / hh)
        st = err_set(err, RAYD_E_LIMIT, NULL,
                     "the image is %ld x %ld pixels; the limit is %ld pixels", ww, hh, max_pixels);
    else
        st = chunk_within(ctx, ww, max_pixels, err);
    float *px = st == RAYD_OK ? calloc((size_t)ww * (size_t)hh * 3, sizeof *px) : NULL;
    if (st == RAYD_OK && !px)
        st = err_set(err, RAYD_E_NOMEM, NULL, "out of memory for an OpenEXR image");
    if (st == RAYD_OK) {
        struct exr_dst dst = {px, NULL, (int)ww};
        exr_result_t rv = through_imf(ctx) ? read_imf(&src, px, (int)ww, (int)hh)
                                           : read_rows(ctx, &dst, dw.min.y, dw.max.y);
        if (rv != EXR_ERR_SUCCESS)
            st = err_set(err, RAYD_E_INVALID, NULL, "cannot decode the OpenEXR image: %s",
                         src.message[0] ? src.message : exr_get_default_error_message(rv));
    }
    exr_finish(&ctx);
    if (st != RAYD_OK) {
        free(px);
        return st;
    }
    *rgb = px;
    *w = (int)ww;
    *h = (int)hh;
    return RAYD_OK;
}

/* Why the open file is not one rayd_exr_encode_aov wrote of w x h pixels
 * with mask's AOVs, or NULL when it is. */
static const char *not_ours(exr_context_t ctx, const exr_attr_box2i_t *dw, unsigned mask, int w,
                            int h) {
    exr_storage_t st;
    const exr_attr_chlist_t *ch = NULL;
    if ((long)dw->max.x - dw->min.x + 1 != w || (long)dw->max.y - dw->min.y + 1 != h)
        return "its size is not the one asked for";
    if (exr_get_storage(ctx, 0, &st) != EXR_ERR_SUCCESS || st != EXR_STORAGE_SCANLINE ||
        through_imf(ctx))
        return "it is not a scanline file in a compression OpenEXRCore decodes";
    if (exr_get_channels(ctx, 0, &ch) != EXR_ERR_SUCCESS || !ch) return "it has no channel list";
    int want = 0;
    for (size_t i = 0; i < exr_nchans; i++) want += !exr_chans[i].aov || (exr_chans[i].aov & mask);
    if (ch->num_channels != want) return "its channels are not the ones asked for";
    for (int i = 0; i < ch->num_channels; i++) {
        const struct exr_chan *k = chan_find(ch->entries[i].name.str);
        if (!k || (k->aov && !(k->aov & mask)) || ch->entries[i].x_sampling != 1 ||
            ch->entries[i].y_sampling != 1)
            return "its channels are not the ones asked for";
    }
    return NULL;
}

enum rayd_status rayd_exr_decode_aov(const void *buf, size_t len, unsigned mask, int w, int h,
                                     float *rgb, float *aov, struct rayd_error *err) {
    if (w <= 0 || h <= 0 || (mask && !aov))
        return err_set(err, RAYD_E_ARG, NULL, "an EXR to decode needs w, h > 0 (and AOVs)");
    struct exr_src src = {buf, len, ""};
    exr_context_t ctx;
    exr_attr_box2i_t dw;
    enum rayd_status st = exr_open(&src, &ctx, &dw, err);
    if (st != RAYD_OK) return st;
    const char *why = not_ours(ctx, &dw, mask & RAYD_AOV_ALL, w, h);
    struct exr_dst dst = {rgb, mask ? aov : NULL, w};
    exr_result_t rv = why ? EXR_ERR_SUCCESS : read_rows(ctx, &dst, dw.min.y, dw.max.y);
    exr_finish(&ctx);
    if (why) return err_set(err, RAYD_E_INVALID, NULL, "is not the EXR expected: %s", why);
    if (rv != EXR_ERR_SUCCESS)
        return err_set(err, RAYD_E_INVALID, NULL, "cannot decode the OpenEXR image: %s",
                       src.message[0] ? src.message : exr_get_default_error_message(rv));
    return RAYD_OK;
}
