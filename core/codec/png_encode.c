/* png_encode.c -- PNG out, deflated in parallel bands.
 *
 * The image is cut into bands of rows; each band is filtered and deflated
 * on its own (libdeflate or ISA-L, raw deflate) by whichever thread takes
 * it, and the bands are joined into one zlib stream: a band that is not the
 * last ends with an empty stored block at a byte boundary and no final
 * block (a sync flush, or libdeflate's whole stream rewritten so by
 * deflate_chain.c), so the deflate streams simply follow one another, and
 * the Adler-32 of the whole is combined from the bands' (adler32_combine).
 * This is how pigz writes one valid stream from parallel pieces.
 *
 * Invariant: the bytes depend on the image alone.  The bands depend on the
 * image width alone (about PNG_BAND_BYTES of raw rows each), never on the
 * thread count; which deflate takes which band depends on the band's index
 * alone; which thread deflates which band changes nothing.  Each band
 * starts with an empty dictionary.
 *
 * Filters: the one of None, Sub, Up and Average whose bytes have the least
 * order-0 entropy (a histogram of every other 4 bytes, counted as each
 * filter computes them, without writing its row); then only the chosen
 * filter's row is written.  The choice is made on every PNG_CHOOSE_EVERY-th
 * row of a band and the rows below take it: a rendered image changes little
 * from row to row.  Paeth is not tried (it made the output larger under
 * this measure).
 *
 * Deflate.  With no level asked for (-1), a blend: libdeflate level 1 for
 * three bands in four, ISA-L (below) for every fourth, bands 3, 7, 11, ...
 * (PNG_ISAL_EVERY); images of fewer than four bands are libdeflate's alone.
 * The blend keeps the encoding under a quarter of the tracing with bytes
 * within +15% of libpng level 6 (bench/README.md, "Design records").
 * libdeflate cannot end a stream without a final block, so each of its
 * bands but the last is walked once more by deflate_chain to clear that bit
 * and append the empty stored block.  Levels 0 and 2-9 are libdeflate's, as
 * asked.  Level 1, the fastest, is Intel ISA-L (isal_deflate,
 * PNG_ISAL_LEVEL, raw deflate with a sync flush or, for the last band, the
 * final block), which matches greedily from one hash candidate: faster,
 * and larger on smooth gradients.  The Adler-32 of a band is ISA-L's,
 * combined across bands with zlib's adler32_combine.
 *
 * Encoding while rendering (rayd_png_stream).  A band needs only its own
 * rows and the one above them, so it can be deflated as soon as those are
 * drawn: the render tells the stream through its rows callback, and the
 * worker that finishes a row of tiles deflates the bands that row
 * completes (only those: it is soon back to tiles) while the others go on
 * drawing.  Only the joining is left for after the render, and
 * rayd_png_stream_finish_to hands the chunks to a sink straight from the
 * bands' buffers, so rayd-render never copies the file whole into fresh
 * memory.
 *
 * Memory.  A page first touched costs a fault, so each worker's memory is
 * one block -- its filtered rows, its deflate output and libdeflate's
 * compressor, put there through libdeflate's allocator hook -- and the
 * deflated bands are kept in a few big blocks until the file is joined,
 * not in an allocation each; for an image of PNG_HUGE_MIN bytes of rows or
 * more these blocks are on 2 MiB huge pages (huge_alloc_pages).  A fresh
 * huge page costs the kernel's zeroing of all of it, so the blocks are
 * packed to fill their pages, and they go back to huge_free_pages, which
 * keeps them warm for the next image.
 *
 * The chunks are those libpng wrote before: IHDR, sRGB, gAMA and cHRM for
 * sRGB, the IDATs (one a band: no copy of the whole stream), IEND.
 */
#include <isa-l.h>
#include <libdeflate.h>
#include <math.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

#include "base/clock.h"
#include "base/error.h"
#include "base/hugemem.h"
#include "format/deflate_chain.h"
#include "render/image.h"

