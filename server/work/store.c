/* store.c -- the jobs on disk: SQLite for their records, files for images.
 *
 * With --data-dir DIR a job outlives the process: DIR/jobs.db (SQLite in
 * WAL mode, synchronous=FULL, so a commit is on disk when it returns) holds
 * each job's record -- who asked, its priority, the scene as it was sent and
 * the query that shaped it, and once it ended how and when -- and
 * DIR/results/ its images; a frames table (job, frame k, state, attempts,
 * file paths) holds a job's frame 0, a frame-range job's frames each.
 *
 * Nothing torn is ever served: an image is written to NAME.tmp, fsynced,
 * renamed to NAME and the folder fsynced, and only then does the frame's
 * row say "done" (one transaction with the job's end).  A kill -9 at any
 * moment leaves either the old state (the job queued: it is rendered again
 * at the next start) or the new one; at start-up a .tmp file, and a file no
 * row names as done, are deleted, and a done row is believed only when its
 * files are there with the sizes it recorded; a PNG read back is served
 * only when its chunks' CRCs match (rayd_png_whole), an EXR (which has no
 * checksum of its own) only when the CRC-32 written after it matches (the
 * files: store_file.c).  A job is inserted
 * before its 202 is sent, and a DELETE's end recorded before its 200
 * (each request waits for the commit: the work layer hands its waiter down
 * here), so no job the client was told of is lost, and none it cancelled
 * comes back.
 *
 * --max-disk bounds the images' bytes: after each write, while over it,
 * the frame that ended first is evicted (its row first, its files after,
 * so a crash in between leaves only orphans the next start deletes); the
 * job keeps its record and answers 410 result_evicted.  The latest image
 * is never evicted by its own write: a budget smaller than one image keeps
 * that one.
 *
 * SQLite and fsync block, so none of it runs on an HTTP thread: the work
 * layer queues operations here under work_lock (store_insert, store_end,
 * store_forget: a few pointers linked) and one store thread runs them in
 * order, without the lock, telling jobs.c what it did through the hooks
 * jobs.c handed it.  The one thing an HTTP thread does is store_read, a
 * plain read of a finished image's file (never written again: renamed into
 * place whole).  Opening and loading (store_open, store_load) run on the
 * main thread before the server listens, after store_dir.c took DIR's lock
 * and checked that a new jobs.db would not cost any image.
 */
#include "work/work_private.h"

#include <dirent.h>
#include <errno.h>
#include <sqlite3.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

enum store_kind { SO_INSERT, SO_END, SO_FORGET, SO_FRAME };

struct store_op {
    enum store_kind kind;
    struct store_job row;
    struct blob *png, *exr; /* SO_END: the images, referenced */
    struct work_waiter *w;  /* SO_INSERT, SO_END: told once the row is committed */
    struct store_op *next;
};

static sqlite3 *store_db;
static atomic_bool store_up; /* store_on(): from store_open to store_stop */
static int store_lock_fd = -1;
static pthread_t store_thread;
static bool store_running, store_stopping; /* lock held */
static pthread_cond_t store_cond = PTHREAD_COND_INITIALIZER;
static struct store_op *store_head, **store_tail = &store_head; /* lock held */
static size_t store_bytes; /* the store thread's (and start-up's): images on disk */
static void (*store_written)(const char *id);
static void (*store_evicted)(const char *id, const char *why, double wall);
static void (*store_frame_written)(const char *id, long k);
static void (*store_frame_evicted)(const char *id, long k, const char *why);

/* jobs.db's user_version after a clean stop (store_stop): the next start
 * counts no attempt for the jobs it finds unfinished. */
#define STORE_CLEAN_TEXT "1"
#define STORE_STOPPED_CLEANLY 1

static const char *const store_schema =
    "PRAGMA journal_mode=WAL;"
    "PRAGMA synchronous=FULL;"
    "CREATE TABLE IF NOT EXISTS jobs("
    " id TEXT PRIMARY KEY, seq INTEGER NOT NULL UNIQUE, client INTEGER NOT NULL,"
    " priority INTEGER NOT NULL, created REAL NOT NULL, state TEXT NOT NULL, ended REAL,"
    " scene BLOB NOT NULL, scene_id TEXT NOT NULL, x INTEGER, y INTEGER, w INTEGER, h INTEGER,"
    " keep_exr INTEGER, progressive INTEGER, pass_step INTEGER, time_budget REAL,"
    " noise_target REAL, tiles INTEGER, rays INTEGER, est_rays REAL, queue_ms REAL,"
    " render_ms REAL, encode_ms REAL, err_code INTEGER, err_message TEXT, err_path TEXT,"
    " evicted REAL, evicted_why TEXT);"
    "CREATE TABLE IF NOT EXISTS frames("
    " job TEXT NOT NULL REFERENCES jobs(id) ON DELETE CASCADE, k INTEGER NOT NULL,"
    " state TEXT NOT NULL, attempts INTEGER NOT NULL DEFAULT 0, path TEXT, exr_path TEXT,"
    " bytes INTEGER NOT NULL DEFAULT 0, ended REAL, PRIMARY KEY(job, k));"
    "CREATE INDEX IF NOT EXISTS jobs_client ON jobs(client, seq);"
    "CREATE INDEX IF NOT EXISTS frames_ended ON frames(state, ended);"
    "PRAGMA foreign_keys=ON;";

