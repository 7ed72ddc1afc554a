/* scene_json_util.c -- JSON Pointers and the typed getters of the scene
 * loader.  Each getter reads one key, checks its type and range, and on
 * failure names the value by its JSON Pointer (RFC 6901: "~" and "/" in keys
 * are escaped) with a message that says what is wrong.
 */
#define _XOPEN_SOURCE 700 /* realpath */
#include <errno.h>
#include <stdarg.h>
#include <sys/stat.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/scene_json_util.h"

/* Appends the UTF-8 character at *src to dst (capacity cap, length *n)
 * with control characters (and, with quotes, '"' and '\\') escaped as in
 * JSON, so a message stays one line of valid UTF-8.  False (nothing written) when it does not
 * fit. */
static bool put_char(char *dst, size_t cap, size_t *n, const char **src, bool quotes) {
    unsigned char c = (unsigned char)**src;
    char esc[8];
    size_t len = 1;
    const char *from = *src;
    if (c < 0x20 || c == 0x7f) {
        snprintf(esc, sizeof esc, "\\u%04x", c);
        from = esc;
        len = 6;
    } else if (quotes && (c == '"' || c == '\\')) {
        esc[0] = '\\';
        esc[1] = (char)c;
        from = esc;
        len = 2;
    } else if (c >= 0x80) {
        while ((((unsigned char)(*src)[len]) & 0xC0) == 0x80) len++;
    }
    if (*n + len + 4 >= cap) return false; /* keep room for "..." and NUL */
    memcpy(dst + *n, from, len);
    *n += len;
    *src += c >= 0x80 ? len : 1;
    return true;
}

const char *sj_quote(char *dst, size_t cap, const char *src) {
    size_t n = 0;
    while (*src && put_char(dst, cap, &n, &src, true)) continue;
    if (*src) memcpy(dst + n, "...", 3), n += 3;
    dst[n] = '\0';
    return dst;
}

struct jp sj_key(const struct jp *parent, const char *key) {
    struct jp r;
    size_t n = strlen(parent->s);
    memcpy(r.s, parent->s, n);
    r.s[n++] = '/';
    const char *k = key;
    while (*k) {
        if (*k == '~' || *k == '/') { /* RFC 6901 escapes */
            if (n + 6 >= sizeof r.s) break;
            r.s[n++] = '~';
            r.s[n++] = *k++ == '~' ? '0' : '1';
        } else if (!put_char(r.s, sizeof r.s, &n, &k, false)) {
            break;
        }
    }
    if (*k) memcpy(r.s + n, "...", 3), n += 3;
    r.s[n] = '\0';
    return r;
}

struct jp sj_index(const struct jp *parent, int i) {
    struct jp r;
    size_t n = strlen(parent->s);
    if (n > sizeof r.s - 16) n = sizeof r.s - 16; /* a parent this long ends in "..." already */
    snprintf(r.s, sizeof r.s, "%.*s/%d", (int)n, parent->s, i);
    return r;
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
        struct jp p = sj_key(at, c->string);
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
        struct jp p = sj_key(at, names[i]);
        st = sj_fail(ld, RAYD_E_INVALID, &p, "duplicate key");
    }
    free(names);
    return st;
}

/* A number in [lo, hi] (lo excluded when lo_open). */
enum rayd_status sj_num(struct loader *ld, const cJSON *obj, const struct jp *at,
                                const char *key, double def, double lo, bool lo_open, double hi,
                                double *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) {
        *out = def;
        return RAYD_OK;
    }
    struct jp p = sj_key(at, key);
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
enum rayd_status sj_int(struct loader *ld, const cJSON *obj, const struct jp *at,
                                const char *key, long def, long lo, long hi, bool hi_is_limit,
                                long *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) {
        *out = def;
        return RAYD_OK;
    }
    struct jp p = sj_key(at, key);
    if (!cJSON_IsNumber(v))
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be an integer, not %s", sj_type_name(v));
    double x = v->valuedouble;
    if (!isfinite(x) || floor(x) != x)
        return sj_fail(ld, RAYD_E_INVALID, &p, "must be an integer");
    if (x < (double)lo) return sj_fail(ld, RAYD_E_INVALID, &p, "must be >= %ld", lo);
    if (x > (double)hi)
        return sj_fail(ld, hi_is_limit ? RAYD_E_LIMIT : RAYD_E_INVALID, &p,
                    hi_is_limit ? "must be <= %ld (the limit)" : "must be <= %ld", hi);
    *out = (long)x;
    return RAYD_OK;
}

enum rayd_status sj_vec_value(struct loader *ld, const cJSON *v, const struct jp *p,
                              enum vec_rule rule, vec3 *out) {
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return sj_fail(ld, RAYD_E_INVALID, p, "must be an array of 3 numbers");
    double c[3];
    int i = 0;
    for (const cJSON *e = v->child; e; e = e->next, i++) {
        struct jp pe = sj_index(p, i);
        if (!cJSON_IsNumber(e))
            return sj_fail(ld, RAYD_E_INVALID, &pe, "must be a number, not %s", sj_type_name(e));
        c[i] = e->valuedouble;
        if (!isfinite(c[i])) return sj_fail(ld, RAYD_E_INVALID, &pe, "must be a finite number");
        if (fabs(c[i]) > NUM_MAX) return sj_fail(ld, RAYD_E_INVALID, &pe, "must be in [-1e9, 1e9]");
        if (rule == VEC_COLOR && c[i] < 0) return sj_fail(ld, RAYD_E_INVALID, &pe, "must be >= 0");
    }
    *out = v3(c[0], c[1], c[2]);
    if (rule == VEC_NONZERO && !(v3_len(*out) > 0))
        return sj_fail(ld, RAYD_E_INVALID, p, "must not be a zero-length vector");
    return RAYD_OK;
}