#define PNG_BAND_BYTES (256u * 1024u) /* raw bytes of a band, about */
#define PNG_MAX_THREADS 64
#define PNG_ISAL_LEVEL 2 /* ISA-L's level for --png-level 1 (measured) */
#define PNG_ISAL (-1)    /* the stream's level for ISA-L */
#define PNG_BLEND (-2)   /* ... for the default: libdeflate's 1, ISA-L every PNG_ISAL_EVERY bands */
#define PNG_BLEND_LD 1   /* the blend's libdeflate level (measured) */
#define PNG_ISAL_EVERY 4 /* bands 3, 7, 11, ... of the blend are ISA-L's (measured) */
#define PNG_XLOGX_N 4096 /* counts below this have c log2 c in a table */
#define PNG_HUGE_MIN ((size_t)256 << 10)        /* an image's raw bytes from which: huge pages */
#define PNG_HOLD_BLOCK (((size_t)2 << 20) - 64) /* a block of deflated bands: one huge page */
#define PNG_CHOOSE_EVERY 4 /* rows of a band whose filter is measured: 0, 4, 8, ... */
#define PNG_STR(x) #x
#define PNG_XSTR(x) PNG_STR(x) /* a macro's value as a string: PNG_XSTR(PNG_ISAL_LEVEL) is "2" */

struct png_band {
    int y0, rows;
    unsigned char *out; /* raw deflate of the band's filtered rows */
    size_t len;
    uLong adler; /* of the filtered rows */
    size_t raw;  /* bytes of filtered rows */
    int failed;
    bool done; /* deflated, or failed: its rows are read for good */
};

/* A PNG being encoded: its bands and which of them are taken.  The bands
 * are taken in order, each by the rows call that finds its rows final (or
 * by finish), so a call deflates only what its own rows complete and holds
 * its thread no longer than that. */
struct rayd_png_stream {
    const rayd_image *img;
    int level, nbands, band_rows; /* level PNG_ISAL, PNG_BLEND or libdeflate's */
    struct png_band *bands;
    pthread_mutex_t lock;
    pthread_cond_t idle;       /* signalled when calls drops to 0 */
    int next;                  /* the next band nobody has taken */
    int done_upto;             /* bands [0, done_upto) are done */
    int early;                 /* bands taken before finish */
    int calls;                 /* rows calls deflating now */
    bool finishing;            /* finish has begun: every row is final */
    double band_seconds;       /* spent deflating bands, every thread */
    struct png_scratch *spare; /* workers' buffers, free for the next */
    int nspare;
    struct png_hold *hold; /* where the bands' deflated bytes are kept */
};

/* Spare buffers a stream keeps between calls: enough for rayd-render's
 * two threads; a server stream that many workers fed frees the rest. */
#define PNG_SPARE_MAX 2

/* ---- filtering ---------------------------------------------------------- */

static float png_xlogx[PNG_XLOGX_N];
static pthread_once_t png_xlogx_once = PTHREAD_ONCE_INIT;

/* A buffer of the encoder's: on huge pages for a big image (see Memory, at
 * the top), given back to huge_free_pages, which keeps it warm for the
 * next image. */
struct png_buf {
    unsigned char *p;
    size_t bytes;
    bool huge;
};

/* bytes into b, for an image of raw bytes of filtered rows; b->p NULL
 * when out of memory. */
static void png_buf_new(struct png_buf *b, size_t bytes, size_t raw) {
    b->bytes = bytes;
    b->huge = raw >= PNG_HUGE_MIN;
    b->p = huge_alloc_if(b->huge, bytes);
}

static void png_buf_free(struct png_buf *b) {
    huge_free_if(b->huge, b->p, b->bytes);
    b->p = NULL;
}

/* libdeflate's allocations: its compressor, 668 KB from level 2 on, less at 1 (its
 * hash tables cleared for every band), goes into the room a worker's
 * buffer keeps for it (png_ld_room, set around the call), so that one
 * block holds all a worker's memory; anything else on huge pages.  The
 * size and where it went are kept in front. */
#define PNG_LD_HEAD 64
#define PNG_LD_ROOM ((size_t)704 << 10) /* libdeflate 1.14's level 2-12 compressor, and more */
static _Thread_local unsigned char *png_ld_room;

static void *png_ld_alloc(size_t n) {
    size_t head[2] = {n, png_ld_room && n <= PNG_LD_ROOM - PNG_LD_HEAD};
    unsigned char *p = head[1]                       ? png_ld_room
                       : n <= SIZE_MAX - PNG_LD_HEAD ? huge_alloc_pages(n + PNG_LD_HEAD)
                                                     : NULL;
    png_ld_room = NULL;
    if (!p) return NULL;
    memcpy(p, head, sizeof head);
    return p + PNG_LD_HEAD;
}

static void png_ld_free(void *q) {
    if (!q) return;
    unsigned char *p = (unsigned char *)q - PNG_LD_HEAD;
    size_t head[2];
    memcpy(head, p, sizeof head);
    if (!head[1]) huge_free_pages(p, head[0] + PNG_LD_HEAD); /* else its block's */
}