bool store_on(void) { return atomic_load(&store_up); }

/* ---- SQLite ------------------------------------------------------------------------ */

static const char *store_text(sqlite3_stmt *st, int col) {
    const unsigned char *t = sqlite3_column_text(st, col);
    return t ? (const char *)t : "";
}

static bool store_exec(const char *sql) {
    char *msg = NULL;
    if (sqlite3_exec(store_db, sql, NULL, NULL, &msg) == SQLITE_OK) return true;
    log_error("--data-dir %s: %s: %s", store_dir, sql, msg ? msg : "?");
    sqlite3_free(msg);
    return false;
}

/* A statement made from sql with its ? bound by fmt ('t' text, 'b' blob
 * and length, 'i' 64-bit integer, 'd' double), stepped to its first row:
 * SQLITE_ROW (the statement is the caller's: finalize it) or the error
 * (finalized). */
static int store_run(sqlite3_stmt **out, const char *sql, const char *fmt, ...) {
    sqlite3_stmt *st = NULL;
    int rc = sqlite3_prepare_v2(store_db, sql, -1, &st, NULL);
    va_list ap;
    va_start(ap, fmt);
    for (int i = 1; rc == SQLITE_OK && fmt[i - 1]; i++) {
        switch (fmt[i - 1]) {
        case 't': {
            const char *s = va_arg(ap, const char *);
            rc = s ? sqlite3_bind_text(st, i, s, -1, SQLITE_TRANSIENT) : sqlite3_bind_null(st, i);
            break;
        }
        case 'b': {
            const void *b = va_arg(ap, const void *);
            size_t n = va_arg(ap, size_t);
            rc = sqlite3_bind_blob64(st, i, b, n, SQLITE_TRANSIENT);
            break;
        }
        case 'i': rc = sqlite3_bind_int64(st, i, va_arg(ap, long long)); break;
        default: rc = sqlite3_bind_double(st, i, va_arg(ap, double));
        }
    }
    va_end(ap);
    if (rc == SQLITE_OK) rc = sqlite3_step(st);
    if (rc == SQLITE_ROW && out) {
        *out = st;
        return rc;
    }
    if (rc != SQLITE_ROW && rc != SQLITE_DONE)
        log_error("--data-dir %s: %s", store_dir, sqlite3_errmsg(store_db));
    sqlite3_finalize(st);
    return rc == SQLITE_ROW ? SQLITE_DONE : rc;
}

/* A job's state as the store writes it (jobs.c's names; an unfinished
 * job is "queued" whatever it was doing). */
static const char *const store_states[] = {"queued", "queued",   "succeeded",
                                           "failed", "canceled", "evicted"};

static const char *store_state_name(enum jobs_state s) { return store_states[s]; }

static enum jobs_state store_state_of(const char *s) {
    for (int i = JS_SUCCEEDED; i <= JS_EVICTED; i++)
        if (s && !strcmp(s, store_states[i])) return (enum jobs_state)i;
    return JS_QUEUED;
}

/* A frame-range job's range and a queued row for each of its frames. */
static bool store_insert_frames(const struct store_job *j) {
    if (store_run(NULL, "UPDATE jobs SET frame_first = ?, frame_last = ?, fps = ? WHERE id = ?",
                  "iidt", (long long)j->first, (long long)j->last, j->fps, j->id) != SQLITE_DONE)
        return false;
    for (long k = j->first; k <= j->last; k++)
        if (store_run(NULL, "INSERT OR REPLACE INTO frames(job, k, state) VALUES(?, ?, 'queued')",
                      "ti", j->id, (long long)k) != SQLITE_DONE)
            return false;
    return true;
}

/* j's rows inserted; false with SQLite's word in why (read before the
 * rollback, which would make it "not an error"). */
static bool store_insert_row(const struct store_job *j, char *why, size_t n) {
    bool ok = store_exec("BEGIN") &&
              store_run(NULL,
                        "INSERT OR REPLACE INTO jobs(id, seq, client, priority, created, state,"
                        " scene, scene_id, x, y, w, h, keep_exr, progressive, pass_step,"
                        " time_budget, noise_target, tiles, est_rays, denoise, aov)"
                        " VALUES(?, ?, ?, ?, ?, 'queued', ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?,"
                        " ?, ?)",
                        "tiiidbtiiiiiiiddidii", j->id, j->seq, (long long)j->client,
                        (long long)j->priority, j->created_wall, j->scene, j->scene_len,
                        j->scene_id, (long long)j->reg.x, (long long)j->reg.y, (long long)j->reg.w,
                        (long long)j->reg.h, (long long)j->keep_exr, (long long)j->progressive,
                        (long long)j->plan.step, j->plan.time_budget, j->plan.noise_target,
                        (long long)j->tiles, j->est_rays, (long long)j->denoise,
                        (long long)j->aov) == SQLITE_DONE &&
              (j->frames ? store_insert_frames(j)
                         : store_run(NULL,
                                     "INSERT OR REPLACE INTO frames(job, k, state)"
                                     " VALUES(?, 0, 'queued')",
                                     "t", j->id) == SQLITE_DONE) &&
              store_exec("COMMIT");
    if (!ok) {
        snprintf(why, n, "%s", sqlite3_errmsg(store_db));
        store_exec("ROLLBACK");
    }
    return ok;
}

