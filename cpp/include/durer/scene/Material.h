#pragma once
#include <cstddef>
#include <iterator>

#include "durer/math/Float.h"
#include "durer/math/Vec.h"

namespace durer {

// A material's fields in one precision: the scene keeps them in double (Material), a render reads
// them converted to its own (MaterialIn<Real>::from, field by field through kMaterialFieldsIn).
template <typename Real>
struct MaterialIn {
  Vec3<Real> diffuse{Real(0.8)};  // kd, linear RGB: the flat colour without lights, the diffuse albedo with them
  Vec3<Real> emission{0};         // linear RGB added unlit (light sources seen directly; Blender's Emission)
  Vec3<Real> specular{0};         // ks: Phong highlight weight, linear RGB (6.837 assignment 3)
  Real exponent = 1;              // Phong exponent, >= 0
  Vec3<Real> reflective{0};       // weight of the mirror ray's colour (6.837 assignment 4)
  Vec3<Real> transparent{0};      // weight of the refracted ray's colour
  Real ior = 1;                   // index of refraction inside the object, > 0

  static MaterialIn from(const MaterialIn<double>& m);
};

// A reflective material's Phong lobe at least this narrow (about 2°) is its mirror's own reflection
// of the lights, the glint of those no mirror ray meets (the Blender export's mirrors: roughness
// <= 0.2, exponent >= 1248): an area light, which the mirror direction sees, is left out of it.
inline constexpr double kMirrorGlintExponent = 1000;

using Material = MaterialIn<double>;

// The one description of a material's fields, in the struct's order: the binding takes materials
// by these names (durer._core.MATERIAL_FIELDS), Scene::addMaterial checks each by its bound, and a
// render converts each to its precision.
template <typename Real>
struct MaterialFieldIn {
  enum class Bound { NonNegative, Positive };  // every component >= 0, or > 0; finite either way
  const char* name;
  Vec3<Real> MaterialIn<Real>::*color;  // a linear-RGB field, or null
  Real MaterialIn<Real>::*scalar;       // a scalar field, or null
  Bound bound;
  int components() const { return color ? 3 : 1; }
};

template <typename Real>
inline constexpr MaterialFieldIn<Real> kMaterialFieldsIn[] = {
    {"diffuse", &MaterialIn<Real>::diffuse, nullptr, MaterialFieldIn<Real>::Bound::NonNegative},
    {"emission", &MaterialIn<Real>::emission, nullptr, MaterialFieldIn<Real>::Bound::NonNegative},
    {"specular", &MaterialIn<Real>::specular, nullptr, MaterialFieldIn<Real>::Bound::NonNegative},
    {"exponent", nullptr, &MaterialIn<Real>::exponent, MaterialFieldIn<Real>::Bound::NonNegative},
    {"reflective", &MaterialIn<Real>::reflective, nullptr, MaterialFieldIn<Real>::Bound::NonNegative},
    {"transparent", &MaterialIn<Real>::transparent, nullptr, MaterialFieldIn<Real>::Bound::NonNegative},
    {"ior", nullptr, &MaterialIn<Real>::ior, MaterialFieldIn<Real>::Bound::Positive},
};

using MaterialField = MaterialFieldIn<double>;
inline constexpr const auto& kMaterialFields = kMaterialFieldsIn<double>;

template <typename Real>
MaterialIn<Real> MaterialIn<Real>::from(const Material& m) {
  MaterialIn out;
  for (size_t i = 0; i < std::size(kMaterialFields); ++i) {
    const MaterialField& source = kMaterialFields[i];
    const MaterialFieldIn<Real>& target = kMaterialFieldsIn<Real>[i];
    if (source.color) {
      out.*target.color = toReal<Real>(m.*source.color);
    } else {
      out.*target.scalar = static_cast<Real>(m.*source.scalar);
    }
  }
  return out;
}

}  // namespace durer
