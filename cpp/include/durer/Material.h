#pragma once
#include "durer/Vec.h"

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

}  // namespace durer