/* The job's end, and its frame's files once they are in place. */
static bool store_end_row(const struct store_job *j, size_t bytes, bool png, bool exr) {
    const char *fstate = j->state == JS_SUCCEEDED ? "done" : store_state_name(j->state);
    char p[80], e[80];
    snprintf(p, sizeof p, "results/%s.png", j->id);
    snprintf(e, sizeof e, "results/%s.exr", j->id);
    bool ok =
        store_exec("BEGIN") &&
        store_run(NULL,
                  "UPDATE jobs SET state = ?, ended = ?, tiles = ?, rays = ?, queue_ms = ?,"
                  " render_ms = ?, encode_ms = ?, err_code = ?, err_message = ?,"
                  " err_path = ? WHERE id = ?",
                  "tdiidddittt", store_state_name(j->state), j->ended_wall, (long long)j->tiles,
                  (long long)j->rays, j->queue_ms, j->render_ms, j->encode_ms,
                  (long long)j->err.code, j->err.message, j->err.path, j->id) == SQLITE_DONE &&
        (j->frames || store_run(NULL,
                                "UPDATE frames SET state = ?, path = ?, exr_path = ?, bytes = ?,"
                                " ended = ? WHERE job = ? AND k = 0",
                                "tttidt", fstate, png ? p : NULL, exr ? e : NULL, (long long)bytes,
                                j->ended_wall, j->id) == SQLITE_DONE) &&
        store_exec("COMMIT");
    if (!ok) store_exec("ROLLBACK");
    return ok;
}

/* The files of job id's frame k (-1: a one-image job's), unlinked. */
static void store_unlink(const char *id, long k) {
    char path[4200];
    store_path(path, sizeof path, id, k, false, false);
    unlink(path);
    store_path(path, sizeof path, id, k, true, false);
    unlink(path);
}

/* Frame k of frame-range job id evicted by --max-disk: its row first,
 * its files after (a crash between leaves orphans the next start deletes). */
static bool store_evict_frame(const char *id, long k, const char *why) {
    sqlite3_stmt *st = NULL;
    char p[4200] = "", e[4200] = "";
    if (store_run(&st, "SELECT path, exr_path FROM frames WHERE job = ? AND k = ?", "ti", id,
                  (long long)k) == SQLITE_ROW) {
        if (store_text(st, 0)[0]) snprintf(p, sizeof p, "%s/%s", store_dir, store_text(st, 0));
        if (store_text(st, 1)[0]) snprintf(e, sizeof e, "%s/%s", store_dir, store_text(st, 1));
        sqlite3_finalize(st);
    }
    if (store_run(NULL,
                  "UPDATE frames SET state = 'evicted', path = NULL, exr_path = NULL, bytes = 0"
                  " WHERE job = ? AND k = ?",
                  "ti", id, (long long)k) != SQLITE_DONE)
        return false;
    if (p[0] && !strstr(p + strlen(store_dir), "..")) unlink(p);
    if (e[0] && !strstr(e + strlen(store_dir), "..")) unlink(e);
    log_info("job %s: frame %ld was evicted (%s)", id, k, why);
    if (store_frame_evicted) store_frame_evicted(id, k, why);
    return true;
}

/* A plain job's image evicted by --max-disk: its row, then its files. */
static bool store_evict_job(const char *id, const char *why) {
    double now = (double)time(NULL);
    bool ok = store_exec("BEGIN") &&
              store_run(NULL,
                        "UPDATE frames SET state = 'evicted', path = NULL, exr_path = NULL,"
                        " bytes = 0 WHERE job = ? AND k = 0",
                        "t", id) == SQLITE_DONE &&
              store_run(NULL, "UPDATE jobs SET evicted = ?, evicted_why = ? WHERE id = ?", "dtt",
                        now, why, id) == SQLITE_DONE &&
              store_exec("COMMIT");
    if (!ok) {
        store_exec("ROLLBACK");
        return false;
    }
    store_unlink(id, -1);
    log_info("job %s: its result was evicted (%s)", id, why);
    if (store_evicted) store_evicted(id, why, now);
    return true;
}

/* --max-disk: evicts the images that ended first -- a plain job's, or one
 * frame of a frame-range job's -- never keep's (the write just made: job
 * keep, frame keep_k; 0 for a plain job), while over the budget. */
