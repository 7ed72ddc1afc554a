/* scenes.c -- compiled scenes by content: the scene cache behind the lock.
 *
 * Tile clients send the same scene many times, and parsing a scene and
 * building its BVHs is the costly part of a small render, so every body is
 * looked up by its SHA-256 first and compiled only on a miss.  Hashing and
 * compiling run outside work_lock (they take milliseconds to seconds); the
 * lookup and the insertion take it, because cache.c and rcache.c have no
 * lock of their own.  Where they run is compile.c's choice: the lookup on
 * the connection's thread, a parse on its pool, where two requests posting
 * the same new scene at once wait for one parse.
 *
 * A scene that read files is used from the cache only while they are
 * unchanged (scenefiles.c); otherwise it is compiled again and replaces the
 * old entry, which renders in flight keep until they finish.
 *
 * The parse stages (parse, decode mesh files, build BVHs) of a miss are
 * timed here for rayd_stage_seconds.
 *
 * A compiled scene's bytes (rayd_scene_info: its textures, meshes, BVHs)
 * are counted in the one memory budget (--max-memory, mem.c) from its
 * compile to its free, whether it is cached, queued or rendering; a scene
 * that finds no room is freed and refused (503 memory_full with
 * Retry-After, or 413 when it alone is over the whole budget) before
 * anything holds it.
 *
 * A parse is counted too, before it starts and while it builds.  When its
 * body is queued (compile.c) a first cap, from the body's size
 * (scenes_parse_cap: its JSON tree, inline meshes and data URIs), is
 * reserved as kind "parses".  Then the core tells, before each image it
 * decodes, each file it reads and each mesh it builds, about the bytes that
 * will hold (rayd_limits.charge, scenes_charge here): what passes the
 * reservation is reserved first, so the count grows with the parse rather
 * than after it.  A charge with no room now ends the parse 503 memory_full
 * (Retry-After); one that takes the scene over the whole budget (less its
 * own body) ends it 413, at the JSON Pointer of the value that did.  So a
 * parse that ends refused never held more than the count said, give or
 * take the value being decoded.  When the scene is built its measured bytes
 * (rayd_scene_info) replace the reservation: they become kind scenes and
 * the rest is released.  The core's own limits (triangles, texels, bytes
 * read) are set to the whole budget as well (scenes_room), so a scene whose
 * single value is over the budget is refused before it is decoded.
 */
#include "work/work_private.h"

#include <string.h>

/* The scene limits: the core's defaults with --max-pixels, --max-body and
 * --asset-dir (files read only inside it), unless set here (the fuzz harness lowers them so it
 * explores errors rather than rendering big scenes). */
static struct rayd_limits scenes_limits;
static bool scenes_limits_set;
/* Every parse's image textures and mesh sources, shared with the live
 * scenes of the same bytes (the frames of a frame-range job, a scene
 * edited in the preview):
 * the cache holds none itself, so it adds nothing to the memory budget. */
static rayd_asset_cache *scenes_assets;

void scenes_set_limits(const struct rayd_limits *lim) {
    scenes_limits = *lim;
    scenes_limits_set = true;
}

static void scenes_nomem(struct rayd_error *err, const char *msg) {
    if (!err) return;
    memset(err, 0, sizeof *err);
    err->code = RAYD_E_NOMEM;
    snprintf(err->message, sizeof err->message, "%s", msg);
}

struct cache_entry *scenes_peek(const char *id) {
    work_lock_take();
    struct cache_entry *e = cache_get(id);
    work_lock_give();
    return e;
}

bool scenes_current(struct cache_entry *e, bool have_text) {
    return scenefiles_usable(cache_scene(e), have_text);
}

/* About the memory a built triangle takes (its vertices, normals, BVH
 * nodes and material index; 5 million took 650 MB), and a decoded texel
 * (linear RGB floats). */
#define SCENES_TRIANGLE_BYTES 128
#define SCENES_TEXEL_BYTES 12

/* A parse's first cap: SCENES_PARSE_FLOOR, and SCENES_PARSE_PER_BYTE bytes
 * a byte of text (its JSON tree, inline meshes and data URIs decoded);
 * each charge past the reservation grows it by at least SCENES_PARSE_GROW. */
#define SCENES_PARSE_FLOOR ((size_t)4 << 20)
#define SCENES_PARSE_PER_BYTE 32
#define SCENES_PARSE_GROW ((size_t)1 << 20)

static size_t scenes_last_cap(size_t len);

