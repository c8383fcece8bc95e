#pragma once

namespace durer {

// How a ray meets a sphere; all three agree on ordinary cases (docs/numerics.md says where they part).
enum class SphereMethod {
  Algebraic,  // the lecture's quadratic: (-b ± sqrt(b² - 4ac)) / 2a
  Geometric,  // the lecture's construction: closest approach, early rejection, then Pythagoras
  Robust,     // discriminant from the ray-to-centre distance and the stable root pair (Ray Tracing Gems ch. 7)
};

enum class Precision { Float, Double };

}  // namespace durer
