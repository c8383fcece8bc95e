#pragma once
// Functions of the traversal's inner loop that must be inlined into it whatever the compiler's
// size heuristics say: a call per node visit costs more than the node test itself. DURER_INLINE_LAMBDA
// is the same for a lambda (after its parameter list): a grid cell's test, called once per cell
// a ray crosses, was left a call.
#if defined(__GNUC__)
#define DURER_INLINE inline __attribute__((always_inline))
#define DURER_INLINE_LAMBDA __attribute__((always_inline))
#else
#define DURER_INLINE inline
#define DURER_INLINE_LAMBDA
#endif