/* At most half of what the scene may take in all: the body is counted
 * too, and a first cap of the whole budget could never be reserved beside
 * it (a 4 MB body under --max-memory 128M was 503 memory_full, "retry
 * later", on an idle server for good).  A parse that needs more grows its
 * reservation charge by charge (scenes_charge). */
size_t scenes_parse_cap(size_t len) {
    size_t most = scenes_last_cap(len) / 2;
    if (len >= most / SCENES_PARSE_PER_BYTE) return most; /* and no overflow below */
    size_t cap = SCENES_PARSE_FLOOR + len * SCENES_PARSE_PER_BYTE;
    return cap < most ? cap : most;
}

size_t scenes_check_cap(size_t len) {
    size_t most = scenes_last_cap(len) / 2;
    return len >= most / SCENES_PARSE_PER_BYTE ? most : len * SCENES_PARSE_PER_BYTE;
}

/* A scene may not build more than the whole memory budget (less its own
 * text): its triangles, its decoded textures and the files and buffers it
 * reads are each held to it (the text itself, already read, keeps
 * --max-body), so a few bytes of glTF or PNG are refused 413 with the JSON
 * Pointer of what is too big, rather than building hundreds of MB first.
 * The cap is the budget, not the room left now, so the 413 does not depend
 * on other requests: the room now is scenes_charge's (503). */
static void scenes_room(struct rayd_limits *lim, size_t cap) {
    size_t room = cap;
    if ((size_t)lim->max_triangles > room / SCENES_TRIANGLE_BYTES)
        lim->max_triangles = (long)(room / SCENES_TRIANGLE_BYTES);
    if (lim->max_texels <= 0 || (size_t)lim->max_texels > room / SCENES_TEXEL_BYTES)
        lim->max_texels = (long)(room / SCENES_TEXEL_BYTES) + 1; /* 0 would be the default */
    size_t floor = (size_t)config.max_body;
    if (lim->max_bytes > room) lim->max_bytes = room > floor ? room : floor;
}

/* A parse's account in the budget (rayd_limits.charge's argument): held,
 * the bytes of kind parses reserved for it; charged, what the core said it
 * takes, beyond the first cap's share; last, the most the scene may take. */
struct scenes_meter {
    size_t held, charged, last;
    /* the last charge's refusal (RAYD_OK: none): RAYD_E_NOMEM, the budget
     * had no room now; RAYD_E_LIMIT, past the whole budget */
    enum rayd_status refused;
};

/* The core's charge: reserves what passes the reservation, or refuses
 * (413 past the whole budget, 503 with no room now); a negative delta is
 * given back (the working copy of a step freed). */
static enum rayd_status scenes_charge(void *arg, long long delta, char *why, size_t why_len) {
    struct scenes_meter *m = arg;
    if (delta < 0) { /* given back: the reservation stays the parse's, for what comes next */
        size_t back = (size_t) - (delta + 1) + 1;
        m->charged -= back < m->charged ? back : m->charged;
        return RAYD_OK;
    }
    size_t bytes = (size_t)delta, before = m->charged;
    m->refused = RAYD_OK;
    m->charged = bytes > SIZE_MAX - m->charged ? SIZE_MAX : m->charged + bytes;
    if (m->charged <= m->held) return RAYD_OK;
    /* a refused charge is not taken: the loader may go on without what it
     * was for (a copy it would have shared, rayd.h), and the parse's later
     * charges must not pay for it */
    if (m->charged > m->last) {
        snprintf(why, why_len,
                 "brings the scene to more than %zu bytes, over the memory budget of %zu bytes "
                 "(--max-memory)",
                 m->last, mem_limit());
        m->charged = before;
        return m->refused = RAYD_E_LIMIT;
    }
    size_t grow = m->charged - m->held;
    if (grow < SCENES_PARSE_GROW) grow = SCENES_PARSE_GROW;
    if (grow > m->last - m->held) grow = m->last - m->held;
    if (!mem_reserve(MEM_PARSES, grow)) {
        snprintf(why, why_len,
                 "brings the scene to %zu bytes and the memory budget of %zu bytes "
                 "(--max-memory) has no room for it now; retry later",
                 m->charged, mem_limit());
        m->charged = before;
        return m->refused = RAYD_E_NOMEM;
    }
    m->held += grow;
    return RAYD_OK;
}

/* The core's limits of a scene's parse, from the options. */
static void scenes_limits_now(struct rayd_limits *lim) {
    if (scenes_limits_set) {
        *lim = scenes_limits;
        return;
    }
    rayd_limits_default(lim);
    lim->max_pixels = config.max_pixels;
    lim->max_samples = (int)config.max_samples;
    if (lim->max_bytes < (size_t)config.max_body) lim->max_bytes = (size_t)config.max_body;
    lim->asset_dir = config.asset_dir; /* confined (asset_confine) */
}

