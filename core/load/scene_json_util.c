/* scene_json_util.c -- the typed getters of the scene loader.  Each getter
 * reads one key, checks its type and range, and on failure names the value
 * by its JSON Pointer (json_pointer.h) with a message that says what is
 * wrong.
 */
#define _GNU_SOURCE /* realpath, syscall (openat2) */
#include <errno.h>
#include <fcntl.h>
#include <linux/openat2.h>
#include <stdint.h>
#include <sys/syscall.h>
#include <unistd.h>
#include <stdarg.h>
#include <sys/stat.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "load/scene_json_util.h"
#include "base/hugemem.h"
#include "format/mesh_io.h"
#include "scene/scene_files.h"
#include "shade/texture.h"

long sj_max_texels(const struct loader *ld) {
    long m = ld->lim->max_texels;
    return m > 0 && m < TEXTURE_MAX_SCENE_PIXELS ? m : TEXTURE_MAX_SCENE_PIXELS;
}

/* The loader's charge hook as format/mesh_io's, whose mesh_charge and
 * mesh_give_back make the calls. */
static struct mesh_limits sj_hook(const struct loader *ld) {
    return (struct mesh_limits){.charge = ld->lim->charge, .charge_arg = ld->lim->charge_arg};
}

enum rayd_status sj_charge(struct loader *ld, const struct jp *at, size_t bytes) {
    struct mesh_limits hook = sj_hook(ld);
    size_t charged = 0;
    char why[200];
    enum rayd_status st = mesh_charge(&hook, &charged, bytes, why, sizeof why);
    return st == RAYD_OK ? RAYD_OK : sj_fail(ld, st, at, "%s", why);
}

void sj_give_back(struct loader *ld, size_t bytes) {
    struct mesh_limits hook = sj_hook(ld);
    size_t charged = bytes;
    mesh_give_back(&hook, &charged, bytes);
}

const char *sj_type_name(const cJSON *v) {
    if (cJSON_IsNumber(v)) return "a number";
    if (cJSON_IsString(v)) return "a string";
    if (cJSON_IsBool(v)) return "a boolean";
    if (cJSON_IsNull(v)) return "null";
    if (cJSON_IsArray(v)) return "an array";
    return "an object";
}

enum rayd_status sj_fail(struct loader *ld, enum rayd_status code, const struct jp *at,
                         const char *fmt, ...) {
    char msg[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return err_set(ld->err, code, at->s, "%s", msg);
}

static int cmp_names(const void *a, const void *b) {
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* Every key of obj must be in allowed (NULL-terminated; NULL = any key) and
 * appear once. */
enum rayd_status sj_check_keys(struct loader *ld, const cJSON *obj, const struct jp *at,
                               const char *const *allowed) {
    if (!cJSON_IsObject(obj))
        return sj_fail(ld, RAYD_E_INVALID, at, "must be an object, not %s", sj_type_name(obj));
    int n = 0;
    for (const cJSON *c = obj->child; c; c = c->next) {
        n++;
        if (!allowed) continue;
        const char *const *a = allowed;
        while (*a && strcmp(*a, c->string) != 0) a++;
        if (*a) continue;
        char list[200] = "";
        for (a = allowed; *a; a++) {
            strncat(list, *a, sizeof list - strlen(list) - 1);
            if (a[1]) strncat(list, ", ", sizeof list - strlen(list) - 1);
        }
        struct jp p = jp_key(at, c->string);
        return sj_fail(ld, RAYD_E_INVALID, &p, "unknown key (allowed here: %s)", list);
    }
    if (n < 2) return RAYD_OK;
    const char **names = malloc(sizeof *names * (size_t)n);
    if (!names) return err_set(ld->err, RAYD_E_NOMEM, at->s, "out of memory");
    int i = 0;
    for (const cJSON *c = obj->child; c; c = c->next) names[i++] = c->string;
    qsort(names, (size_t)n, sizeof *names, cmp_names);
    for (i = 1; i < n && strcmp(names[i - 1], names[i]) != 0; i++) continue;
    enum rayd_status st = RAYD_OK;
    if (i < n) {
        struct jp p = jp_key(at, names[i]);
        st = sj_fail(ld, RAYD_E_INVALID, &p, "duplicate key");
    }
    free(names);
    return st;
}

/* A number in [lo, hi] (lo excluded when lo_open). */
enum rayd_status sj_num(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                        double def, double lo, bool lo_open, double hi, double *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) {
        *out = def;
        return RAYD_OK;
    }
    struct jp p = jp_key(at, key);
    if (!cJSON_IsNumber(v))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be a number, not %s", sj_type_name(v));
    double x = v->valuedouble;
    if (!isfinite(x)) return sj_fail(ld, RAYD_E_INVALID, &p, "must be a finite number");
    if (lo_open && !(x > lo)) return sj_fail(ld, RAYD_E_INVALID, &p, "must be > %g", lo);
    if (!lo_open && x < lo) return sj_fail(ld, RAYD_E_INVALID, &p, "must be >= %g", lo);
    if (x > hi) return sj_fail(ld, RAYD_E_INVALID, &p, "must be <= %g", hi);
    *out = x;
    return RAYD_OK;
}

/* A whole number in [lo, hi]; above hi is a limit (RAYD_E_LIMIT) when
 * hi_is_limit, else invalid. */
enum rayd_status sj_int(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                        long def, long lo, long hi, bool hi_is_limit, long *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) {
        *out = def;
        return RAYD_OK;
    }
    struct jp p = jp_key(at, key);
    if (!cJSON_IsNumber(v))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be an integer, not %s", sj_type_name(v));
    double x = v->valuedouble;
    if (!isfinite(x)) return sj_fail(ld, RAYD_E_INVALID, &p, "must be a finite number");
    if (floor(x) != x) return sj_fail(ld, RAYD_E_INVALID, &p, "must be an integer");
    if (lo == hi && x != (double)lo) return sj_fail(ld, RAYD_E_INVALID, &p, "must be %ld", lo);
    if (x < (double)lo) return sj_fail(ld, RAYD_E_INVALID, &p, "must be >= %ld", lo);
    if (x > (double)hi)
        return sj_fail(ld, hi_is_limit ? RAYD_E_LIMIT : RAYD_E_INVALID, &p,
                       hi_is_limit ? "must be <= %ld (the limit)" : "must be <= %ld", hi);
    *out = (long)x;
    return RAYD_OK;
}