enum rayd_status sj_vec(struct loader *ld, const cJSON *obj, const struct jp *at,
                        const char *key, vec3 def, enum vec_rule rule, vec3 *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) {
        *out = def;
        return RAYD_OK;
    }
    struct jp p = sj_key(at, key);
    return sj_vec_value(ld, v, &p, rule, out);
}

/* ---- lights ----------------------------------------------------------------- */

/* A string key that must be one of the names in types: *out its index. */
enum rayd_status sj_enum(struct loader *ld, const cJSON *obj, const struct jp *at,
                                     const char *key, const char *const *types, int *out) {
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(obj, key);
    struct jp p = sj_key(at, key);
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
                   strcmp(key, "type") == 0 ? "type" : "value", sj_quote(q, sizeof q, t->valuestring), list);
}

enum rayd_status sj_type(struct loader *ld, const cJSON *obj, const struct jp *at,
                         const char *const *types, int *out) {
    TRY(sj_enum(ld, obj, at, "type", types, out));
    struct jp p = sj_key(at, "type");
    if (*out < 0) return sj_fail(ld, RAYD_E_INVALID, &p, "is required");
    return RAYD_OK;
}

enum rayd_status sj_bool(struct loader *ld, const cJSON *obj, const struct jp *at, const char *key,
                         bool def, bool *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    *out = def;
    if (!v) return RAYD_OK;
    struct jp p = sj_key(at, key);
    if (!cJSON_IsBool(v)) return sj_fail(ld, RAYD_E_INVALID, &p, "must be true or false, not %s", sj_type_name(v));
    *out = cJSON_IsTrue(v);
    return RAYD_OK;
}

/* ---- files a scene names -------------------------------------------------- */

/* A ".." path component anywhere. */
static bool has_dotdot(const char *p) {
    for (const char *c = p; (c = strstr(c, "..")) != NULL; c += 2)
        if ((c == p || c[-1] == '/') && (c[2] == '/' || c[2] == '\0')) return true;
    return false;
}

/* path resolves (symbolic links followed) to somewhere under dir. */
static bool inside_dir(const char *dir, const char *path) {
    char *rd = realpath(dir, NULL), *rp = realpath(path, NULL);
    size_t n = rd ? strlen(rd) : 0;
    bool ok = rd && rp && strncmp(rd, rp, n) == 0 && (rp[n] == '/' || (n == 1 && rd[0] == '/'));
    free(rd);
    free(rp);
    return ok;
}

/* Reads a file named by a scene, under the limits' asset rules. */
enum rayd_status sj_read_asset(struct loader *ld, const cJSON *f, const struct jp *at,
                                   char **out, size_t *len) {
    const struct rayd_limits *lim = ld->lim;
    if (!cJSON_IsString(f)) return sj_fail(ld, RAYD_E_INVALID, at, "must be a string, not %s", sj_type_name(f));
    const char *name = f->valuestring;
    if (!lim->asset_dir)
        return sj_fail(ld, RAYD_E_INVALID, at, "files are not allowed here (embed the data as \"text\" or \"base64\"; rayd reads files only with --asset-dir)");
    if (name[0] == '\0') return sj_fail(ld, RAYD_E_INVALID, at, "must not be empty");
    if (lim->asset_confine && (name[0] == '/' || has_dotdot(name)))
        return sj_fail(ld, RAYD_E_INVALID, at, "must be a relative path inside the asset directory, without '..'");
    char path[4096], q[96];
    if (name[0] == '/')
        snprintf(path, sizeof path, "%s", name);
    else if ((size_t)snprintf(path, sizeof path, "%s/%s", lim->asset_dir, name) >= sizeof path)
        return sj_fail(ld, RAYD_E_INVALID, at, "path is too long");
    if (lim->asset_confine && !inside_dir(lim->asset_dir, path))
        return sj_fail(ld, RAYD_E_INVALID, at, "\"%s\" is not a file inside the asset directory", sj_quote(q, sizeof q, name));
    FILE *fp = fopen(path, "rb");
    struct stat st;
    if (fp && (fstat(fileno(fp), &st) != 0 || !S_ISREG(st.st_mode))) {
        fclose(fp);
        return sj_fail(ld, RAYD_E_INVALID, at, "\"%s\" is not a regular file", sj_quote(q, sizeof q, name));
    }
    if (!fp) return sj_fail(ld, RAYD_E_INVALID, at, "cannot open \"%s\": %s", sj_quote(q, sizeof q, name), strerror(errno));
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, fp);
        if (n < cap) break;
        if (cap > lim->max_bytes) {
            free(buf);
            fclose(fp);
            return sj_fail(ld, RAYD_E_LIMIT, at, "file is over the limit of %zu bytes", lim->max_bytes);
        }
        char *nb = realloc(buf, cap * 2);
        if (!nb) free(buf);
        buf = nb;
        cap *= 2;
    }
    bool bad = ferror(fp);
    fclose(fp);
    if (!buf) return err_set(ld->err, RAYD_E_NOMEM, at->s, "out of memory reading a file");
    if (bad) {
        free(buf);
        return sj_fail(ld, RAYD_E_INVALID, at, "cannot read \"%s\"", sj_quote(q, sizeof q, name));
    }
    *out = buf;
    *len = n;
    return RAYD_OK;
}
