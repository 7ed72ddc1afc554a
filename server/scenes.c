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
 * that finds no room is freed and refused (503 with Retry-After, or 413
 * when it alone is over the whole budget) before anything holds it.
 */
#include "work_private.h"

#include <string.h>

/* The scene limits: the core's defaults with --max-pixels, --max-body and
 * --asset-dir (files read only inside it), unless set here (the fuzz harness lowers them so it explores errors rather
 * than rendering big scenes). */
static struct rayd_limits scenes_limits;
static bool scenes_limits_set;

void scenes_set_limits(const struct rayd_limits *lim)
{
    scenes_limits = *lim;
    scenes_limits_set = true;
}

static void scenes_nomem(struct rayd_error *err, const char *msg)
{
    if (!err)
        return;
    memset(err, 0, sizeof *err);
    err->code = RAYD_E_NOMEM;
    snprintf(err->message, sizeof err->message, "%s", msg);
}

struct cache_entry *scenes_peek(const char *id)
{
    pthread_mutex_lock(&work_lock);
    struct cache_entry *e = cache_get(id);
    pthread_mutex_unlock(&work_lock);
    return e;
}

bool scenes_current(struct cache_entry *e, bool have_text)
{
    return scenefiles_usable(cache_scene(e), have_text);
}

/* About the memory a built triangle takes (its vertices, normals, BVH
 * nodes and material index; 5 million took 650 MB), and a decoded texel
 * (linear RGB floats). */
#define SCENES_TRIANGLE_BYTES 128
#define SCENES_TEXEL_BYTES 12

/* A scene may not build more than the whole memory budget: its triangles,
 * its decoded textures and the files and buffers it reads are held to the
 * budget (the text itself, already read, keeps --max-body), so a few bytes
 * of glTF or PNG are refused 413 with the JSON Pointer of what is too big,
 * rather than building hundreds of MB first.  The budget, not the room left
 * now, so the answer does not depend on other requests: what the room
 * allows is decided once the scene is built (scenes_reserve, 503). */
static void scenes_room(struct rayd_limits *lim)
{
    size_t room = mem_limit();
    if ((size_t)lim->max_triangles > room / SCENES_TRIANGLE_BYTES)
        lim->max_triangles = (long)(room / SCENES_TRIANGLE_BYTES);
    if (lim->max_texels <= 0 || (size_t)lim->max_texels > room / SCENES_TEXEL_BYTES)
        lim->max_texels = (long)(room / SCENES_TEXEL_BYTES) + 1; /* 0 would be the default */
    size_t floor = (size_t)config.max_body;
    if (lim->max_bytes > room)
        lim->max_bytes = room > floor ? room : floor;
}

/* Parses and builds body outside the lock, timing each stage. */
static enum rayd_status scenes_compile(const char *body, size_t len, rayd_scene **scene,
                                       struct rayd_error *err)
{
    struct rayd_limits lim;
    if (scenes_limits_set) {
        lim = scenes_limits;
    } else {
        rayd_limits_default(&lim);
        lim.max_pixels = config.max_pixels;
        if (lim.max_bytes < (size_t)config.max_body)
            lim.max_bytes = (size_t)config.max_body;
        lim.asset_dir = config.asset_dir; /* confined (asset_confine) */
    }
    scenes_room(&lim);
    metrics_scene_parse();
    double t0 = clock_now();
    enum rayd_status st = rayd_scene_parse(body, len, &lim, scene, err);
    double parsed = clock_now() - t0;
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

static size_t scenes_bytes(const rayd_scene *scene)
{
    struct rayd_scene_info info;
    rayd_scene_info(scene, &info);
    return info.bytes;
}

/* Counts a scene just compiled in the memory budget, or frees it and says
 * why not: 413 when it alone is over the budget, else 503 (no room now). */
static enum rayd_status scenes_reserve(rayd_scene *scene, struct rayd_error *err)
{
    size_t bytes = scenes_bytes(scene);
    if (mem_reserve(MEM_SCENES, bytes))
        return RAYD_OK;
    rayd_scene_free(scene);
    mem_freed(bytes); /* for mem_trim: the heap held it a moment ago */
    metrics_reject(MR_MEMORY);
    bool alone = bytes > mem_limit();
    memset(err, 0, sizeof *err);
    err->code = alone ? RAYD_E_LIMIT : RAYD_E_NOMEM;
    snprintf(err->message, sizeof err->message,
             alone ? "the compiled scene takes %zu bytes, over the memory budget of %zu bytes "
                     "(--max-memory)"
                   : "the compiled scene takes %zu bytes and the memory budget of %zu bytes "
                     "(--max-memory) has no room for it now; retry later",
             bytes, mem_limit());
    return err->code;
}

bool scenes_id(const char *body, size_t len, char id[65], struct rayd_error *err)
{
    if (cache_hash(body, len, id))
        return true;
    scenes_nomem(err, "cannot hash the scene (libcrypto)");
    return false;
}

enum rayd_status scenes_build(const char *id, const char *body, size_t len,
                              struct cache_entry **out, struct rayd_error *err)
{
    rayd_scene *scene = NULL;
    enum rayd_status st = scenes_compile(body, len, &scene, err);
    if (st != RAYD_OK)
        return st;
    st = scenes_reserve(scene, err);
    if (st != RAYD_OK)
        return st;
    char version[65];
    struct cache_entry *e = NULL;
    if (scenefiles_version(id, scene, version)) {
        pthread_mutex_lock(&work_lock);
        e = cache_put(id, version, scene);
        pthread_mutex_unlock(&work_lock);
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

void scenes_release(struct cache_entry *e)
{
    if (!e)
        return;
    pthread_mutex_lock(&work_lock);
    cache_release(e);
    pthread_mutex_unlock(&work_lock);
}

/* ---- both caches' gauges, registered with metrics.c --------------------- */

/* The bytes (or, bytes false, the entries) of the cache whose stats
 * function is given (cache.c's or rcache.c's), read under the lock that
 * both files leave to their callers. */
static long scenes_size(void (*stats)(size_t *bytes, size_t *entries), bool bytes)
{
    size_t b, n;
    pthread_mutex_lock(&work_lock);
    stats(&b, &n);
    pthread_mutex_unlock(&work_lock);
    return (long)(bytes ? b : n);
}

static long scenes_gauge_bytes(void) { return scenes_size(cache_stats, true); }
static long scenes_gauge_entries(void) { return scenes_size(cache_stats, false); }
static long scenes_gauge_rbytes(void) { return scenes_size(rcache_stats, true); }
static long scenes_gauge_rentries(void) { return scenes_size(rcache_stats, false); }

/* Sizes the scene cache and the result cache and registers their gauges:
 * here, because this file is where the caches meet the lock. */
void scenes_start(void)
{
    cache_init((size_t)config.cache_mb * 1024 * 1024);
    rcache_init((size_t)config.result_cache_mb * 1024 * 1024);
    metrics_gauge(MG_CACHE_BYTES, scenes_gauge_bytes);
    metrics_gauge(MG_CACHE_ENTRIES, scenes_gauge_entries);
    metrics_gauge(MG_RESULT_CACHE_BYTES, scenes_gauge_rbytes);
    metrics_gauge(MG_RESULT_CACHE_ENTRIES, scenes_gauge_rentries);
}