enum rayd_status sj_item_num(struct loader *ld, const cJSON *e, const struct jp *p, int i,
                             double max, const char *range, double *out) {
    if (cJSON_IsNumber(e) && isfinite(e->valuedouble) && fabs(e->valuedouble) <= max) {
        *out = e->valuedouble;
        return RAYD_OK;
    }
    struct jp pe = jp_index(p, i);
    if (!cJSON_IsNumber(e))
        return sj_fail(ld, RAYD_E_INVALID, &pe, "must be a number, not %s", sj_type_name(e));
    if (!isfinite(e->valuedouble))
        return sj_fail(ld, RAYD_E_INVALID, &pe, "must be a finite number");
    return sj_fail(ld, RAYD_E_INVALID, &pe, "must be in %s", range);
}

enum rayd_status sj_vec_value(struct loader *ld, const cJSON *v, const struct jp *p,
                              enum vec_rule rule, vec3 *out) {
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return sj_fail(ld, RAYD_E_INVALID, p, "must be an array of 3 numbers");
    double c[3] = {0, 0, 0}; /* all three set: the size is checked above */
    int i = 0;
    for (const cJSON *e = v->child; e && i < 3; e = e->next, i++) {
        TRY(sj_item_num(ld, e, p, i, NUM_MAX, NUM_RANGE, &c[i]));
        if (rule == VEC_COLOR && c[i] < 0) {
            struct jp pe = jp_index(p, i);
            return sj_fail(ld, RAYD_E_INVALID, &pe, "must be >= 0");
        }
    }
    *out = v3(c[0], c[1], c[2]);
    if (rule == VEC_NONZERO && !(v3_len(*out) > 0))
        return sj_fail(ld, RAYD_E_INVALID, p, "must not be a zero-length vector");
    return RAYD_OK;
}

enum rayd_status sj_vec(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                        vec3 def, enum vec_rule rule, vec3 *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) {
        *out = def;
        return RAYD_OK;
    }
    struct jp p = jp_key(at, key);
    return sj_vec_value(ld, v, &p, rule, out);
}

/* ---- lights ----------------------------------------------------------------- */

/* A string key that must be one of the names in types: *out its index. */
enum rayd_status sj_enum(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                         const char *const *types, int *out) {
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(obj, key);
    struct jp p = jp_key(at, key);
    *out = -1;
    if (!t) return RAYD_OK;
    if (!cJSON_IsString(t))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be a string, not %s", sj_type_name(t));
    char list[160] = "";
    for (int i = 0; types[i]; i++) {
        if (strcmp(types[i], t->valuestring) == 0) {
            *out = i;
            return RAYD_OK;
        }
        strncat(list, types[i], sizeof list - strlen(list) - 1);
        if (types[i + 1]) strncat(list, ", ", sizeof list - strlen(list) - 1);
    }
    char q[96];
    return sj_fail(ld, RAYD_E_INVALID, &p, "unknown %s \"%s\" (supported: %s)",
                   strcmp(key, "type") == 0 ? "type" : "value",
                   jp_quote(q, sizeof q, t->valuestring), list);
}