enum rayd_status scenes_check_frames(const char *body, size_t len, long first, long last,
                                     const atomic_int *cancel, struct rayd_error *err) {
    struct rayd_limits lim;
    scenes_limits_now(&lim);
    lim.cancel = cancel;
    return rayd_scene_check_frames(body, len, &lim, first, last, err);
}

/* Parses and builds body outside the lock, timing each stage. */
static enum rayd_status scenes_compile(const char *body, size_t len, long frame,
                                       const atomic_int *cancel, struct scenes_meter *m,
                                       rayd_scene **scene, struct rayd_error *err) {
    struct rayd_limits lim;
    scenes_limits_now(&lim);
    scenes_room(&lim, m->last);
    lim.charge = scenes_charge;
    lim.charge_arg = m;
    lim.assets = scenes_assets;
    lim.cancel = cancel;
    metrics_scene_parse();
    double t0 = clock_now();
    enum rayd_status st = frame < 0 ? rayd_scene_parse(body, len, &lim, scene, err)
                                    : rayd_scene_parse_frame(body, len, &lim, frame, scene, err);
    double parsed = clock_now() - t0;
    if (st == RAYD_E_CANCELED) metrics_scene_parse_canceled();
    if (st != RAYD_OK) {
        metrics_stage(MS_PARSE, parsed);
        return st;
    }
    struct rayd_scene_info info;
    rayd_scene_info(*scene, &info);
    metrics_stage(MS_PARSE, parsed - info.decode_seconds - info.build_seconds);
    metrics_stage(MS_DECODE, info.decode_seconds);
    metrics_stage(MS_BUILD, info.build_seconds);
    return RAYD_OK;
}

static size_t scenes_bytes(const rayd_scene *scene) {
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    return info.bytes;
}

/* err says the budget has no room now for what, of bytes: 503 memory_full. */
static void scenes_full(struct rayd_error *err, const char *what, size_t bytes, bool *full) {
    metrics_reject(MR_MEMORY);
    memset(err, 0, sizeof *err);
    err->code = RAYD_E_NOMEM;
    snprintf(err->message, sizeof err->message,
             "%s %zu bytes and the memory budget of %zu bytes (--max-memory) has no room for "
             "it now; retry later",
             what, bytes, mem_limit());
    *full = true;
}

/* Counts a scene just compiled in the memory budget, its parse's held
 * bytes turned into its own, or frees it and says why not: 413 when it
 * alone is over the budget, else 503 (no room now). */
static enum rayd_status scenes_reserve(rayd_scene *scene, size_t held, struct rayd_error *err,
                                       bool *full) {
    size_t bytes = scenes_bytes(scene);
    if (bytes <= held) {
        mem_move(MEM_PARSES, MEM_SCENES, bytes);
        mem_release(MEM_PARSES, held - bytes);
        return RAYD_OK;
    }
    if (mem_reserve(MEM_SCENES, bytes - held)) {
        mem_move(MEM_PARSES, MEM_SCENES, held);
        return RAYD_OK;
    }
    mem_release(MEM_PARSES, held);
    rayd_scene_free(scene);
    mem_freed(bytes); /* for mem_trim: the heap held it a moment ago */
    if (bytes <= mem_limit()) {
        scenes_full(err, "the compiled scene takes", bytes, full);
        return RAYD_E_NOMEM;
    }
    metrics_reject(MR_MEMORY);
    memset(err, 0, sizeof *err);
    err->code = RAYD_E_LIMIT;
    snprintf(err->message, sizeof err->message,
             "the compiled scene takes %zu bytes, over the memory budget of %zu bytes "
             "(--max-memory)",
             bytes, mem_limit());
    return err->code;
}

/* The most a scene of len bytes of text may take: the budget less the
 * body's buffer, counted too (twice the text at most: a chunked body's
 * buffer grows by doubling). */
static size_t scenes_last_cap(size_t len) {
    size_t text = 2 * len + 4096;
    return mem_limit() > text ? mem_limit() - text : 0;
}

bool scenes_id(const char *body, size_t len, char id[65], struct rayd_error *err) {
    if (cache_hash(body, len, id)) return true;
    scenes_nomem(err, "cannot hash the scene (libcrypto)");
    return false;
}

