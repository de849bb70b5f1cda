#pragma once
// Functions built twice, for AVX2 and for the baseline x86-64 target, the processor choosing
// at load time (GCC's target_clones); elsewhere, and for the static analyser, built once.
// Neither build enables FMA, so a function gives the same bits in both.

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang_analyzer__)
#define MESHMARK_LANE_TARGETS __attribute__((target_clones("avx2", "default")))
#else
#define MESHMARK_LANE_TARGETS
#endif
