#pragma once
// The one dispatch point of the render and cast kernels: the sphere method is chosen once per
// render or cast (withSphereMethod), and a kernel body runs through runKernel, which compiles the
// default method's body as a hot kernel. A hot kernel has everything it calls inlined into it
// (flatten), and on x86-64 GCC/Clang it is compiled twice, for x86-64-v2 and for x86-64-v3 (AVX2,
// FMA), the best one being picked when the module loads (target_clones): the default build runs on
// any x86-64-v2 machine yet uses AVX2 where present. The lecture's methods are there to compare
// accuracy and are compiled once (each clone of a flattened kernel costs minutes of compilation).
// DURER_NATIVE builds skip the clones and compile everything for the build machine.
#include <type_traits>

#include "durer/Options.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(DURER_NATIVE)
#define DURER_HOT_KERNEL __attribute__((flatten, target_clones("default", "arch=x86-64-v3")))
#else
#define DURER_HOT_KERNEL __attribute__((flatten))
#endif

namespace durer {

namespace kernel {
template <typename Body>
DURER_HOT_KERNEL auto cloned(const Body& body) -> decltype(body()) {
  return body();
}
template <typename Body>
__attribute__((flatten)) auto plain(const Body& body) -> decltype(body()) {
  return body();
}
}  // namespace kernel

// body() compiled as a kernel for sphere method M: ISA clones for the default method, plain otherwise.
template <SphereMethod M, typename Body>
auto runKernel(const Body& body) -> decltype(body()) {
  if constexpr (M == SphereMethod::Robust) {
    return kernel::cloned(body);
  } else {
    return kernel::plain(body);
  }
}

template <SphereMethod M>
using SphereMethodTag = std::integral_constant<SphereMethod, M>;

// f(SphereMethodTag<M>{}) for the method chosen at run time: the one switch over sphere methods.
template <typename F>
decltype(auto) withSphereMethod(SphereMethod method, F&& f) {
  switch (method) {
    case SphereMethod::Algebraic:
      return f(SphereMethodTag<SphereMethod::Algebraic>{});
    case SphereMethod::Geometric:
      return f(SphereMethodTag<SphereMethod::Geometric>{});
    case SphereMethod::Robust:
      break;
  }
  return f(SphereMethodTag<SphereMethod::Robust>{});
}

}  // namespace durer