enum rayd_status scenes_build(const char *id, const char *body, size_t len, long frame, size_t held,
                              const atomic_int *cancel, struct cache_entry **out,
                              struct rayd_error *err, bool *full) {
    rayd_scene *scene = NULL;
    /* the first cap's share of the text (its JSON tree) is taken; the
     * core's charges start on the rest */
    size_t tree = len > held / SCENES_PARSE_PER_BYTE ? held : len * SCENES_PARSE_PER_BYTE;
    struct scenes_meter m = {.held = held, .charged = tree, .last = scenes_last_cap(len)};
    enum rayd_status st = scenes_compile(body, len, frame, cancel, &m, &scene, err);
    *full = st == RAYD_E_NOMEM && m.refused == RAYD_E_NOMEM; /* the budget's refusal ended it */
    if (st != RAYD_OK && st == m.refused) metrics_reject(MR_MEMORY); /* it ended the parse */
    if (st != RAYD_OK) {
        mem_release(MEM_PARSES, m.held);
        return st;
    }
    st = scenes_reserve(scene, m.held, err, full);
    if (st != RAYD_OK) return st;
    char version[65];
    struct cache_entry *e = NULL;
    if (scenefiles_version(id, scene, version)) {
        work_lock_take();
        e = cache_put(id, version, scene);
        work_lock_give();
    }
    if (!e) {
        mem_release(MEM_SCENES, scenes_bytes(scene));
        rayd_scene_free(scene);
        scenes_nomem(err, "out of memory");
        return RAYD_E_NOMEM;
    }
    *out = e;
    return RAYD_OK;
}

void scenes_release(struct cache_entry *e) {
    if (!e) return;
    work_lock_take();
    cache_release(e);
    work_lock_give();
}

/* ---- both caches' gauges, registered with metrics.c --------------------- */

/* The bytes (or, bytes false, the entries) of the cache whose stats
 * function is given (cache.c's or rcache.c's), read under the lock that
 * both files leave to their callers. */
static long scenes_size(void (*stats)(size_t *bytes, size_t *entries), bool bytes) {
    size_t b, n;
    work_lock_take();
    stats(&b, &n);
    work_lock_give();
    return (long)(bytes ? b : n);
}

static long scenes_gauge_bytes(void) { return scenes_size(cache_stats, true); }
static long scenes_gauge_entries(void) { return scenes_size(cache_stats, false); }
static long scenes_gauge_rbytes(void) { return scenes_size(rcache_stats, true); }
static long scenes_gauge_rentries(void) { return scenes_size(rcache_stats, false); }

static long scenes_assets_count(enum rayd_asset_kind kind, bool shared) {
    long hits = 0, misses = 0;
    if (scenes_assets) rayd_asset_cache_stats(scenes_assets, kind, &hits, &misses);
    return shared ? hits : misses;
}
static long scenes_gauge_shared(void) { return scenes_assets_count(RAYD_ASSET_IMAGE, true); }
static long scenes_gauge_decoded(void) { return scenes_assets_count(RAYD_ASSET_IMAGE, false); }
static long scenes_gauge_meshes_shared(void) { return scenes_assets_count(RAYD_ASSET_MESH, true); }
static long scenes_gauge_meshes_built(void) { return scenes_assets_count(RAYD_ASSET_MESH, false); }

/* Sizes the scene cache and the result cache and registers their gauges:
 * here, because this file is where the caches meet the lock. */
void scenes_start(void) {
    cache_init((size_t)config.cache_mb * 1024 * 1024);
    rcache_init((size_t)config.result_cache_mb * 1024 * 1024);
    metrics_gauge(MG_CACHE_BYTES, scenes_gauge_bytes);
    metrics_gauge(MG_CACHE_ENTRIES, scenes_gauge_entries);
    metrics_gauge(MG_RESULT_CACHE_BYTES, scenes_gauge_rbytes);
    metrics_gauge(MG_RESULT_CACHE_ENTRIES, scenes_gauge_rentries);
    scenes_assets = rayd_asset_cache_new(0); /* NULL: every parse decodes its own */
    metrics_gauge(MG_IMAGES_SHARED, scenes_gauge_shared);
    metrics_gauge(MG_IMAGES_DECODED, scenes_gauge_decoded);
    metrics_gauge(MG_MESHES_SHARED, scenes_gauge_meshes_shared);
    metrics_gauge(MG_MESHES_BUILT, scenes_gauge_meshes_built);
}

void scenes_stop(void) {
    cache_free_all();
    rcache_free_all();
    rayd_asset_cache_free(scenes_assets); /* freed with the last scene that holds an entry */
    scenes_assets = NULL;
}