static void xlogx_init(void) {
    for (int c = 1; c < PNG_XLOGX_N; c++) png_xlogx[c] = (float)(c * log2((double)c));
    libdeflate_set_memory_allocator(png_ld_alloc, png_ld_free); /* rayd's one use of libdeflate */
}

/* The byte that filter f makes of cur[i]: for the first bytes of a row,
 * where the pixel to the left is missing (0). */
static unsigned char filter_byte(int f, const unsigned char *cur, const unsigned char *prev,
                                 size_t i) {
    unsigned a = i >= 3 ? cur[i - 3] : 0, b = prev[i];
    return (unsigned char)(f == 0   ? cur[i]
                           : f == 1 ? cur[i] - a
                           : f == 2 ? cur[i] - b
                                    : cur[i] - ((a + b) >> 1));
}

/* The four filters at byte j >= 3 of the row cur over the row prev (names
 * the callers use), for the loops below: one loop a filter, which the
 * compiler can vectorise (the filters read only unfiltered bytes, so no
 * loop carries a dependency). */
#define FILTER_NONE(j) cur[j]
#define FILTER_SUB(j) (cur[j] - cur[(j)-3])
#define FILTER_UP(j) (cur[j] - prev[j])
#define FILTER_AVG(j) (cur[j] - ((cur[(j)-3] + prev[j]) >> 1))

/* The row filtered with f into out (the filter type byte, then n bytes). */
static void filter_row(int f, const unsigned char *cur, const unsigned char *prev, size_t n,
                       unsigned char *out) {
    unsigned char *o = out + 1;
    out[0] = (unsigned char)f;
    size_t i = 0;
    for (; i < n && i < 3; i++) o[i] = filter_byte(f, cur, prev, i);
#define FILL(v)                                                                                    \
    for (; i < n; i++) o[i] = (unsigned char)(v(i))
    switch (f) {
    case 0: memcpy(o + i, cur + i, n - i); break;
    case 1: FILL(FILTER_SUB); break;
    case 2: FILL(FILTER_UP); break;
    default: FILL(FILTER_AVG); break;
    }
#undef FILL
}

/* Sum of c log2 c over the byte counts c of the row filtered with f: the
 * larger, the smaller the order-0 entropy of the row (m log2 m minus this,
 * m bytes counted, the same m for every filter).  The filtered bytes are
 * counted as they are computed, never written: writing each filter's row
 * and reading it back took 37% more time for the same counts.  Only the
 * first 4 of every 8 bytes are counted (the same sizes as counting all,
 * 16% less time; 4 of every 12 or 16 made up to 1.1% or 1.6% more bytes on
 * the example scenes), in four tables counted in turn and then added:
 * filtered rows are full of runs of one byte, and a single table would
 * wait on its own last increment (twice as slow). */
static double order0(int f, const unsigned char *cur, const unsigned char *prev, size_t n) {
    uint32_t cnt[4][256];
    memset(cnt, 0, sizeof cnt);
    size_t i = 0;
    if (n >= 8) {
        for (int k = 0; k < 4; k++) cnt[k][filter_byte(f, cur, prev, (size_t)k)]++;
        i = 8;
    }
#define COUNT4(v)                                                                                  \
    do {                                                                                           \
        for (; i + 8 <= n; i += 8) {                                                               \
            cnt[0][(unsigned char)(v(i))]++;                                                       \
            cnt[1][(unsigned char)(v(i + 1))]++;                                                   \
            cnt[2][(unsigned char)(v(i + 2))]++;                                                   \
            cnt[3][(unsigned char)(v(i + 3))]++;                                                   \
        }                                                                                          \
    } while (0)
    switch (f) {
    case 0: COUNT4(FILTER_NONE); break;
    case 1: COUNT4(FILTER_SUB); break;
    case 2: COUNT4(FILTER_UP); break;
    default: COUNT4(FILTER_AVG); break;
    }
#undef COUNT4
    for (; i < n; i += 2) cnt[0][filter_byte(f, cur, prev, i)]++;
    double s = 0;
    for (int b = 0; b < 256; b++) {
        uint32_t c = cnt[0][b] + cnt[1][b] + cnt[2][b] + cnt[3][b];
        s += c < PNG_XLOGX_N ? png_xlogx[c] : c * log2((double)c);
    }
    return s;
}

/* The one of None, Sub, Up and Average whose bytes have the least order-0
 * entropy for the row cur over prev.  (Measured against libpng's least sum
 * of absolute values and against Paeth: see the top comment.) */
static int filter_choose(const unsigned char *cur, const unsigned char *prev, size_t n) {
    int best = 0;
    double most = order0(0, cur, prev, n);
    for (int f = 1; f <= 3; f++) {
        double c = order0(f, cur, prev, n);
        if (c > most) {
            most = c;
            best = f;
        }
    }
    return best;
}

