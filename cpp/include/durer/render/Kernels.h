#pragma once
// The hot kernels' entry points: a render and a cast per precision, compiled once per instruction
// set (src/kernels; CMakeLists.txt keeps each set's inline code to itself). Every set serves the
// robust sphere test; the baseline set (x86-64-v2, or the only one) also the lecture's methods,
// there to compare accuracy, not to be fast. kernelsFor() picks the set for this CPU and method:
// the CPU's once per process, never per function call.
#include <functional>

#include "durer/render/Cast.h"
#include "durer/render/Renderer.h"

namespace durer {

struct RenderJob {
  const Scene& scene;
  const CameraSpec& camera;
  const RenderSettings& settings;
  const RenderTargets& targets;
  EffectSet effects;  // decided once per render (Renderer.cpp)
  JobControl& control;
  const std::function<void()>& poll;
};

template <typename Real>
struct CastJob {
  const Scene& scene;
  const CastInput& input;
  const CastOutput<Real>& output;
  JobControl& control;
  const std::function<void()>& poll;
};

// One instruction set's kernels.
struct KernelSet {
  const char* isa;  // "x86-64-v2", "x86-64-v3", "x86-64-v4", "native" or "generic"
  RenderStats (*renderFloat)(const RenderJob&);
  RenderStats (*renderDouble)(const RenderJob&);
  CastStats (*castFloat)(const CastJob<float>&);
  CastStats (*castDouble)(const CastJob<double>&);
};

// The best kernel set this CPU runs.
const KernelSet& kernels();

// The best kernel set this CPU runs that serves `method`.
const KernelSet& kernelsFor(SphereMethod method);

// The sphere methods the kernel set being compiled serves (DURER_LECTURE_METHODS: the baseline's).
#if defined(DURER_LECTURE_METHODS)
using KernelMethods = SphereMethods<SphereMethod::Robust, SphereMethod::Algebraic, SphereMethod::Geometric>;
#else
using KernelMethods = SphereMethods<SphereMethod::Robust>;
#endif

// Each kernel set's entry points, in a namespace of its own (DURER_ISA when a set is compiled); the
// only symbols that stay global in the set's object (CMakeLists.txt).
#define DURER_DECLARE_KERNEL_SET(ns)                              \
  namespace ns {                                                  \
  RenderStats renderFloat(const RenderJob& job);                  \
  RenderStats renderDouble(const RenderJob& job);                 \
  CastStats castFloat(const CastJob<float>& job);                 \
  CastStats castDouble(const CastJob<double>& job);               \
  }

// A KernelSet's entry points of set `ns`, in the struct's order.
#define DURER_KERNEL_SET_ENTRIES(ns) ns::renderFloat, ns::renderDouble, ns::castFloat, ns::castDouble

}  // namespace durer
