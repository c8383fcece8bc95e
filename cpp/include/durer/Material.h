#pragma once
#include "durer/Vec.h"

namespace durer {

struct Material {
  Vec3d diffuse{0.8};  // kd, linear RGB: the flat colour without lights, the diffuse albedo with them
};

}  // namespace durer