static void store_evict(const char *keep, long keep_k) {
    static const char why[] = "over --max-disk: the oldest finished results are evicted first";
    while (config.max_disk_bytes > 0 && store_bytes > config.max_disk_bytes) {
        sqlite3_stmt *st = NULL;
        if (store_run(&st,
                      "SELECT f.job, f.k, f.bytes, j.frame_first IS NOT NULL FROM frames f"
                      " JOIN jobs j ON j.id = f.job WHERE f.state = 'done'"
                      " AND NOT (f.job = ? AND f.k = ?) ORDER BY f.ended, f.rowid LIMIT 1",
                      "ti", keep, (long long)keep_k) != SQLITE_ROW)
            return;
        char id[33];
        snprintf(id, sizeof id, "%s", store_text(st, 0));
        long k = (long)sqlite3_column_int64(st, 1);
        size_t bytes = (size_t)sqlite3_column_int64(st, 2);
        bool frame = sqlite3_column_int(st, 3) != 0;
        sqlite3_finalize(st);
        if (!(frame ? store_evict_frame(id, k, why) : store_evict_job(id, why))) return;
        store_bytes -= bytes < store_bytes ? bytes : store_bytes;
    }
}

/* ---- the store thread ------------------------------------------------------------- */

/* A job's end: its images written whole, then its row; false when it is
 * not recorded (said in the log). */
static bool store_do_end(struct store_op *op) {
    struct store_job *j = &op->row;
    bool ok = true;
    size_t bytes = 0;
    if (op->png) {
        ok = store_write_file(j->id, -1, false, op->png) == 0;
        bytes += op->png->len;
    }
    if (ok && op->exr) {
        ok = store_write_file(j->id, -1, true, op->exr) == 0;
        bytes += store_file_bytes(op->exr, true);
    }
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/results", store_dir);
    if (ok && (op->png || op->exr)) ok = store_fsync_dir(dir) == 0;
    if (!ok) {
        log_error("job %s: cannot write its image under --data-dir %s: %s (it stays on this "
                  "process's memory only)",
                  j->id, store_dir, strerror(errno));
        return false;
    }
    if (!store_end_row(j, bytes, op->png != NULL, op->exr != NULL)) return false;
    store_bytes += bytes;
    if (bytes && store_written) store_written(j->id);
    if (bytes) store_evict(j->id, 0);
    return true;
}

/* Now, seconds since the epoch to the microsecond: frames that end in the
 * same second are evicted in the order they ended. */
static double store_wall(void) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

/* Frame k of a frame-range job (op->row.first): its files written whole,
 * then its row says done. */
static void store_do_frame(struct store_op *op) {
    const char *id = op->row.id;
    long k = op->row.first;
    size_t bytes = op->png->len + (op->exr ? store_file_bytes(op->exr, true) : 0);
    char dir[4200], p[96], e[96];
    snprintf(dir, sizeof dir, "%s/results", store_dir);
    snprintf(p, sizeof p, "results/%s-%ld.png", id, k);
    snprintf(e, sizeof e, "results/%s-%ld.exr", id, k);
    bool ok = store_write_file(id, k, false, op->png) == 0 &&
              (!op->exr || store_write_file(id, k, true, op->exr) == 0) &&
              store_fsync_dir(dir) == 0;
    if (!ok) {
        log_error("job %s: cannot write frame %ld under --data-dir %s: %s", id, k, store_dir,
                  strerror(errno));
        return;
    }
    /* the frame done, and in the same commit its job's frames left counting
     * kills from zero again: the job went on, so the kills so far are no
     * sign that it kills rayd (durable.c) */
    bool done =
        store_exec("BEGIN") &&
        store_run(NULL,
                  "UPDATE frames SET state = 'done', path = ?, exr_path = ?, bytes = ?, ended = ?"
                  " WHERE job = ? AND k = ?",
                  "ttidti", p, op->exr ? e : NULL, (long long)bytes, store_wall(), id,
                  (long long)k) == SQLITE_DONE &&
        store_run(NULL, "UPDATE frames SET attempts = 0 WHERE job = ? AND state = 'queued'", "t",
                  id) == SQLITE_DONE &&
        store_run(NULL,
                  "UPDATE jobs SET tiles = ?, rays = ?, queue_ms = ?, render_ms = ?, encode_ms = ?"
                  " WHERE id = ?",
                  "iidddt", (long long)op->row.tiles, (long long)op->row.rays, op->row.queue_ms,
                  op->row.render_ms, op->row.encode_ms, id) == SQLITE_DONE &&
        store_exec("COMMIT");
    if (!done) {
        store_exec("ROLLBACK");
        return;
    }
    store_bytes += bytes;
    if (store_frame_written) store_frame_written(id, k);
    store_evict(id, k);
}

/* A job forgotten (--job-ttl, --max-jobs): its rows deleted in one commit,
 * and only then its files (every frame's), so a kill in between leaves
 * orphans the next start sweeps, never a done row whose files are gone --
 * which the next start would render again, the forgotten job back. */