/* ---- one band ----------------------------------------------------------- */

/* libdeflate: one whole raw deflate stream, which deflate_chain makes into
 * one that the next band may follow unless the band is the last; its length
 * in out[0..cap), or 0 on failure. */
static size_t deflate_libdeflate(struct libdeflate_compressor *c, const unsigned char *in, size_t n,
                                 int last, unsigned char *out, size_t cap) {
    size_t len = libdeflate_deflate_compress(c, in, n, out, cap - DEFLATE_CHAIN_EXTRA);
    return len && !last ? deflate_chain(out, len, cap) : len;
}

/* ISA-L, the fastest (--png-level 1): a raw deflate ending in a sync flush
 * or, for the last band, the final block; its length, or 0 on failure. */
static size_t deflate_isal(unsigned char *in, size_t n, int last, unsigned char *lb, size_t lbsize,
                           unsigned char *out, size_t cap) {
    struct isal_zstream s;
    isal_deflate_init(&s);
    s.level = PNG_ISAL_LEVEL;
    s.level_buf = lb;
    s.level_buf_size = (uint32_t)lbsize;
    s.gzip_flag = IGZIP_DEFLATE;
    s.flush = SYNC_FLUSH;
    s.end_of_stream = (uint16_t)last;
    s.next_in = in;
    s.avail_in = (uint32_t)n;
    s.next_out = out;
    s.avail_out = (uint32_t)cap;
    int done = last ? ZSTATE_END : ZSTATE_NEW_HDR;
    if (isal_deflate(&s) != COMP_OK || s.avail_in || (int)s.internal_state.state != done) return 0;
    return cap - s.avail_out;
}

/* The deflate band i of a stream at level runs: PNG_ISAL or libdeflate's
 * level. */
static int band_level(int level, int i) {
    if (level != PNG_BLEND) return level;
    return i % PNG_ISAL_EVERY == PNG_ISAL_EVERY - 1 ? PNG_ISAL : PNG_BLEND_LD;
}

/* A worker's buffers, kept from band to band and from worker to worker in
 * the stream's pool: fresh ones for each band cost page faults (the
 * deflate's output, allocated a band, was 7% of the whole process on the
 * 1080p sphere scene). */
struct png_scratch {
    struct png_buf block;       /* holding all below, and libdeflate's compressor */
    unsigned char *filt, *zero; /* filtered rows, a row of zeros */
    unsigned char *z, *lb;      /* the deflate's output (zcap bytes), ISA-L's state */
    size_t zcap, lbsize;
    struct libdeflate_compressor *ld; /* for every level but ISA-L's */
    struct png_scratch *next;         /* in the pool */
};

/* Room for a band of raw bytes deflated by either library, with stored
 * blocks should it not compress, and the chain's empty block. */
static size_t band_zcap(size_t raw) { return raw + raw / 8 + 1024 + DEFLATE_CHAIN_EXTRA; }

static void band_encode(const rayd_image *img, int level, struct png_band *b, int last,
                        const struct png_scratch *w) {
    size_t n = (size_t)img->w * 3, rowb = n + 1;
    b->raw = rowb * (size_t)b->rows;
    int f = 0;
    for (int r = 0; r < b->rows; r++) {
        int y = b->y0 + r;
        const unsigned char *cur = image_row(img, y);
        const unsigned char *prev = y > 0 ? image_row(img, y - 1) : w->zero;
        if (r % PNG_CHOOSE_EVERY == 0) f = filter_choose(cur, prev, n);
        filter_row(f, cur, prev, n, w->filt + (size_t)r * rowb);
    }
    b->adler = isal_adler32(1, w->filt, b->raw);
    size_t zcap = band_zcap(b->raw);
    b->len = level == PNG_ISAL ? deflate_isal(w->filt, b->raw, last, w->lb, w->lbsize, w->z, zcap)
                               : deflate_libdeflate(w->ld, w->filt, b->raw, last, w->z, zcap);
}

static void scratch_free(struct png_scratch *w) {
    if (!w) return;
    libdeflate_free_compressor(w->ld); /* first: it may live in the block */
    png_buf_free(&w->block);
    free(w);
}

/* A worker's buffers for s's bands, from the pool or new; NULL when out of
 * memory. */