enum rayd_status sj_type(struct loader *ld, const cJSON *obj, const struct jp *at,
                         const char *const *types, int *out) {
    TRY(sj_enum(ld, obj, at, "type", types, out));
    struct jp p = jp_key(at, "type");
    if (*out < 0) return sj_fail(ld, RAYD_E_INVALID, &p, "is required");
    return RAYD_OK;
}

enum rayd_status sj_bool(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                         bool def, bool *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    *out = def;
    if (!v) return RAYD_OK;
    struct jp p = jp_key(at, key);
    if (!cJSON_IsBool(v))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be true or false, not %s", sj_type_name(v));
    *out = cJSON_IsTrue(v);
    return RAYD_OK;
}

/* ---- files a scene names -------------------------------------------------- */

/* rayd-render trusts its own scene: a name is a path, relative to the
 * scene's folder.  The server reads only files inside --asset-dir
 * (asset_confine), and the name comes from the network, so the checks are
 * made where they cannot be raced: openat2(RESOLVE_BENEATH) resolves the
 * name inside the directory in the kernel, refusing "..", absolute paths
 * and any symbolic link that would leave it (an absolute link too, even
 * one pointing back inside), in the same step that opens the file.  On a
 * kernel without openat2 (before 5.6, or a seccomp filter answering ENOSYS)
 * the name is resolved with realpath, the result must lie under the
 * directory's own realpath, and that resolved path is opened with
 * O_NOFOLLOW, so a link swapped in for the last component is refused; a
 * folder on the way swapped between the check and the open is the window
 * this fallback leaves, which is why openat2 comes first.  Every open is
 * O_NONBLOCK so that a FIFO cannot hang the loader; only regular files are
 * read, and no more than the scene's max_bytes. */

/* A ".." path component anywhere. */
static bool has_dotdot(const char *p) {
    for (const char *c = p; (c = strstr(c, "..")) != NULL; c += 2)
        if ((c == p || c[-1] == '/') && (c[2] == '/' || c[2] == '\0')) return true;
    return false;
}

/* The fallback: realpath, prefix check, O_NOFOLLOW.  -1 with errno, EXDEV
 * when the name leads outside dir. */
static int open_beneath_realpath(const char *dir, const char *name) {
    char path[4096];
    if ((size_t)snprintf(path, sizeof path, "%s/%s", dir, name) >= sizeof path) {
        errno = ENAMETOOLONG;
        return -1;
    }
    char *rd = realpath(dir, NULL), *rp = realpath(path, NULL);
    int fd = -1, e = errno;
    size_t n = rd ? strlen(rd) : 0;
    if (rd && rp && strncmp(rd, rp, n) == 0 && (rp[n] == '/' || (n == 1 && rd[0] == '/')))
        fd = open(rp, O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK | O_NOFOLLOW), e = errno;
    else if (rd && rp)
        e = EXDEV;
    free(rd);
    free(rp);
    errno = e;
    return fd;
}

/* Opens name for reading inside dir, never outside it (see above). */
static int open_beneath(const char *dir, const char *name) {
    int dfd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd < 0) return -1;
    struct open_how how = {.flags = O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK,
                           .resolve = RESOLVE_BENEATH | RESOLVE_NO_MAGICLINKS};
    int fd = (int)syscall(SYS_openat2, dfd, name, &how, sizeof how);
    int e = errno;
    close(dfd);
    if (fd < 0 && e == ENOSYS) return open_beneath_realpath(dir, name);
    errno = e;
    return fd;
}

