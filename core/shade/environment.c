/* environment.c -- image-based lighting.
 *
 * The environment is either one constant radiance or an equirectangular
 * image: column u covers the azimuth phi = 2 pi (u - 1/2) measured from -Z
 * toward +X, row v the polar angle theta = pi v from +Y (row 0 is straight
 * up).  So the image's centre is seen looking down -Z, rayd's default
 * camera direction.  "rotation" turns the whole image about +Y; a lookup
 * turns the direction back by the same angle.
 *
 * Lookups take the nearest texel: the radiance is then piecewise constant
 * over exactly the cells the sampler draws from, so the sampling pdf is
 * proportional to what it samples, and a lookup is a few operations with no
 * filter to make the result depend on anything but the direction.  The
 * cell is found against the very edges the sampler draws between (tables
 * of their cos(theta) and of sin and cos phi), so a drawn direction is
 * always looked up in the cell it was drawn from.
 *
 * The path tracer draws directions in proportion to the radiance's
 * luminance over the sphere: a cell's weight is its luminance times its
 * solid angle (2 pi / w times the difference of its rows' cos(theta)); a
 * row by the marginal CDF, then a column by that row's conditional CDF,
 * each search started from a guide table, then a point uniform in solid
 * angle within the cell (phi uniform, cos(theta) uniform).  The
 * solid-angle pdf of a direction is then its cell's luminance over the
 * map's integral of luminance: proportional to what it samples
 * everywhere, even in the rows near the poles, where a point uniform in
 * theta would crowd the pole (the studio map's bright top row:
 * bench/README.md, "against Mitsuba 3 too").
 * A constant environment needs no table: the BSDF's own sampling is
 * already the best one can do against a uniform light.
 *
 * The mean (solid-angle average) radiance is the Whitted integrator's
 * ambient light: a uniform environment of that radiance lights a Lambert
 * surface of albedo a to exactly a times it.
 */
#include <stdlib.h>

#include "shade/environment.h"

#include "math/turn.h"
#include "shade/texels.h"

#define PI 3.14159265358979323846

