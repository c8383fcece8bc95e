#pragma once
#include "durer/math/Vec.h"

namespace durer {

struct Material {
  Vec3d diffuse{0.8};   // kd, linear RGB: the flat colour without lights, the diffuse albedo with them
  Vec3d emission{0.0};  // linear RGB added unlit (light sources seen directly; Blender's Emission)
  Vec3d specular{0.0};  // ks: Phong highlight weight, linear RGB (6.837 assignment 3)
  double exponent = 1;  // Phong exponent, >= 0
  Vec3d reflective{0.0};   // weight of the mirror ray's colour (6.837 assignment 4)
  Vec3d transparent{0.0};  // weight of the refracted ray's colour
  double ior = 1;          // index of refraction inside the object, > 0
};

// The one description of Material's fields, in the struct's order: the binding takes materials by
// these names (durer._core.MATERIAL_FIELDS) and Scene::addMaterial checks each by its bound.
struct MaterialField {
  enum class Bound { NonNegative, Positive };  // every component >= 0, or > 0; finite either way
  const char* name;
  Vec3d Material::*color;   // a linear-RGB field, or null
  double Material::*scalar;  // a scalar field, or null
  Bound bound;
  int components() const { return color ? 3 : 1; }
};

inline constexpr MaterialField kMaterialFields[] = {
    {"diffuse", &Material::diffuse, nullptr, MaterialField::Bound::NonNegative},
    {"emission", &Material::emission, nullptr, MaterialField::Bound::NonNegative},
    {"specular", &Material::specular, nullptr, MaterialField::Bound::NonNegative},
    {"exponent", nullptr, &Material::exponent, MaterialField::Bound::NonNegative},
    {"reflective", &Material::reflective, nullptr, MaterialField::Bound::NonNegative},
    {"transparent", &Material::transparent, nullptr, MaterialField::Bound::NonNegative},
    {"ior", nullptr, &Material::ior, MaterialField::Bound::Positive},
};

}  // namespace durer
