/* png_encode.c -- PNG out, deflated in parallel bands.
 *
 * Encoding a 1080p frame with libpng (one thread, zlib level 6, adaptive
 * filters) took about twice as long as rendering it.  Here the image is cut
 * into bands of rows; each band is filtered and deflated on its own (zlib,
 * raw deflate) by whichever thread takes it, and the bands are joined into
 * one zlib stream: a band that is not the last ends with a sync flush (a
 * byte-aligned empty stored block, never a final block), so the deflate
 * streams simply follow one another, and the Adler-32 of the whole is
 * combined from the bands' (adler32_combine).  This is how pigz writes one
 * valid stream from parallel pieces.
 *
 * The bands depend on the image width alone (about 256 KiB of raw rows
 * each), never on the thread count, so the bytes are the same however many
 * threads encode.  Each band starts with an empty dictionary, which costs a
 * little size (under 1% at level 6 on the example scenes).
 *
 * Filters: per row, the one of the five PNG filters whose output has the
 * smallest sum of absolute values (as signed bytes), libpng's own
 * heuristic; deflate with zlib's filtered strategy, as libpng does.  With
 * no level asked for (-1), zlib level 4, chosen by measurement
 * (bench/pngbench.c, 2 threads): on the 1080p sphere scene 6x faster than
 * libpng at level 6 for 8.6% more bytes, and 0-11% more on the example
 * scenes.  The default strategy at level 4 was as fast but up to 15%
 * larger; level 5, 1.4x slower; zlib's run-length strategy 1.5x faster but
 * up to 23% larger.
 *
 * The chunks are those libpng wrote before: IHDR, sRGB, gAMA and cHRM for
 * sRGB, the IDATs (one a band: no copy of the whole stream), IEND.
 */
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

#include "base/error.h"
#include "render/image.h"

#define PNG_BAND_BYTES (256u * 1024u) /* raw bytes of a band, about */
#define PNG_MAX_THREADS 64
#define PNG_LEVEL_DEFAULT 4 /* zlib level when none is asked for (measured) */

struct png_band {
    int y0, rows;
    unsigned char *out; /* raw deflate of the band's filtered rows */
    size_t len;
    uLong adler; /* of the filtered rows */
    size_t raw;  /* bytes of filtered rows */
    int failed;
};

struct png_job {
    const rayd_image *img;
    int level, nbands;
    struct png_band *bands;
    pthread_mutex_t lock;
    int next; /* the next band nobody has taken */
};

/* ---- filtering ---------------------------------------------------------- */

/* Each filter has its own loop (the compiler vectorises all but Paeth);
 * a = the byte one pixel left, b = above, c = above-left. */
static inline int paeth(int a, int b, int c) {
    int pa = abs(b - c), pb = abs(a - c), pc = abs(a + b - 2 * c);
    int ab = pa <= pb ? a : b, pab = pa <= pb ? pa : pb;
    return pab <= pc ? ab : c;
}

static unsigned long cost(const unsigned char *v, size_t n) {
    unsigned long sum = 0;
    for (size_t i = 0; i < n; i++) sum += (unsigned)abs((signed char)v[i]);
    return sum;
}

/* Filters row cur over row prev (zeros above the first row) with filter f
 * into out[1..n], out[0] = f; returns the cost of the result. */
static unsigned long filter_row(int f, const unsigned char *cur, const unsigned char *prev,
                                size_t n, unsigned char *out) {
    unsigned char *o = out + 1;
    out[0] = (unsigned char)f;
    size_t k = n < 3 ? n : 3;
    switch (f) {
    case 0:
        memcpy(o, cur, n);
        break;
    case 1:
        memcpy(o, cur, k);
        for (size_t i = 3; i < n; i++) o[i] = (unsigned char)(cur[i] - cur[i - 3]);
        break;
    case 2:
        for (size_t i = 0; i < n; i++) o[i] = (unsigned char)(cur[i] - prev[i]);
        break;
    case 3:
        for (size_t i = 0; i < k; i++) o[i] = (unsigned char)(cur[i] - (prev[i] >> 1));
        for (size_t i = 3; i < n; i++)
            o[i] = (unsigned char)(cur[i] - ((cur[i - 3] + prev[i]) >> 1));
        break;
    default:
        for (size_t i = 0; i < k; i++) o[i] = (unsigned char)(cur[i] - prev[i]);
        for (size_t i = 3; i < n; i++)
            o[i] = (unsigned char)(cur[i] - paeth(cur[i - 3], prev[i], prev[i - 3]));
        break;
    }
    return cost(o, n);
}