static void store_do_forget(const char *id) {
    sqlite3_stmt *st = NULL;
    size_t bytes = 0;
    long first = 0, last = -1;
    if (store_run(&st,
                  "SELECT (SELECT COALESCE(SUM(bytes), 0) FROM frames WHERE job = ?1 AND"
                  " state = 'done'), frame_first, frame_last FROM jobs WHERE id = ?1",
                  "t", id) == SQLITE_ROW) {
        bytes = (size_t)sqlite3_column_int64(st, 0);
        if (sqlite3_column_type(st, 1) != SQLITE_NULL) /* a frame-range job */
            first = (long)sqlite3_column_int64(st, 1), last = (long)sqlite3_column_int64(st, 2);
        sqlite3_finalize(st);
    }
    bool ok = store_exec("BEGIN") &&
              store_run(NULL, "DELETE FROM frames WHERE job = ?", "t", id) == SQLITE_DONE &&
              store_run(NULL, "DELETE FROM jobs WHERE id = ?", "t", id) == SQLITE_DONE &&
              store_exec("COMMIT");
    if (!ok) {
        store_exec("ROLLBACK");
        return;
    }
    store_unlink(id, -1);
    for (long k = first; k <= last; k++) store_unlink(id, k);
    store_bytes -= bytes < store_bytes ? bytes : store_bytes;
}

/* Runs op; its waiter (a POST's insert, a DELETE's end) is told after. */
static void store_do(struct store_op *op) {
    char why[200] = "its end: see the server's log";
    bool ok = true;
    if (op->kind == SO_FRAME) store_do_frame(op);
    if (op->kind == SO_INSERT) ok = store_insert_row(&op->row, why, sizeof why);
    if (op->kind == SO_END) ok = store_do_end(op);
    if (op->kind == SO_FORGET) store_do_forget(op->row.id);
    struct work_result res = {.status = ok ? RAYD_OK : RAYD_E_IO};
    if (!ok)
        snprintf(res.err.message, sizeof res.err.message,
                 "the job could not be recorded under --data-dir: %s", why);
    if (op->w) op->w->done(op->w, &res);
}

static void store_op_free(struct store_op *op) {
    blob_unref(op->png);
    blob_unref(op->exr);
    free(op->row.scene);
    free(op);
}

static void *store_main(void *arg) {
    (void)arg;
    work_lock_take();
    for (;;) {
        while (!store_head && !store_stopping) work_wait(&store_cond);
        struct store_op *ops = store_head;
        store_head = NULL;
        store_tail = &store_head;
        if (!ops && store_stopping) break;
        work_lock_give();
        while (ops) {
            struct store_op *next = ops->next;
            store_do(ops);
            store_op_free(ops);
            ops = next;
        }
        work_lock_take();
    }
    work_lock_give();
    return NULL;
}

/* Links op (lock held); without a store (rayd stops: the job stays as it
 * was on disk) it is dropped. */
static void store_queue(struct store_op *op) {
    if (store_stopping || !store_running) {
        store_op_free(op);
        return;
    }
    op->next = NULL;
    *store_tail = op;
    store_tail = &op->next;
    pthread_cond_signal(&store_cond);
}

bool store_insert(struct store_job *row, struct work_waiter *w) {
    struct store_op *op = store_stopping || !store_running ? NULL : calloc(1, sizeof *op);
    if (!op) return false;
    op->kind = SO_INSERT;
    op->row = *row;
    row->scene = NULL; /* the op's now */
    op->w = w;
    if (w) w->suspend(w);
    store_queue(op);
    return true;
}

bool store_end(const struct store_job *row, struct blob *png, struct blob *exr,
               struct work_waiter *w) {
    if (store_stopping || !store_running) return false; /* the job stays as it is on disk */
    struct store_op *op = calloc(1, sizeof *op);
    if (!op) {
        log_error("job %s: out of memory to record its end under --data-dir", row->id);
        return false;
    }
    op->kind = SO_END;
    op->row = *row;
    op->row.scene = NULL;
    op->png = blob_ref(png), op->exr = blob_ref(exr);
    op->w = w;
    if (w) w->suspend(w);
    store_queue(op);
    return w != NULL;
}

void store_frame(const struct store_job *row, long k, struct blob *png, struct blob *exr) {
    struct store_op *op = calloc(1, sizeof *op);
    if (!op) {
        log_error("job %s: out of memory to record frame %ld under --data-dir", row->id, k);
        return;
    }
    op->kind = SO_FRAME;
    op->row = *row; /* its id and figures */
    op->row.scene = NULL;
    op->row.first = k;
    op->png = blob_ref(png);
    op->exr = blob_ref(exr);
    store_queue(op);
}

void store_forget(const char *id) {
    struct store_op *op = calloc(1, sizeof *op);
    if (!op) return;
    op->kind = SO_FORGET;
    snprintf(op->row.id, sizeof op->row.id, "%s", id);
    store_queue(op);
}

void store_hooks(void (*written)(const char *id),
                 void (*evicted)(const char *id, const char *why, double wall)) {
    store_written = written;
    store_evicted = evicted;
}

