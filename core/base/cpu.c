/* cpu.c -- whether rayd's AVX-512 and AVX2 code may run here (cpu.h).
 *
 * The CPU is asked once, with GCC's __builtin_cpu_supports (which also
 * knows whether the OS saves the AVX-512 registers), and the answer kept;
 * the tests' switch is read on every call, so a test may turn the SIMD
 * paths off and on between two renders and compare them.
 */
#include "base/cpu.h"

#include <stdatomic.h>
#include <stdlib.h>

/* The tests' cap on the code that runs (enum cpu_way: the best, AVX2 at
 * most, the build's). */
static atomic_int cap;

void cpu_force(enum cpu_way way) { atomic_store(&cap, (int)way); }

#ifdef CPU_AVX512

/* The CPU's answers and the environment's, read once: -1 until then. */
static atomic_int avx2_ok = -1, avx512_ok = -1;

static bool avx2_here(void) {
    return !getenv("RAYD_NO_AVX2") && __builtin_cpu_supports("avx2") &&
           __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi") &&
           __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("popcnt");
}

static bool avx512_here(void) {
    return avx2_here() && !getenv("RAYD_NO_AVX512") && __builtin_cpu_supports("avx512f") &&
           __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512vl");
}

/* *cache, filled from here() the first time, while the tests' cap is
 * below capped. */
static bool cpu_asked(atomic_int *cache, bool (*here)(void), int capped) {
    int ok = atomic_load_explicit(cache, memory_order_relaxed);
    if (ok < 0) {
        ok = here();
        atomic_store_explicit(cache, ok, memory_order_relaxed);
    }
    return ok && atomic_load_explicit(&cap, memory_order_relaxed) < capped;
}

bool cpu_avx2(void) { return cpu_asked(&avx2_ok, avx2_here, CPU_WAY_BASE); }

bool cpu_avx512(void) { return cpu_asked(&avx512_ok, avx512_here, CPU_WAY_AVX2); }

#else

bool cpu_avx2(void) { return false; }

bool cpu_avx512(void) { return false; }

#endif