/* The row filtered with the filter of least cost (libpng's heuristic), into
 * out (1 + n bytes); tmp is scratch of the same size. */
static void filter_best(const unsigned char *cur, const unsigned char *prev, size_t n,
                        unsigned char *out, unsigned char *tmp) {
    unsigned char *best = out, *spare = tmp; /* the better of the two so far, and the other */
    unsigned long least = filter_row(0, cur, prev, n, best);
    for (int f = 1; f <= 4; f++) {
        unsigned long c = filter_row(f, cur, prev, n, spare);
        if (c < least) {
            least = c;
            unsigned char *t = best;
            best = spare;
            spare = t;
        }
    }
    if (best != out) memcpy(out, best, n + 1);
}

/* ---- one band ----------------------------------------------------------- */

static void band_encode(const rayd_image *img, int level, struct png_band *b, int last) {
    size_t n = (size_t)img->w * 3, rowb = n + 1;
    b->raw = rowb * (size_t)b->rows;
    unsigned char *filt = malloc(b->raw), *tmp = malloc(rowb), *zero = calloc(1, n);
    z_stream z;
    memset(&z, 0, sizeof z);
    if (!filt || !tmp || !zero ||
        deflateInit2(&z, level, Z_DEFLATED, -15, 8, Z_FILTERED) != Z_OK) {
        free(filt);
        free(tmp);
        free(zero);
        b->failed = 1;
        return;
    }
    for (int r = 0; r < b->rows; r++) {
        int y = b->y0 + r;
        const unsigned char *cur = img->px + (size_t)y * n;
        filter_best(cur, y > 0 ? cur - n : zero, n, filt + (size_t)r * rowb, tmp);
    }
    free(zero);
    b->adler = adler32_z(adler32_z(0, NULL, 0), filt, b->raw);
    size_t cap = deflateBound(&z, (uLong)b->raw) + 16;
    b->out = malloc(cap);
    if (!b->out) {
        b->failed = 1;
    } else {
        z.next_in = filt;
        z.avail_in = (uInt)b->raw;
        z.next_out = b->out;
        z.avail_out = (uInt)cap;
        int rc = deflate(&z, last ? Z_FINISH : Z_SYNC_FLUSH);
        if ((last && rc != Z_STREAM_END) || (!last && (rc != Z_OK || z.avail_in != 0)))
            b->failed = 1;
        b->len = cap - z.avail_out;
    }
    deflateEnd(&z);
    free(filt);
    free(tmp);
}

static void *band_worker(void *arg) {
    struct png_job *j = arg;
    for (;;) {
        pthread_mutex_lock(&j->lock);
        int i = j->next < j->nbands ? j->next++ : -1;
        pthread_mutex_unlock(&j->lock);
        if (i < 0) return NULL;
        band_encode(j->img, j->level, &j->bands[i], i == j->nbands - 1);
    }
}

/* ---- the file ----------------------------------------------------------- */

struct out {
    unsigned char *p;
    size_t len;
};

static void put32(struct out *o, uint32_t v) {
    o->p[o->len++] = (unsigned char)(v >> 24);
    o->p[o->len++] = (unsigned char)(v >> 16);
    o->p[o->len++] = (unsigned char)(v >> 8);
    o->p[o->len++] = (unsigned char)v;
}

/* A chunk whose data is up to three pieces: length, type, data, the CRC of
 * type and data. */
static void put_chunk3(struct out *o, const char *type, const unsigned char *const piece[3],
                       const size_t len[3]) {
    put32(o, (uint32_t)(len[0] + len[1] + len[2]));
    size_t start = o->len;
    memcpy(o->p + o->len, type, 4);
    o->len += 4;
    for (int i = 0; i < 3; i++)
        if (len[i]) {
            memcpy(o->p + o->len, piece[i], len[i]);
            o->len += len[i];
        }
    put32(o, (uint32_t)crc32_z(0, o->p + start, o->len - start));
}

static void put_chunk(struct out *o, const char *type, const unsigned char *data, size_t n) {
    const unsigned char *piece[3] = {data, NULL, NULL};
    const size_t len[3] = {n, 0, 0};
    put_chunk3(o, type, piece, len);
}