static struct png_scratch *scratch_take(struct rayd_png_stream *s) {
    pthread_mutex_lock(&s->lock);
    struct png_scratch *w = s->spare;
    if (w) {
        s->spare = w->next;
        s->nspare--;
    }
    pthread_mutex_unlock(&s->lock);
    if (w) return w;
    size_t n = (size_t)s->img->w * 3, raw = (n + 1) * (size_t)s->band_rows;
    w = calloc(1, sizeof *w);
    if (!w) return NULL;
    size_t zcap = band_zcap(raw), image_raw = (size_t)s->img->h * (n + 1);
    size_t room = (raw + n + zcap + 63) / 64 * 64;       /* the compressor's room from here */
    bool ld = s->level != PNG_ISAL, isal = s->level < 0; /* the blend: both */
    w->lbsize = isal ? ISAL_DEF_LVL2_DEFAULT : 0;
    png_buf_new(&w->block, room + (ld ? PNG_LD_ROOM : 0) + w->lbsize, image_raw);
    unsigned char *b = w->block.p;
    w->filt = b, w->zero = b ? b + raw : NULL, w->z = b ? b + raw + n : NULL;
    w->zcap = zcap;
    if (b) memset(w->zero, 0, n);
    w->lb = b && isal ? b + room + (ld ? PNG_LD_ROOM : 0) : NULL;
    png_ld_room = b && ld ? b + room : NULL;
    w->ld =
        ld ? libdeflate_alloc_compressor(s->level == PNG_BLEND ? PNG_BLEND_LD : s->level) : NULL;
    png_ld_room = NULL;
    if (w->filt && w->zero && w->z && (!isal || w->lb) && (!ld || w->ld)) return w;
    scratch_free(w);
    return NULL;
}

static void scratch_give(struct rayd_png_stream *s, struct png_scratch *w) {
    pthread_mutex_lock(&s->lock);
    bool keep = s->nspare < PNG_SPARE_MAX;
    if (keep) {
        w->next = s->spare;
        s->spare = w;
        s->nspare++;
    }
    pthread_mutex_unlock(&s->lock);
    if (!keep) scratch_free(w);
}

/* The bands' deflated bytes, kept until the file is joined, in blocks
 * that each hold many bands: one allocation a band touched fresh pages
 * for every band's bytes.  A big image's blocks are on huge pages
 * (PNG_HUGE_MIN). */
struct png_hold {
    struct png_hold *next;
    size_t used, cap;
    bool huge;
    unsigned char data[];
};

/* len bytes in s's hold, or NULL when out of memory. */
static unsigned char *hold_take(struct rayd_png_stream *s, size_t len) {
    pthread_mutex_lock(&s->lock);
    struct png_hold *h = s->hold;
    if (!h || h->cap - h->used < len) {
        size_t raw = (size_t)s->img->h * ((size_t)s->img->w * 3 + 1);
        size_t cap = raw >= PNG_HUGE_MIN ? PNG_HOLD_BLOCK : raw / 4 + 4096;
        cap = cap < len ? len : cap;
        struct png_buf m;
        png_buf_new(&m, sizeof *h + cap, raw);
        h = (struct png_hold *)(void *)m.p;
        if (h) {
            *h = (struct png_hold){s->hold, 0, cap, m.huge};
            s->hold = h;
        }
    }
    unsigned char *p = h ? h->data + h->used : NULL;
    if (h) h->used += len;
    pthread_mutex_unlock(&s->lock);
    return p;
}

/* The next band nobody has taken whose rows, and the row above them that
 * its filters read, are among rows [0, rows); -1 when there is none. */
static int band_claim(struct rayd_png_stream *s, int rows) {
    pthread_mutex_lock(&s->lock);
    int i = -1;
    if (s->next < s->nbands) {
        const struct png_band *b = &s->bands[s->next];
        if (b->y0 + b->rows <= rows) i = s->next++;
        if (i >= 0 && !s->finishing) s->early++;
    }
    pthread_mutex_unlock(&s->lock);
    return i;
}

/* Band i is done: the rows above the first band not done, but the one
 * right above it (its filters read it), go back to a window image. */
static void band_done(struct rayd_png_stream *s, int i) {
    pthread_mutex_lock(&s->lock);
    s->bands[i].done = true;
    while (s->done_upto < s->nbands && s->bands[s->done_upto].done) s->done_upto++;
    int read = s->done_upto < s->nbands ? s->bands[s->done_upto].y0 - 1 : s->img->h;
    pthread_mutex_unlock(&s->lock);
    image_rows_release(s->img, read);
}

/* Deflates the bands rows [0, rows) complete that nobody has taken, on
 * the calling thread. */