void store_frame_hooks(void (*written)(const char *id, long k),
                       void (*evicted)(const char *id, long k, const char *why)) {
    store_frame_written = written;
    store_frame_evicted = evicted;
}

/* ---- start-up ---------------------------------------------------------------------- */

/* jobs.db could not be read (damaged): said on stderr; rayd does not start
 * on it, and nothing of DIR is deleted on the word of a store it cannot read. */
static void store_damaged(const char *what) {
    fprintf(stderr,
            "rayd: error: --data-dir %s: jobs.db cannot be read (%s: %s); rayd does not start "
            "on it and deletes nothing: restore jobs.db from a backup, or move DIR away\n",
            store_dir, what, sqlite3_errmsg(store_db));
}

/* Deletes what a kill left under results/: .tmp files, and files no done
 * frame names.  -1 (nothing more deleted) when jobs.db cannot be read. */
static int store_sweep(void) {
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/results", store_dir);
    DIR *d = opendir(dir);
    if (!d) return 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        char id[33] = "";
        size_t n = strlen(e->d_name);
        bool tmp = n > 4 && !strcmp(e->d_name + n - 4, ".tmp");
        bool known = false;
        if (!tmp && n > 32) {
            memcpy(id, e->d_name, 32);
            char rel[300];
            snprintf(rel, sizeof rel, "results/%s", e->d_name);
            sqlite3_stmt *st = NULL;
            int rc = store_run(&st,
                               "SELECT 1 FROM frames WHERE job = ? AND state = 'done' AND"
                               " (path = ? OR exr_path = ?)",
                               "ttt", id, rel, rel);
            known = rc == SQLITE_ROW;
            if (known) sqlite3_finalize(st);
            if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
                closedir(d);
                store_damaged("looking up the files under results/");
                return -1;
            }
        }
        if (!known) {
            unlinkat(dirfd(d), e->d_name, 0);
            log_info("--data-dir: deleted %s/%s (%s)", dir, e->d_name,
                     tmp ? "a write cut short" : "no job names it");
        }
    }
    closedir(d);
    return 0;
}

int store_open(const char *dir) {
    char path[4200];
    store_dir = strdup(dir);
    if (!store_dir) return -1;
    store_lock_fd = store_dir_lock(dir);
    if (store_lock_fd < 0 || store_dir_check(dir)) return -1;
    snprintf(path, sizeof path, "%s/jobs.db", dir);
    if (sqlite3_open_v2(path, &store_db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, NULL) !=
            SQLITE_OK ||
        sqlite3_busy_timeout(store_db, 5000) != SQLITE_OK) {
        fprintf(stderr, "rayd: error: --data-dir %s: cannot open jobs.db: %s\n", dir,
                store_db ? sqlite3_errmsg(store_db) : "out of memory");
        sqlite3_close(store_db);
        store_db = NULL;
        return -1;
    }
    if (!store_exec(store_schema)) {
        fprintf(stderr,
                "rayd: error: --data-dir %s: jobs.db is not a rayd store (or is "
                "damaged)\n",
                dir);
        sqlite3_close(store_db);
        store_db = NULL;
        return -1;
    }
    /* a frame-range job's range (NULL: a plain job); added to a store of before */
    sqlite3_exec(store_db, "ALTER TABLE jobs ADD COLUMN frame_first INTEGER", NULL, NULL, NULL);
    sqlite3_exec(store_db, "ALTER TABLE jobs ADD COLUMN frame_last INTEGER", NULL, NULL, NULL);
    sqlite3_exec(store_db, "ALTER TABLE jobs ADD COLUMN fps REAL", NULL, NULL, NULL);
    /* a job's ?denoise= and ?aov= (NULL in a store of before them: neither) */
    sqlite3_exec(store_db, "ALTER TABLE jobs ADD COLUMN denoise INTEGER", NULL, NULL, NULL);
    sqlite3_exec(store_db, "ALTER TABLE jobs ADD COLUMN aov INTEGER", NULL, NULL, NULL);
    if (store_sweep()) {
        sqlite3_close(store_db);
        store_db = NULL;
        return -1;
    }
    atomic_store(&store_up, true);
    sqlite3_stmt *st = NULL;
    if (store_run(&st, "SELECT COALESCE(SUM(bytes), 0) FROM frames WHERE state = 'done'", "") ==
        SQLITE_ROW) {
        store_bytes = (size_t)sqlite3_column_int64(st, 0);
        sqlite3_finalize(st);
    }
    /* a --max-disk lowered since the last run: kept from the start (the newest image stays) */
    if (config.max_disk_bytes > 0 && store_bytes > config.max_disk_bytes &&
        store_run(&st,
                  "SELECT job, k FROM frames WHERE state = 'done' ORDER BY ended DESC, rowid DESC"
                  " LIMIT 1",
                  "") == SQLITE_ROW) {
        char keep[33];
        snprintf(keep, sizeof keep, "%s", store_text(st, 0));
        long keep_k = (long)sqlite3_column_int64(st, 1);
        sqlite3_finalize(st);
        store_evict(keep, keep_k);
    }
    return 0;
}

