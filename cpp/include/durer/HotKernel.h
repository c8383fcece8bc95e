#pragma once
// DURER_HOT_KERNEL marks the few functions that hold a render's or cast's inner loops. Everything
// they call is inlined into them (flatten), and on x86-64 GCC/Clang they are compiled once per ISA
// level, the best one being picked when the module loads (target_clones): the default build runs on
// any x86-64-v2 machine yet uses AVX2/AVX-512 where present. DURER_NATIVE builds skip the clones.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(DURER_NATIVE)
#define DURER_HOT_KERNEL __attribute__((flatten, target_clones("default", "arch=x86-64-v3", "arch=x86-64-v4")))
#else
#define DURER_HOT_KERNEL __attribute__((flatten))
#endif