static void bands_encode(struct rayd_png_stream *s, int rows) {
    struct png_scratch *w = NULL;
    double spent = 0;
    for (int i; (i = band_claim(s, rows)) >= 0;) {
        if (!w) w = scratch_take(s);
        double t0 = clock_now();
        struct png_band *b = &s->bands[i];
        if (w) band_encode(s->img, band_level(s->level, i), b, i == s->nbands - 1, w);
        b->out = w && b->len ? hold_take(s, b->len) : NULL;
        if (b->out) memcpy(b->out, w->z, b->len);
        b->failed = !b->out;
        spent += clock_now() - t0;
        band_done(s, i);
    }
    if (w) scratch_give(s, w);
    pthread_mutex_lock(&s->lock);
    s->band_seconds += spent;
    pthread_mutex_unlock(&s->lock);
}

static void *band_worker(void *arg) {
    struct rayd_png_stream *s = arg;
    bands_encode(s, s->img->h);
    return NULL;
}

/* ---- the file ----------------------------------------------------------- */

/* Where the file's bytes go: into memory at p, or, when sink is set, to
 * the caller's sink in order (failed: it said no). */
struct out {
    unsigned char *p;
    size_t len;
    rayd_sink_fn sink;
    void *user;
    bool failed;
};

static void put(struct out *o, const void *data, size_t n) {
    if (o->sink) {
        o->failed = o->failed || (n && o->sink(o->user, data, n) != 0);
    } else {
        memcpy(o->p + o->len, data, n);
    }
    o->len += n;
}

static void be32(unsigned char *b, uint32_t v) {
    for (int k = 0; k < 4; k++) b[k] = (unsigned char)(v >> (24 - 8 * k));
}

/* A chunk whose data is up to three pieces: length, type, data, the CRC of
 * type and data. */
static void put_chunk3(struct out *o, const char *type, const unsigned char *const piece[3],
                       const size_t len[3]) {
    unsigned char head[8], crc[4];
    be32(head, (uint32_t)(len[0] + len[1] + len[2]));
    memcpy(head + 4, type, 4);
    uLong c = crc32_z(0, head + 4, 4);
    put(o, head, 8);
    for (int i = 0; i < 3; i++)
        if (len[i]) {
            c = crc32_z(c, piece[i], len[i]);
            put(o, piece[i], len[i]);
        }
    be32(crc, (uint32_t)c);
    put(o, crc, 4);
}

static void put_chunk(struct out *o, const char *type, const unsigned char *data, size_t n) {
    const unsigned char *piece[3] = {data, NULL, NULL};
    const size_t len[3] = {n, 0, 0};
    put_chunk3(o, type, piece, len);
}

static void put_header(struct out *o, const rayd_image *img) {
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    put(o, sig, 8);
    unsigned char ihdr[13] = {0, 0, 0, 0, 0, 0, 0, 0, 8, 2, 0, 0, 0}; /* 8-bit RGB */
    be32(ihdr, (uint32_t)img->w);
    be32(ihdr + 4, (uint32_t)img->h);
    put_chunk(o, "IHDR", ihdr, 13);
    unsigned char srgb = 0; /* perceptual */
    put_chunk(o, "sRGB", &srgb, 1);
    static const uint32_t gama = 45455,
                          chrm[8] = {31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000};
    unsigned char buf[32];
    be32(buf, gama);
    put_chunk(o, "gAMA", buf, 4);
    for (int i = 0; i < 8; i++) be32(buf + 4 * i, chrm[i]);
    put_chunk(o, "cHRM", buf, 32);
}

/* The zlib stream as one IDAT chunk a band: the first begins with the zlib
 * header, the last ends with the Adler-32 of the whole. */
static void put_idats(struct out *o, int level, const struct png_band *bands, int nbands) {
    static const unsigned char flg[4] = {0x01, 0x5e, 0x9c, 0xda}; /* by FLEVEL, as zlib */
    int flevel = level == PNG_ISAL ? 1                            /* fast */
                 : level < 2       ? 0 /* the blend, libdeflate's 0 and 1: fastest */
                 : level <= 5      ? 1
                 : level == 6      ? 2
                                   : 3;
    const unsigned char head[2] = {0x78, flg[flevel]};
    uLong adler = adler32_z(0, NULL, 0);
    for (int i = 0; i < nbands; i++)
        adler = adler32_combine(adler, bands[i].adler, (z_off_t)bands[i].raw);
    unsigned char tail[4];
    be32(tail, (uint32_t)adler);
    for (int i = 0; i < nbands; i++) {
        const unsigned char *piece[3] = {head, bands[i].out, tail};
        const size_t len[3] = {i == 0 ? 2 : 0, bands[i].len, i == nbands - 1 ? 4 : 0};
        put_chunk3(o, "IDAT", piece, len);
    }
    put_chunk(o, "IEND", NULL, 0);
}

