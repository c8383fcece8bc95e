#pragma once
// Vector types of the core. Every geometric routine is a template over `Real` (float or double):
// both precisions are compiled in and chosen per render or cast.
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace durer {

template <typename Real>
using Vec3 = glm::vec<3, Real, glm::defaultp>;

using Vec3d = Vec3<double>;
using Vec4d = glm::dvec4;

}  // namespace durer
