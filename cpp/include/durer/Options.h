#pragma once
// Every option the core takes by name, with its one table of names. The binding builds its name
// lookups and the module's tuples (durer._core.PRECISIONS, ...) from these tables, in their order;
// the Python package reads the tuples, so a new option value needs one edit, here.
#include <cstddef>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace durer {

// The precision every ray and intersection of a render or cast is computed in.
enum class Precision { Float, Double };

// How a ray meets a sphere; all three agree on ordinary cases (docs/numerics.md says where they part).
enum class SphereMethod {
  Algebraic,  // the lecture's quadratic: (-b ± sqrt(b² - 4ac)) / 2a
  Geometric,  // the lecture's construction: closest approach, early rejection, then Pythagoras
  Robust,     // discriminant from the ray-to-centre distance and the stable root pair (Ray Tracing Gems ch. 7)
};

// The sphere methods a kernel set compiles (Kernels.h): a render's method is a runtime setting,
// and only the searches (Group::intersect, Group::occluded) are compiled once per method served,
// not the renderer around them. call(method, f) calls f(std::integral_constant<SphereMethod, m>)
// for method m, which must be one of Ms (Kernels.cpp sends a job only to a set that serves it).
template <SphereMethod First, SphereMethod... Rest>
struct SphereMethods {
  template <typename F>
  static auto call(SphereMethod method, const F& f) {
    if constexpr (sizeof...(Rest) > 0) {
      if (method != First) return SphereMethods<Rest...>::call(method, f);
    }
    return f(std::integral_constant<SphereMethod, First>{});
  }
};

// Where a pixel's samples go (PixelSampler.h).
enum class SamplerKind {
  Center,      // every sample at the pixel centre (no anti-aliasing: the baseline)
  Random,      // independent uniform positions
  Stratified,  // one jittered position per stratum of an nx·ny grid, spp = nx·ny (1 sample: the centre)
  Sobol,       // Owen-scrambled Sobol (0,2) points, scrambled per pixel (Burley 2020)
  Adaptive,    // the Sobol points, as many per pixel as its samples disagree (AdaptiveSampler.h)
};

// The images a render can write; a render asks for a set of them (bit flags).
enum PassFlags : unsigned {
  kPassColor = 1u << 0,   // RGBA, linear
  kPassDepth = 1u << 1,   // the pixel's nearest sample hit (DepthKind says measured how); inf on a miss
  kPassNormal = 1u << 2,  // unit world-space normal, the normalised mean over the pixel's hit samples (the
                          // nearest hit sample's where their normals cancel: TileRenderer.h); 0 on a miss
  kPassObjectId = 1u << 3,    // int32: the object id (as cast reports it) of the pixel's nearest hit sample (the
                              // first taken among equally near ones); -1 on a miss
  kPassMaterialId = 1u << 4,  // int32: the material id of that sample; -1 on a miss
};
// What a render computes when not told: the float passes. Id passes are asked for by name.
inline constexpr unsigned kDefaultPasses = kPassColor | kPassDepth | kPassNormal;

// What the depth pass measures.
enum class DepthKind {
  Ray,     // t along the unit camera ray: the distance from the ray's origin
  Planar,  // the distance along the camera's view axis (Blender's and Cycles' Depth pass)
};

enum class Projection { Orthographic, Perspective };

// Which image dimension the camera's size or field of view spans.
enum class Fit {
  Auto,        // the larger one (the 6.837 rule; Blender's sensor fit "Auto")
  Horizontal,  // the width
  Vertical,    // the height
};

enum class ShadingMode {
  Auto,  // lit if the scene has lights, else flat
  Flat,  // every hit takes its material's diffuse + emission colour
  Lit,   // emission + ambient·kd + the lights' diffuse terms, even with no lights (ambient only)
};

template <typename Enum>
struct OptionName {
  const char* name;
  Enum value;
};

inline constexpr OptionName<Precision> kPrecisionNames[] = {{"float", Precision::Float}, {"double", Precision::Double}};
inline constexpr OptionName<SphereMethod> kSphereMethodNames[] = {
    {"algebraic", SphereMethod::Algebraic}, {"geometric", SphereMethod::Geometric}, {"robust", SphereMethod::Robust}};
inline constexpr OptionName<SamplerKind> kSamplerNames[] = {
    {"center", SamplerKind::Center},  {"random", SamplerKind::Random},     {"stratified", SamplerKind::Stratified},
    {"sobol", SamplerKind::Sobol},    {"adaptive", SamplerKind::Adaptive}};
inline constexpr OptionName<PassFlags> kPassNames[] = {
    {"color", kPassColor}, {"depth", kPassDepth}, {"normal", kPassNormal}, {"object_id", kPassObjectId},
    {"material_id", kPassMaterialId}};
inline constexpr OptionName<DepthKind> kDepthNames[] = {{"ray", DepthKind::Ray}, {"planar", DepthKind::Planar}};
inline constexpr OptionName<Projection> kProjectionNames[] = {
    {"orthographic", Projection::Orthographic}, {"perspective", Projection::Perspective}};
inline constexpr OptionName<Fit> kFitNames[] = {
    {"auto", Fit::Auto}, {"horizontal", Fit::Horizontal}, {"vertical", Fit::Vertical}};
inline constexpr OptionName<ShadingMode> kShadingModeNames[] = {
    {"auto", ShadingMode::Auto}, {"flat", ShadingMode::Flat}, {"lit", ShadingMode::Lit}};

// The value named `name` in `table`; std::invalid_argument naming `field` and the choices otherwise.
template <typename Enum, size_t N>
Enum optionNamed(const OptionName<Enum> (&table)[N], const std::string& name, const std::string& field) {
  std::string choices;
  for (size_t i = 0; i < N; ++i) {
    if (name == table[i].name) return table[i].value;
    choices += (i == 0 ? "'" : i + 1 < N ? ", '" : " or '") + std::string(table[i].name) + "'";
  }
  throw std::invalid_argument(field + " must be " + choices + ", got '" + name + "'");
}

// The name of `value` in `table` (every enum value has one).
template <typename Enum, size_t N>
const char* optionName(const OptionName<Enum> (&table)[N], Enum value) {
  for (const OptionName<Enum>& entry : table) {
    if (entry.value == value) return entry.name;
  }
  return table[0].name;
}

}  // namespace durer
