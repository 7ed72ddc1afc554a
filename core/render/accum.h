/* accum.h -- the accumulator's fields, for accum.c and the denoised
 * resolve (accum_denoise.c). */
#ifndef ACCUM_H
#define ACCUM_H

#include <stdbool.h>

#include "rayd/rayd.h"

struct rayd_accum {
    struct rayd_region r;
    int n;       /* samples summed; -1 after a canceled pass */
    bool centre; /* the sums are the one-sample (pixel centre) image */
    double *sum; /* r.w * r.h * 3, rows packed */
    double *aov; /* NULL, or r.w * r.h * AOV_SUMS (render/aov.h) */
    /* A denoised accumulator (rayd_accum_new_denoised) renders r, the
     * region asked plus the filter's apron, and resolves to view, the
     * region asked, filtered (accum_view); threads: its last pass's. */
    bool denoise;
    struct rayd_region view;
    int threads;
    /* rayd_accum_watch's, for the filter: may be NULL */
    const atomic_int *cancel;
    atomic_int_least64_t *rays_left;
};

/* A denoised accumulator's resolve (accum_denoise.c): into v, a plain
 * accumulator of a->view's size made by the caller (sum and, when a keeps
 * them, aov allocated), the sums of a->view: with filter, the denoised
 * radiance times n, else the raw sums; the AOV sums cut out. */
enum rayd_status accum_denoise_view(const rayd_accum *a, bool filter, rayd_accum *v,
                                    struct rayd_error *err);

#endif
