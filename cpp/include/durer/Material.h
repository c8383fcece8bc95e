#pragma once
#include "durer/Vec.h"

namespace durer {

struct Material {
  Vec3d diffuse{0.8};   // kd, linear RGB: the flat colour without lights, the diffuse albedo with them
  Vec3d emission{0.0};  // linear RGB added unlit (light sources seen directly; Blender's Emission)
};

}  // namespace durer
