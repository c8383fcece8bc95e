#pragma once
#include "durer/Vec.h"

namespace durer {

struct DirectionalLight {
  Vec3d direction;  // unit, world space: the way the light travels (the surface sees it from -direction)
  Vec3d color;      // linear RGB, no falloff
};

struct PointLight {
  Vec3d position;  // world space
  Vec3d color;     // linear RGB, no falloff (the 6.837 assignment-2 light)
};

}  // namespace durer