int store_start(void) {
    if (!store_db) return 0;
    if (pthread_create(&store_thread, NULL, store_main, NULL)) return -1;
    work_lock_take();
    store_running = true;
    work_lock_give();
    return 0;
}

/* A done row's files, there with the bytes it recorded? */
static bool store_files_ok(const char *id, long k, bool exr, long long bytes) {
    char path[4200];
    struct stat st;
    long long have = 0;
    store_path(path, sizeof path, id, k, false, false);
    if (stat(path, &st) != 0) return false;
    have += st.st_size;
    if (exr) {
        store_path(path, sizeof path, id, k, true, false);
        if (stat(path, &st) != 0) return false;
        have += st.st_size;
    }
    return have == bytes;
}

/* One row of store_load's query into j. */
static bool store_row(sqlite3_stmt *st, struct store_job *j) {
    memset(j, 0, sizeof *j);
    snprintf(j->id, sizeof j->id, "%s", store_text(st, 0));
    j->seq = sqlite3_column_int64(st, 1);
    j->client = (uint64_t)sqlite3_column_int64(st, 2);
    j->priority = sqlite3_column_int(st, 3);
    j->created_wall = sqlite3_column_double(st, 4);
    j->state = store_state_of(store_text(st, 5));
    j->ended_wall = sqlite3_column_double(st, 6);
    int n = sqlite3_column_bytes(st, 7);
    j->scene = malloc((size_t)n + 1);
    if (!j->scene) return false;
    memcpy(j->scene, sqlite3_column_blob(st, 7), (size_t)n);
    j->scene[n] = 0;
    j->scene_len = (size_t)n;
    snprintf(j->scene_id, sizeof j->scene_id, "%s", store_text(st, 8));
    j->reg = (struct rayd_region){sqlite3_column_int(st, 9), sqlite3_column_int(st, 10),
                                  sqlite3_column_int(st, 11), sqlite3_column_int(st, 12)};
    j->keep_exr = sqlite3_column_int(st, 13);
    j->progressive = sqlite3_column_int(st, 14);
    j->plan.step = sqlite3_column_int(st, 15);
    j->plan.time_budget = sqlite3_column_double(st, 16);
    j->plan.noise_target = sqlite3_column_double(st, 17);
    j->tiles = sqlite3_column_int64(st, 18);
    j->rays = (uint64_t)sqlite3_column_int64(st, 19);
    j->est_rays = sqlite3_column_double(st, 20);
    j->queue_ms = sqlite3_column_double(st, 21);
    j->render_ms = sqlite3_column_double(st, 22);
    j->encode_ms = sqlite3_column_double(st, 23);
    j->err.code = (enum rayd_status)sqlite3_column_int(st, 24);
    snprintf(j->err.message, sizeof j->err.message, "%s", store_text(st, 25));
    snprintf(j->err.path, sizeof j->err.path, "%s", store_text(st, 26));
    j->evicted_wall = sqlite3_column_double(st, 27);
    snprintf(j->evicted_why, sizeof j->evicted_why, "%s", store_text(st, 28));
    const char *fstate = store_text(st, 29);
    j->attempts = sqlite3_column_int(st, 30);
    bool has_exr = sqlite3_column_type(st, 31) != SQLITE_NULL;
    long long bytes = sqlite3_column_int64(st, 32);
    j->denoise = sqlite3_column_int(st, 36); /* NULL (a store before them): 0 */
    j->aov = (unsigned)sqlite3_column_int(st, 37);
    j->frames = sqlite3_column_type(st, 33) != SQLITE_NULL;
    if (j->frames) { /* a frame-range job: its frames are store_load_frames' */
        j->first = sqlite3_column_int64(st, 33);
        j->last = sqlite3_column_int64(st, 34);
        j->fps = sqlite3_column_double(st, 35);
        return true;
    }
    j->result_ok = !strcmp(fstate, "done") && store_files_ok(j->id, -1, has_exr, bytes);
    if (j->state == JS_SUCCEEDED && !strcmp(fstate, "done") && !j->result_ok) {
        log_warn("job %s: its image files are missing or not whole: it renders again", j->id);
        j->state = JS_QUEUED;
    }
    return true;
}

/* Whether a job's row is one rayd wrote: its id 32 hex digits (it names
 * the job's files: a row of another id could name any file, and its
 * expiry delete it) and a frame range within what a job may ask
 * (--max-frames).  Else it is left out, said in the log. */
static bool store_row_sane(const struct store_job *j) {
    bool hex = strlen(j->id) == 32 && strspn(j->id, "0123456789abcdef") == 32;
    bool frames = !j->frames || (j->first >= 0 && j->first <= j->last && j->last <= 1000000 &&
                                 j->last - j->first + 1 <= config.max_frames);
    if (hex && frames) return true;
    char safe[40];
    snprintf(safe, sizeof safe, "%.32s", j->id);
    for (char *c = safe; *c; c++)
        if (*c < 0x20 || *c > 0x7e) *c = '?';
    log_warn("--data-dir: the job row '%s' is left out: %s", safe,
             !hex ? "its id is not 32 hex digits" : "its frames are past --max-frames");
    return false;
}

