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
 * Many CPUs (AMD's before Zen 4, Intel's client parts) stop at AVX2 with
 * FMA (cpu_avx2).  For them the scene's and meshes' packets go as two of
 * 8 rays (accel/bvh_rays8.h, geom/mesh_packet8.c, scene/scene_packet8.c),
 * and the one-ray mesh walk has a third copy, whose 8-wide node test needs
 * no more.  A CPU with AVX-512 takes the AVX-512 code; the AVX2 node test
 * is inlined into it (a subset target).
 */
#ifndef CPU_H
#define CPU_H

#include <stdbool.h>

/* True when the AVX-512 code runs: built in, the CPU and OS have it,
 * RAYD_NO_AVX512 is not set in the environment (to compare, or to rule
 * the SIMD code out), and cpu_force has not turned it off. */
bool cpu_avx512(void);
/* True when the AVX2 code runs: the CPU and OS have AVX2, FMA, BMI and
 * popcount, RAYD_NO_AVX2 is not set (it rules out AVX-512 too), and
 * cpu_force has not turned it off. */
bool cpu_avx2(void);
/* Tests: the code that may run, to compare the ways on one CPU: whatever
 * the CPU has; the AVX2 code where the AVX-512 code would run; the
 * build's own target (SSE2 on plain x86-64), one ray at a time. */
enum cpu_way { CPU_WAY_BEST, CPU_WAY_AVX2, CPU_WAY_BASE };
void cpu_force(enum cpu_way way);

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
