/* roulette.h -- the path tracer's Russian roulette, written once.
 *
 * From bounce ROULETTE_FROM on (bounce 0 is the camera ray's hit, so the
 * third vertex of a path), a path goes on with chance roulette_chance of
 * its throughput beta (the largest of its channels): ROULETTE_GAIN x beta
 * clamped to [0.05, 0.95], its weight divided by that chance.  Two files
 * follow the rule: render/integrate_path.c plays it, and
 * scene/scene_cost.c bounds a path's expected length by it before the
 * render is admitted; one definition keeps the bound true when the rule
 * changes.
 *
 * Why these numbers.  At a gain of 1 from bounce 3 (as pbrt has it) a path
 * at a third of the camera's weight lived on one time in three, three
 * times as bright: the survivors that then met a caustic were the glass
 * box's brightest specks.  At 2 from bounce 2, on make bench-pt's scenes
 * at 16 and 256 samples (16 and 3 seeds, CPU time): the mean squared error
 * 28-30% lower on the glass box, 9-11% on the Cornell box and the slit
 * room, in 2-10% less time; efficiency 1.46-1.52x, 1.22-1.23x,
 * 1.13-1.14x, the bunny level (bench/README.md, "Samples cheaper and less
 * noisy").  A gain of 3 was worse than 2 on every scene.
 */
#ifndef ROULETTE_H
#define ROULETTE_H

#include "math/vec.h"

#define ROULETTE_FROM 2u  /* the first bounce that plays */
#define ROULETTE_GAIN 2.0 /* the chance per unit of throughput */
#define ROULETTE_MIN 0.05 /* no path is ended for sure ... */
#define ROULETTE_MAX 0.95 /* ... nor let go on for sure */

/* The chance that a path of throughput beta goes on; a NaN beta gets
 * ROULETTE_MIN (v3_fmax ignores a NaN, as fmax does). */
static inline double roulette_chance(double beta) {
    return v3_fmin(ROULETTE_MAX, v3_fmax(ROULETTE_MIN, ROULETTE_GAIN * beta));
}

#endif