/* The open file behind name, or an error at *at.  Checks the name first. */
static enum rayd_status asset_open(struct loader *ld, const char *name, const struct jp *at,
                                   int *fd) {
    const struct rayd_limits *lim = ld->lim;
    char q[96];
    if (!lim->asset_dir)
        return sj_fail(
            ld, RAYD_E_INVALID, at,
            "files are not read here: a server reads them only when started with --asset-dir; "
            "embed the data instead (a mesh: \"text\" or \"base64\", a texture: \"png_base64\")");
    if (name[0] == '\0') return sj_fail(ld, RAYD_E_INVALID, at, "must not be empty");
    if (lim->asset_confine && name[0] == '/')
        return sj_fail(ld, RAYD_E_INVALID, at,
                       "must be a path relative to the asset directory, not an absolute path");
    if (lim->asset_confine && has_dotdot(name))
        return sj_fail(
            ld, RAYD_E_INVALID, at,
            "must not contain a '..' component (files are read only inside the asset directory)");
    char path[4096];
    if (lim->asset_confine) {
        *fd = open_beneath(lim->asset_dir, name);
    } else if (name[0] != '/' &&
               (size_t)snprintf(path, sizeof path, "%s/%s", lim->asset_dir, name) >= sizeof path) {
        return sj_fail(ld, RAYD_E_INVALID, at, "path is too long");
    } else {
        *fd = open(name[0] == '/' ? name : path, O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
    }
    if (*fd >= 0) return RAYD_OK;
    if (lim->asset_confine && errno == EXDEV) /* RESOLVE_BENEATH's (and the fallback's) refusal */
        return sj_fail(ld, RAYD_E_INVALID, at,
                       "\"%s\" leads outside the asset directory (a symbolic link)",
                       jp_quote(q, sizeof q, name));
    return sj_fail(ld, RAYD_E_INVALID, at, "cannot open \"%s\": %s", jp_quote(q, sizeof q, name),
                   strerror(errno));
}

/* st, after closing fd when it is an error. */
static enum rayd_status close_on_fail(int fd, enum rayd_status st) {
    if (st != RAYD_OK) close(fd);
    return st;
}

/* Reads a file named by a scene, under the limits' asset rules. */
enum rayd_status sj_read_asset(struct loader *ld, const cJSON *f, const struct jp *at, char **out,
                               size_t *len) {
    if (!cJSON_IsString(f))
        return sj_fail(ld, RAYD_E_INVALID, at, "must be a string, not %s", sj_type_name(f));
    const char *name = f->valuestring;
    char q[96];
    int fd = -1;
    TRY(asset_open(ld, name, at, &fd));
    struct stat st;
    /* st_size < 0: never; said so the analyzer knows cap > 0 below */
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size < 0) {
        close(fd);
        return sj_fail(ld, RAYD_E_INVALID, at, "\"%s\" is not a regular file",
                       jp_quote(q, sizeof q, name));
    }
    /* the identity before a byte is read: a write during the read shows */
    if (!scene_files_add(ld->s, ld->lim->asset_dir, name, &st)) {
        close(fd);
        return err_set(ld->err, RAYD_E_NOMEM, at->s, "out of memory reading a file");
    }
    size_t max = ld->lim->max_bytes;
    if ((uintmax_t)st.st_size > (uintmax_t)max) {
        close(fd);
        return sj_fail(ld, RAYD_E_LIMIT, at, "file is over the limit of %zu bytes", max);
    }
    /* the file may grow while it is read: stop past max + 1 bytes.  A big
     * file goes to huge pages (hugemem.c): read() into 4 KiB pages faulted
     * once a page, 85% of a 1.3M-triangle PLY load's page faults.  Charged
     * as whole huge pages, which is what becomes resident */
    size_t cap = (size_t)st.st_size + 1, n = 0;
    TRY(close_on_fail(fd, sj_charge(ld, at, huge_alloc_room(cap))));
    char *buf = huge_alloc(cap);
    ssize_t r = 0;
    int rerr = 0;
    while (buf && n <= max) {
        if (n == cap) {
            size_t nc = cap > max / 2 ? max + 1 : cap * 2;
            char *nb = nc > cap ? realloc(buf, nc) : NULL; /* max + 1 may wrap to 0 */
            if (!nb) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = nb;
            cap = nc;
            continue;
        }
        r = read(fd, buf + n, cap - n);
        if (r < 0 && errno == EINTR) continue;
        rerr = errno;
        if (r <= 0) break;
        n += (size_t)r;
    }
    close(fd);
    if (!buf) return err_set(ld->err, RAYD_E_NOMEM, at->s, "out of memory reading a file");
    if (n > max) {
        free(buf);
        return sj_fail(ld, RAYD_E_LIMIT, at, "file is over the limit of %zu bytes", max);
    }
    if (r < 0) {
        free(buf);
        return sj_fail(ld, RAYD_E_INVALID, at, "cannot read \"%s\": %s",
                       jp_quote(q, sizeof q, name), strerror(rerr));
    }
    *out = buf;
    *len = n;
    return RAYD_OK;
}

static int cmp_named(const void *a, const void *b) {
    return strcmp(((const struct named *)a)->name, ((const struct named *)b)->name);
}

enum rayd_status sj_names_sorted(struct loader *ld, const cJSON *obj, int first, struct named **out,
                                 int *n) {
    *out = NULL;
    *n = cJSON_GetArraySize(obj);
    if (*n == 0) return RAYD_OK;
    struct named *names = malloc(sizeof *names * (size_t)*n);
    if (!names) return err_set(ld->err, RAYD_E_NOMEM, NULL, "out of memory");
    int i = 0;
    for (const cJSON *e = obj->child; e; e = e->next, i++)
        names[i] = (struct named){e->string, first + i};
    qsort(names, (size_t)*n, sizeof *names, cmp_named);
    *out = names;
    return RAYD_OK;
}

const struct named *sj_name_find(const struct named *names, int n, const char *name) {
    struct named key = {name, 0};
    return n > 0 ? bsearch(&key, names, (size_t)n, sizeof key, cmp_named) : NULL;
}