static void put_header(struct out *o, const rayd_image *img) {
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    memcpy(o->p, sig, 8);
    o->len = 8;
    unsigned char ihdr[13] = {0, 0, 0, 0, 0, 0, 0, 0, 8, 2, 0, 0, 0}; /* 8-bit RGB */
    for (int k = 0; k < 4; k++) {
        ihdr[k] = (unsigned char)((uint32_t)img->w >> (24 - 8 * k));
        ihdr[4 + k] = (unsigned char)((uint32_t)img->h >> (24 - 8 * k));
    }
    put_chunk(o, "IHDR", ihdr, 13);
    unsigned char srgb = 0; /* perceptual */
    put_chunk(o, "sRGB", &srgb, 1);
    static const uint32_t gama = 45455,
                          chrm[8] = {31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000};
    unsigned char buf[32];
    for (int k = 0; k < 4; k++) buf[k] = (unsigned char)(gama >> (24 - 8 * k));
    put_chunk(o, "gAMA", buf, 4);
    for (int i = 0; i < 8; i++)
        for (int k = 0; k < 4; k++) buf[4 * i + k] = (unsigned char)(chrm[i] >> (24 - 8 * k));
    put_chunk(o, "cHRM", buf, 32);
}

/* The zlib stream as one IDAT chunk a band: the first begins with the zlib
 * header, the last ends with the Adler-32 of the whole. */
static void put_idats(struct out *o, int level, const struct png_band *bands, int nbands) {
    static const unsigned char flg[4] = {0x01, 0x5e, 0x9c, 0xda}; /* by FLEVEL, as zlib */
    int flevel = level < 2 ? 0 : level <= 5 ? 1 : level == 6 ? 2 : 3;
    const unsigned char head[2] = {0x78, flg[flevel]};
    uLong adler = adler32_z(0, NULL, 0);
    for (int i = 0; i < nbands; i++)
        adler = adler32_combine(adler, bands[i].adler, (z_off_t)bands[i].raw);
    unsigned char tail[4];
    for (int k = 0; k < 4; k++) tail[k] = (unsigned char)(adler >> (24 - 8 * k));
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

/* Deflates every band on threads threads; 0 when all went well. */
static int encode_bands(struct png_job *j, int threads) {
    pthread_t tid[PNG_MAX_THREADS];
    int started = 0;
    for (int t = 1; t < threads; t++)
        if (pthread_create(&tid[started], NULL, band_worker, j) == 0) started++;
    band_worker(j);
    for (int t = 0; t < started; t++) pthread_join(tid[t], NULL);
    for (int i = 0; i < j->nbands; i++)
        if (j->bands[i].failed) return -1;
    return 0;
}

enum rayd_status rayd_png_encode_threads(const rayd_image *img, int level, int threads, void **buf,
                                         size_t *len, struct rayd_error *err) {
    if (level < 0 || level > 9) level = PNG_LEVEL_DEFAULT;
    size_t rowb = (size_t)img->w * 3 + 1;
    int band_rows = (int)(PNG_BAND_BYTES / rowb);
    if (band_rows < 1) band_rows = 1;
    struct png_job j = {.img = img, .level = level, .nbands = (img->h + band_rows - 1) / band_rows};
    j.bands = calloc((size_t)j.nbands, sizeof *j.bands);
    if (!j.bands) return err_set(err, RAYD_E_NOMEM, NULL, "out of memory encoding the PNG");
    for (int i = 0; i < j.nbands; i++) {
        j.bands[i].y0 = i * band_rows;
        j.bands[i].rows = img->h - j.bands[i].y0 < band_rows ? img->h - j.bands[i].y0 : band_rows;
    }
    pthread_mutex_init(&j.lock, NULL);
    int failed = encode_bands(&j, png_threads(threads, j.nbands));
    pthread_mutex_destroy(&j.lock);
    size_t zlen = 6;
    for (int i = 0; i < j.nbands; i++) zlen += j.bands[i].len;
    /* header chunks 8 + 25 + 13 + 16 + 44, 12 per IDAT, IEND 12 */
    size_t cap = 8 + 25 + 13 + 16 + 44 + zlen + 12 * (size_t)j.nbands + 12;
    struct out o = {failed ? NULL : malloc(cap), 0};
    int ok = o.p != NULL;
    if (ok) {
        put_header(&o, img);
        put_idats(&o, level, j.bands, j.nbands);
    }
    for (int i = 0; i < j.nbands; i++) free(j.bands[i].out);
    free(j.bands);
    if (!ok) {
        free(o.p);
        return err_set(err, RAYD_E_NOMEM, NULL, "out of memory encoding the PNG");
    }
    *buf = o.p;
    *len = o.len;
    return RAYD_OK;
}