int store_load(struct store_job **rows, int *n) {
    *rows = NULL;
    *n = 0;
    if (!store_db) return 0;
    /* each unfinished frame is an attempt more from now on -- unless the
     * last rayd stopped cleanly (store_stop): a drain is no attempt, and a
     * job queued through five deploys must not fail for them */
    sqlite3_stmt *clean = NULL;
    bool drained = store_run(&clean, "PRAGMA user_version", "") == SQLITE_ROW &&
                   sqlite3_column_int(clean, 0) == STORE_STOPPED_CLEANLY;
    sqlite3_finalize(clean);
    if (!drained)
        store_run(NULL, "UPDATE frames SET attempts = attempts + 1 WHERE state = 'queued'", "");
    store_exec("PRAGMA user_version = 0"); /* a kill from now on is an attempt */
    sqlite3_stmt *st = NULL;
    int rc = sqlite3_prepare_v2(
        store_db,
        "SELECT j.id, j.seq, j.client, j.priority, j.created, j.state, j.ended, j.scene,"
        " j.scene_id, j.x, j.y, j.w, j.h, j.keep_exr, j.progressive, j.pass_step, j.time_budget,"
        " j.noise_target, j.tiles, j.rays, j.est_rays, j.queue_ms, j.render_ms, j.encode_ms,"
        " j.err_code, j.err_message, j.err_path, j.evicted, j.evicted_why, f.state,"
        " COALESCE((SELECT MAX(attempts) FROM frames q WHERE q.job = j.id AND"
        " q.state = 'queued'), f.attempts),"
        " f.exr_path, f.bytes, j.frame_first, j.frame_last, j.fps, j.denoise, j.aov"
        " FROM jobs j LEFT JOIN frames f ON f.job = j.id AND f.k = 0"
        " ORDER BY j.seq",
        -1, &st, NULL);
    int cap = 0, step = SQLITE_DONE;
    while (rc == SQLITE_OK && (step = sqlite3_step(st)) == SQLITE_ROW) {
        if (*n == cap) {
            cap = cap ? 2 * cap : 64;
            struct store_job *more = realloc(*rows, (size_t)cap * sizeof **rows);
            if (!more) break;
            *rows = more;
        }
        if (!store_row(st, &(*rows)[*n])) break;
        if (!store_row_sane(&(*rows)[*n])) {
            free((*rows)[*n].scene);
            continue;
        }
        (*n)++;
    }
    sqlite3_finalize(st);
    if (rc != SQLITE_OK || (step != SQLITE_ROW && step != SQLITE_DONE)) {
        store_damaged("reading the jobs");
        return -1;
    }
    return 0;
}

int store_load_frames(const struct store_job *j, unsigned char *states) {
    memset(states, STORE_FRAME_QUEUED, (size_t)(j->last - j->first + 1));
    sqlite3_stmt *st = NULL;
    if (sqlite3_prepare_v2(store_db, "SELECT k, state, exr_path, bytes FROM frames WHERE job = ?",
                           -1, &st, NULL) != SQLITE_OK) {
        store_damaged("reading a frame-range job's frames");
        return -1;
    }
    sqlite3_bind_text(st, 1, j->id, -1, SQLITE_TRANSIENT);
    int done = 0, step;
    while ((step = sqlite3_step(st)) == SQLITE_ROW) {
        long k = sqlite3_column_int64(st, 0);
        const char *state = store_text(st, 1);
        if (k < j->first || k > j->last) continue;
        bool exr = sqlite3_column_type(st, 2) != SQLITE_NULL;
        if (!strcmp(state, "done") && store_files_ok(j->id, k, exr, sqlite3_column_int64(st, 3))) {
            states[k - j->first] = STORE_FRAME_DONE;
            done++;
        } else if (!strcmp(state, "evicted")) {
            states[k - j->first] = STORE_FRAME_EVICTED;
        } else if (!strcmp(state, "done")) {
            log_warn("job %s: frame %ld's files are missing or not whole: it renders again", j->id,
                     k);
        }
    }
    sqlite3_finalize(st);
    if (step != SQLITE_DONE) {
        store_damaged("reading a frame-range job's frames");
        return -1;
    }
    return done;
}

void store_rows_free(struct store_job *rows, int n) {
    for (int i = 0; i < n; i++) free(rows[i].scene);
    free(rows);
}

void store_stop(void) {
    atomic_store(&store_up, false);
    if (store_running) {
        work_lock_take();
        store_stopping = true;
        pthread_cond_signal(&store_cond);
        work_lock_give();
        pthread_join(store_thread, NULL);
        store_running = false;
        if (store_db) store_exec("PRAGMA user_version = " STORE_CLEAN_TEXT);
    }
    if (store_db) sqlite3_close(store_db);
    store_db = NULL;
    if (store_lock_fd >= 0) close(store_lock_fd);
    store_lock_fd = -1;
    free(store_dir);
    store_dir = NULL;
}
