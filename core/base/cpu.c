/* cpu.c -- whether rayd's AVX-512 code may run here (cpu.h).
 *
 * The CPU is asked once, with GCC's __builtin_cpu_supports (which also
 * knows whether the OS saves the AVX-512 registers), and the answer kept;
 * the tests' switch is read on every call, so a test may turn the SIMD
 * paths off and on between two renders and compare them.
 */
#include "base/cpu.h"

#include <stdatomic.h>
#include <stdlib.h>

static atomic_bool force_scalar;

void cpu_force_scalar(bool on) { atomic_store(&force_scalar, on); }

#ifdef CPU_AVX512

/* The CPU's answer and the environment's, read once: -1 until then. */
static atomic_int cpu_ok = -1;

bool cpu_avx512(void) {
    int ok = atomic_load_explicit(&cpu_ok, memory_order_relaxed);
    if (ok < 0) {
        ok = !getenv("RAYD_NO_AVX512") && __builtin_cpu_supports("avx512f") &&
             __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw") &&
             __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx2") &&
             __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi") &&
             __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("popcnt");
        atomic_store_explicit(&cpu_ok, ok, memory_order_relaxed);
    }
    return ok && !atomic_load_explicit(&force_scalar, memory_order_relaxed);
}

#else

bool cpu_avx512(void) { return false; }

#endif
