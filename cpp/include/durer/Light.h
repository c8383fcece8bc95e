#pragma once
#include "durer/Vec.h"

namespace durer {

struct DirectionalLight {
  Vec3d direction;  // unit, world space: the way the light travels (the surface sees it from -direction)
  Vec3d color;      // linear RGB, no falloff
  bool shadows = false;  // whether occluders block it (shadow rays are cast only for such lights)
};

struct PointLight {
  Vec3d position;  // world space
  Vec3d color;     // linear RGB, no falloff (the 6.837 assignment-2 light)
  bool shadows = false;  // whether occluders block it
};

}  // namespace durer
