#pragma once
// Functions of the traversal's inner loop that must be inlined into it whatever the compiler's
// size heuristics say: a call per node visit costs more than the node test itself.
#if defined(__GNUC__)
#define DURER_INLINE inline __attribute__((always_inline))
#else
#define DURER_INLINE inline
#endif
