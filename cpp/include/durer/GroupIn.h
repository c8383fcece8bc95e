#pragma once
#include <optional>
#include <type_traits>

#include "durer/Group.h"
#include "durer/Scene.h"

namespace durer {

// The scene's geometry in precision Real: the stored double group itself, or a float copy made once
// per render or cast (so float runs see inputs rounded to float, as the numerics tests assume).
template <typename Real>
const Group<Real>& groupIn(const Scene& scene, std::optional<Group<Real>>& storage) {
  if constexpr (std::is_same_v<Real, double>) {
    return scene.group();
  } else {
    storage.emplace(scene.group());
    return *storage;
  }
}

}  // namespace durer