static int png_threads(int threads, int nbands) {
    if (threads <= 0) {
        long c = sysconf(_SC_NPROCESSORS_ONLN);
        threads = c > 0 ? (int)c : 1;
    }
    if (threads > PNG_MAX_THREADS) threads = PNG_MAX_THREADS;
    return threads < nbands ? threads : nbands;
}

/* Stops the rows calls: later ones do nothing, and those under way are
 * waited for (their bands must be done before the file is joined or the
 * stream freed).  Returns the bands nobody has taken. */
static int stream_close(struct rayd_png_stream *s) {
    pthread_mutex_lock(&s->lock);
    s->finishing = true;
    while (s->calls > 0) pthread_cond_wait(&s->idle, &s->lock);
    int left = s->nbands - s->next;
    pthread_mutex_unlock(&s->lock);
    return left;
}

/* Deflates every band left on up to threads threads (none started when
 * none is left); 0 when all went well. */
static int encode_bands(struct rayd_png_stream *s, int threads) {
    int left = stream_close(s);
    threads = png_threads(threads, left);
    pthread_t tid[PNG_MAX_THREADS];
    int started = 0;
    for (int t = 1; t < threads; t++)
        if (pthread_create(&tid[started], NULL, band_worker, s) == 0) started++;
    bands_encode(s, s->img->h);
    for (int t = 0; t < started; t++) pthread_join(tid[t], NULL);
    for (int i = 0; i < s->nbands; i++)
        if (s->bands[i].failed) return -1;
    return 0;
}

/* The deflate a level asked for runs: PNG_ISAL, PNG_BLEND (the default,
 * which no level names) or libdeflate's level. */
static int png_level(int level) {
    if (level == 1) return PNG_ISAL; /* the fastest (smaller and faster than zlib's 1) */
    if (level < 0 || level > 9) return PNG_BLEND;
    return level;
}

const char *rayd_png_encoder(int level) {
    static const char *const names[] = {
#define PNG_LD_NAME(n) "libdeflate " LIBDEFLATE_VERSION_STRING " level " #n
        PNG_LD_NAME(0), PNG_LD_NAME(1), PNG_LD_NAME(2), PNG_LD_NAME(3), PNG_LD_NAME(4),
        PNG_LD_NAME(5), PNG_LD_NAME(6), PNG_LD_NAME(7), PNG_LD_NAME(8), PNG_LD_NAME(9),
#undef PNG_LD_NAME
    };
#define PNG_ISAL_NAME                                                                              \
    "isa-l " PNG_XSTR(ISAL_MAJOR_VERSION) "." PNG_XSTR(ISAL_MINOR_VERSION) " level " PNG_XSTR(     \
        PNG_ISAL_LEVEL)
    static const char isal[] = PNG_ISAL_NAME;
    static const char blend[] = "libdeflate " LIBDEFLATE_VERSION_STRING " level " PNG_XSTR(
        PNG_BLEND_LD) ", every " PNG_XSTR(PNG_ISAL_EVERY) "th band " PNG_ISAL_NAME;
#undef PNG_ISAL_NAME
    int l = png_level(level);
    return l == PNG_ISAL ? isal : l == PNG_BLEND ? blend : names[l];
}

enum rayd_status rayd_png_stream_new(const rayd_image *img, int level, rayd_png_stream **out,
                                     struct rayd_error *err) {
    if (img->win && (img->px || img->win->keep))
        return err_set(err, RAYD_E_ARG, NULL,
                       "a window image streams only its own render, into one stream");
    level = png_level(level);
    pthread_once(&png_xlogx_once, xlogx_init);
    size_t rowb = (size_t)img->w * 3 + 1;
    int band_rows = (int)(PNG_BAND_BYTES / rowb);
    if (band_rows < 1) band_rows = 1;
    struct rayd_png_stream *s = calloc(1, sizeof *s);
    int nbands = (img->h + band_rows - 1) / band_rows;
    if (s) s->bands = calloc((size_t)nbands, sizeof *s->bands);
    if (!s || !s->bands) {
        free(s);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory encoding the PNG");
    }
    s->img = img;
    s->level = level;
    s->nbands = nbands;
    s->band_rows = band_rows;
    for (int i = 0; i < nbands; i++) {
        s->bands[i].y0 = i * band_rows;
        s->bands[i].rows =
            img->h - s->bands[i].y0 < band_rows ? img->h - s->bands[i].y0 : band_rows;
    }
    pthread_mutex_init(&s->lock, NULL);
    pthread_cond_init(&s->idle, NULL);
    image_window_keep(img, band_rows + 1); /* a band and the row above it */
    *out = s;
    return RAYD_OK;
}