/* d turned by the rotation (sign +1) or back (-1) about +Y. */
static vec3 turn(const struct environment *e, vec3 d, double sign) {
    double c = e->cos_r, s = sign * e->sin_r;
    return v3(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
}

/* floor(x) as an index in [0, n): NaN and what lies outside clamped. */
static int index_in(double x, int n) { return x > 0 ? (x < n ? (int)x : n - 1) : 0; }

/* acos(y) to 7e-5 (Abramowitz and Stegun 4.4.45), for a first guess. */
static double acos_guess(double y) {
    double a = fabs(y),
           r = sqrt(1 - a) * (1.5707288 + a * (-0.2121144 + a * (0.0742610 - a * 0.0187293)));
    return y < 0 ? PI - r : r;
}

/* atan2(x, z) to 1e-5 (A and S 4.4.49 on the smaller ratio), a first guess. */
static double atan2_guess(double x, double z) {
    double ax = fabs(x), az = fabs(z), lo = v3_fmin(ax, az), hi = v3_fmax(ax, az);
    double a = hi > 0 ? lo / hi : 0, a2 = a * a;
    double t =
        a * (0.9998660 + a2 * (-0.3302995 + a2 * (0.1801410 + a2 * (-0.0851330 + a2 * 0.0208351))));
    if (ax > az) t = PI / 2 - t;
    if (z < 0) t = PI - t;
    return signbit(x) ? -t : t;
}

/* The row of a local direction: from a guess, stepped to the one whose
 * edges' cos(theta) (the table env_sample draws from) hold y. */
static int row_of(const struct environment *e, double y) {
    int h = e->h, j = index_in(acos_guess(v3_fmax(-1, v3_fmin(1, y))) * (h / PI), h);
    while (j > 0 && y > e->row_cos[j]) j--;
    while (j + 1 < h && y <= e->row_cos[j + 1]) j++;
    return j;
}

/* The column of a local direction, likewise: (x, -z) lies at or past
 * column k's left edge when it is on the edge's left, a sign that holds
 * within half a turn of the edge: the guess is far nearer than that. */
static int col_of(const struct environment *e, double x, double z) {
    int w = e->w, i = index_in((atan2_guess(x, -z) / (2 * PI) + 0.5) * w, w);
    const double *s = e->col_sin, *c = e->col_cos;
    if (x == 0 && z == 0) return i; /* straight up or down: any column */
    while (i > 0 && x * c[i] + z * s[i] < 0) i--;
    while (i + 1 < w && x * c[i + 1] + z * s[i + 1] >= 0) i++;
    return i;
}

/* The cell of a local direction: the one env_sample draws it from.  No
 * acos or atan2 (a fifth of an environment-lit path's time): a guess
 * good to a fraction of a cell, then a step or two against the cells'
 * edges as env_sample makes them, which gives every direction that
 * sampler draws in a cell that cell, to the last bit. */
static int cell_of(const struct environment *e, vec3 l) {
    return row_of(e, l.y) * e->w + col_of(e, l.x, l.z);
}

static vec3 texel(const float *p) { return v3(p[0], p[1], p[2]); }

vec3 env_radiance(const struct environment *e, vec3 d) {
    if (e->kind == ENV_CONSTANT) return e->color;
    if (e->kind != ENV_IMAGE) return v3(0, 0, 0);
    return texel(e->rgb + 3 * (size_t)cell_of(e, turn(e, d, -1)));
}

static double luminance(const float *p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; }

static double row_sin(const struct environment *e, int j) { return sin(PI * (j + 0.5) / e->h); }

/* cos(theta) at the top edge of row j (j = h: the bottom of the map);
 * env_sample reads it from the table made of it. */
static double row_cos(const struct environment *e, int j) {
    return j <= 0 ? 1 : j >= e->h ? -1 : cos(PI * j / e->h);
}

/* The index k in [0, n) with cdf[k] <= x < cdf[k + 1], skipping empty ones
 * (the only such k; n - 1 for x >= cdf[n]). */
static int find(const double *cdf, int n, double x) {
    int lo = 0, hi = n; /* cdf[lo] <= x < cdf[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (cdf[mid] <= x)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* find's k for x = u cdf[n], u in [0, 1), from guide[(int)(u m)], find's
 * answer at the start of that m-th of the range (Chen and Asau's guide
 * table): a step or two from there instead of a binary search's chain of
 * dependent loads, which was most of a sample's cost on an environment
 * lit scene.  Since that k is the only one, the steps (either way, so a
 * rounding at a bucket's edge cannot mislead) end where find does. */
static int find_guided(const double *cdf, int n, const int *guide, int m, double u, double x) {
    int g = (int)(u * m), k = guide[g < 0 ? 0 : g >= m ? m - 1 : g];
    while (k > 0 && cdf[k] > x) k--;
    while (k + 1 < n && cdf[k + 1] <= x) k++;
    return k;
}

/* guide[g] = find's k at the start of the g-th of m parts of the range. */
static void make_guide(const double *cdf, int n, int *guide, int m) {
    for (int g = 0; g < m; g++) guide[g] = find(cdf, n, cdf[n] * g / m);
}

/* The weights' CDFs (luminance x the cell's cos(theta) extent); integral =
 * the luminance integrated over the sphere. */
static bool build_tables(struct environment *e) {
    int w = e->w, h = e->h;
    e->row_cdf = malloc((size_t)(h + 1) * sizeof *e->row_cdf);
    e->row_cos = malloc((size_t)(h + 1) * sizeof *e->row_cos);
    e->col_cdf = malloc((size_t)h * (size_t)(w + 1) * sizeof *e->col_cdf);
    e->row_guide = malloc((size_t)h * sizeof *e->row_guide);
    e->col_guide = malloc((size_t)h * (size_t)w * sizeof *e->col_guide);
    e->col_sin = malloc((size_t)(w + 1) * sizeof *e->col_sin);
    e->col_cos = malloc((size_t)(w + 1) * sizeof *e->col_cos);
    if (!e->row_cdf || !e->row_cos || !e->col_cdf || !e->row_guide || !e->col_guide ||
        !e->col_sin || !e->col_cos)
        return false;
    for (int j = 0; j <= h; j++) e->row_cos[j] = row_cos(e, j);
    for (int i = 0; i <= w; i++) turn_sincos((double)i / w - 0.5, &e->col_sin[i], &e->col_cos[i]);
    e->row_cdf[0] = 0;
    for (int j = 0; j < h; j++) {
        double *c = e->col_cdf + (size_t)j * (size_t)(w + 1);
        double area = e->row_cos[j] - e->row_cos[j + 1];
        c[0] = 0;
        for (int i = 0; i < w; i++)
            c[i + 1] = c[i] + luminance(e->rgb + 3 * ((size_t)j * w + i)) * area;
        e->row_cdf[j + 1] = e->row_cdf[j] + c[w];
        make_guide(c, w, e->col_guide + (size_t)j * (size_t)w, w);
    }
    make_guide(e->row_cdf, h, e->row_guide, h);
    e->integral = e->row_cdf[h] * 2 * PI / w;
    return true;
}

bool env_prepare(struct environment *e) {
    e->sample = true;
    if (e->kind != ENV_IMAGE) {
        e->mean = e->color;
        return true;
    }
    vec3 sum = v3(0, 0, 0);
    double wsum = 0;
    for (int j = 0; j < e->h; j++) {
        double st = row_sin(e, j);
        for (int i = 0; i < e->w; i++) {
            const float *p = e->rgb + 3 * ((size_t)j * e->w + i);
            sum = v3_madd(sum, v3(p[0], p[1], p[2]), st);
        }
        wsum += st * e->w;
    }
    e->mean = v3_scale(sum, 1 / wsum);
    return build_tables(e);
}

bool env_can_sample(const struct environment *e) {
    return e->kind == ENV_IMAGE && e->sample && e->integral > 0;
}

bool env_sample(const struct environment *e, double u1, double u2, vec3 *d, double *pdf, vec3 *le) {
    int w = e->w, h = e->h;
    double x = u1 * e->row_cdf[h];
    int j = find_guided(e->row_cdf, h, e->row_guide, h, u1, x);
    double rw = e->row_cdf[j + 1] - e->row_cdf[j];
    double fv = rw > 0 ? (x - e->row_cdf[j]) / rw : 0.5;
    const double *c = e->col_cdf + (size_t)j * (size_t)(w + 1);
    double y = u2 * c[w];
    int i = find_guided(c, w, e->col_guide + (size_t)j * (size_t)w, w, u2, y);
    double cw = c[i + 1] - c[i];
    double fu = cw > 0 ? (y - c[i]) / cw : 0.5;
    if (!(cw > 0)) return false;
    double top = e->row_cos[j], ct = top - v3_fmin(fv, 1) * (top - e->row_cos[j + 1]);
    double st = sqrt(v3_fmax(0, 1 - ct * ct)), sp, cp;
    turn_sincos((i + v3_fmin(fu, 1)) / w - 0.5, &sp, &cp); /* phi = 2 pi (that) */
    vec3 l = v3(st * sp, ct, -st * cp);
    *d = turn(e, l, 1);
    /* the cell's share of all weight, spread evenly over its solid angle */
    const float *p = e->rgb + 3 * ((size_t)j * w + i);
    *pdf = luminance(p) / e->integral;
    *le = texel(p);
    return *pdf > 0;
}

vec3 env_radiance_pdf(const struct environment *e, vec3 d, double *pdf) {
    const float *p = e->rgb + 3 * (size_t)cell_of(e, turn(e, d, -1));
    *pdf = e->integral > 0 ? luminance(p) / e->integral : 0;
    return texel(p);
}

void env_free(struct environment *e) {
    if (e->shared)
        texels_unref(e->shared);
    else
        free(e->rgb);
    e->shared = NULL;
    free(e->row_cdf);
    free(e->row_cos);
    free(e->col_cdf);
    free(e->row_guide);
    free(e->col_guide);
    free(e->col_sin);
    free(e->col_cos);
    e->rgb = NULL;
    e->row_cdf = e->row_cos = e->col_cdf = e->col_sin = e->col_cos = NULL;
    e->row_guide = e->col_guide = NULL;
}

size_t env_bytes(const struct environment *e) {
    if (e->kind != ENV_IMAGE) return 0;
    size_t w = (size_t)e->w, h = (size_t)e->h;
    return w * h * 3 * sizeof *e->rgb + (2 * (h + 1) + 2 * (w + 1) + h * (w + 1)) * sizeof(double) +
           (h + h * w) * sizeof(int) +
           (e->shared ? e->shared->sh.key_len : 0); /* a shared image counts whole in each scene */
}
