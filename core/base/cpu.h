/* cpu.h -- whether rayd's AVX-512 and AVX2 code may run here (cpu.c),
 * and the attributes that compile a function for either whatever the
 * build's -march.
 *
 * The packet code (accel/bvh16.h, geom/mesh_packet.c, scene/scene_packet.c,
 * render/integrate_wide.c, the camera's and sRGB's 16-wide paths) is built
 * for AVX-512 in every x86-64 build with GCC or clang, its functions
 * carrying a target attribute, and each entry point asks cpu_avx512 before
 * it runs any of it: elsewhere the same entry points loop over their rays
 * one at a time, to the same bits.  Every layer of the core asks, so the
 * question lives here at the bottom.
 *
 * The one-ray mesh walk has a third copy, for AVX2 with FMA (cpu_avx2):
 * its 8-wide node test needs no more, and many CPUs (AMD's before Zen 4,
 * Intel's client parts) stop there.  A CPU with AVX-512 takes the
 * AVX-512 copy; the AVX2 test is inlined into it (a subset target).
 */
#ifndef CPU_H
#define CPU_H

#include <stdbool.h>

/* True when the AVX-512 code runs: built in, the CPU and OS have it,
 * RAYD_NO_AVX512 is not set in the environment (to compare, or to rule
 * the SIMD code out), and neither cpu_force_scalar nor cpu_force_avx2 has
 * turned it off. */
bool cpu_avx512(void);
/* True when the AVX2 code runs: the CPU and OS have AVX2, FMA, BMI and
 * popcount, RAYD_NO_AVX2 is not set (it rules out AVX-512 too), and
 * cpu_force_scalar has not turned it off. */
bool cpu_avx2(void);
/* Tests: run the one-ray paths in the build's own target (SSE2 on plain
 * x86-64) even where AVX-512 or AVX2 runs. */
void cpu_force_scalar(bool on);
/* Tests: run the AVX2 code, not the AVX-512 code, where both would run. */
void cpu_force_avx2(bool on);

#if defined(__x86_64__) && defined(__GNUC__) && !defined(RAYD_NO_SIMD)
#define CPU_AVX512 1
#include <immintrin.h>

/* Skylake-server's set: AVX-512 F, DQ, BW, VL with the AVX2 generation
 * beside it (BMI, FMA, popcount), all checked at run time by cpu_avx512. */
#define CPU_AVX512_TARGET "avx512f,avx512dq,avx512bw,avx512vl,avx2,fma,bmi,bmi2,popcnt"
#define CPU_AVX512_EXTERN __attribute__((target(CPU_AVX512_TARGET)))
#define CPU_AVX512_FN __attribute__((target(CPU_AVX512_TARGET))) static inline
#define CPU_AVX512_INLINE __attribute__((target(CPU_AVX512_TARGET), always_inline)) static inline

/* Haswell's and Zen's set, checked at run time by cpu_avx2. */
#define CPU_AVX2_TARGET "avx2,fma,bmi,bmi2,popcnt"
#define CPU_AVX2_EXTERN __attribute__((target(CPU_AVX2_TARGET)))
#define CPU_AVX2_FN __attribute__((target(CPU_AVX2_TARGET))) static inline
#define CPU_AVX2_INLINE __attribute__((target(CPU_AVX2_TARGET), always_inline)) static inline
#endif

#endif
