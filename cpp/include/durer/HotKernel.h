#pragma once
// DURER_HOT_KERNEL marks the few functions that hold a render's or cast's inner loops. Everything
// they call is inlined into them (flatten), and on x86-64 GCC/Clang they are compiled twice, for
// x86-64-v2 and for x86-64-v3 (AVX2, FMA), the best one being picked when the module loads
// (target_clones): the default build runs on any x86-64-v2 machine yet uses AVX2 where present.
// Only the default sphere method gets the clones (the lecture's methods are there to compare
// accuracy, and each clone of a flattened kernel costs minutes of compilation). DURER_NATIVE builds
// skip the clones and compile everything for the build machine.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(DURER_NATIVE)
#define DURER_HOT_KERNEL __attribute__((flatten, target_clones("default", "arch=x86-64-v3")))
#else
#define DURER_HOT_KERNEL __attribute__((flatten))
#endif
#define DURER_PLAIN_KERNEL __attribute__((flatten))