void rayd_png_stream_rows(void *stream, int rows) {
    struct rayd_png_stream *s = stream;
    pthread_mutex_lock(&s->lock);
    bool open = !s->finishing;
    s->calls += open;
    pthread_mutex_unlock(&s->lock);
    if (!open) return;
    bands_encode(s, rows);
    pthread_mutex_lock(&s->lock);
    if (--s->calls == 0) pthread_cond_broadcast(&s->idle);
    pthread_mutex_unlock(&s->lock);
}

void rayd_png_stream_free(rayd_png_stream *s) {
    if (!s) return;
    stream_close(s);
    while (s->hold) {
        struct png_hold *h = s->hold;
        s->hold = h->next;
        struct png_buf m = {(unsigned char *)h, sizeof *h + h->cap, h->huge};
        png_buf_free(&m);
    }
    free(s->bands);
    while (s->spare) {
        struct png_scratch *w = s->spare;
        s->spare = w->next;
        scratch_free(w);
    }
    pthread_cond_destroy(&s->idle);
    pthread_mutex_destroy(&s->lock);
    free(s);
}

/* The PNG file of s's encoded bands into *buf; 0, or -1 out of memory. */
static int png_assemble(const struct rayd_png_stream *s, void **buf, size_t *len) {
    size_t zlen = 6;
    for (int i = 0; i < s->nbands; i++) zlen += s->bands[i].len;
    /* header chunks 8 + 25 + 13 + 16 + 44, 12 per IDAT, IEND 12 */
    size_t cap = 8 + 25 + 13 + 16 + 44 + zlen + 12 * (size_t)s->nbands + 12;
    struct out o = {.p = malloc(cap)};
    if (!o.p) return -1;
    put_header(&o, s->img);
    put_idats(&o, s->level, s->bands, s->nbands);
    *buf = o.p;
    *len = o.len;
    return 0;
}

/* A window image holds rows only once its render has opened it: until
 * then there is nothing to encode (and no row has a place). */
static enum rayd_status stream_undrawn(rayd_png_stream *s, struct rayd_error *err) {
    if (!s->img->win || s->img->win->rows > 0) return RAYD_OK;
    rayd_png_stream_free(s);
    return err_set(err, RAYD_E_ARG, NULL, "a window image is encoded only as its render draws it");
}

enum rayd_status rayd_png_stream_finish(rayd_png_stream *s, int threads, void **buf, size_t *len,
                                        struct rayd_png_stats *stats, struct rayd_error *err) {
    if (stream_undrawn(s, err) != RAYD_OK) return RAYD_E_ARG;
    int failed = encode_bands(s, threads);
    if (stats) *stats = (struct rayd_png_stats){s->nbands, s->early, s->band_seconds};
    failed = failed || png_assemble(s, buf, len) < 0;
    rayd_png_stream_free(s);
    if (failed) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory encoding the PNG");
    return RAYD_OK;
}

enum rayd_status rayd_png_stream_finish_to(rayd_png_stream *s, int threads, rayd_sink_fn sink,
                                           void *user, struct rayd_png_stats *stats,
                                           struct rayd_error *err) {
    if (stream_undrawn(s, err) != RAYD_OK) return RAYD_E_ARG;
    int failed = encode_bands(s, threads);
    if (stats) *stats = (struct rayd_png_stats){s->nbands, s->early, s->band_seconds};
    struct out o = {.sink = sink, .user = user};
    if (!failed) {
        put_header(&o, s->img);
        put_idats(&o, s->level, s->bands, s->nbands);
    }
    rayd_png_stream_free(s);
    if (failed) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory encoding the PNG");
    if (o.failed) return err_set(err, RAYD_E_IO, NULL, "the PNG's bytes could not be written");
    return RAYD_OK;
}

enum rayd_status rayd_png_encode_threads(const rayd_image *img, int level, int threads, void **buf,
                                         size_t *len, struct rayd_error *err) {
    if (img->win) /* its rows come only while its render draws them */
        return err_set(err, RAYD_E_ARG, NULL, "a window image is encoded only by its stream");
    rayd_png_stream *s = NULL;
    enum rayd_status st = rayd_png_stream_new(img, level, &s, err);
    if (st != RAYD_OK) return st;
    return rayd_png_stream_finish(s, threads, buf, len, NULL, err);
}
