#pragma once
#include <cstdint>
#include <vector>

namespace durer {

// What every primitive set keeps per primitive besides its geometry: ids, not pointers.
class PrimitiveIds {
 public:
  void add(int32_t material, int32_t objectId) {
    m_materials.push_back(material);
    m_objectIds.push_back(objectId);
  }
  void reserve(size_t n) {
    m_materials.reserve(n);
    m_objectIds.reserve(n);
  }
  // Reorders to order[i] -> i, as the primitives' own storage was.
  void permute(const std::vector<uint32_t>& order) {
    std::vector<int32_t> materials(order.size()), objectIds(order.size());
    for (size_t i = 0; i < order.size(); ++i) {
      materials[i] = m_materials[order[i]];
      objectIds[i] = m_objectIds[order[i]];
    }
    m_materials.swap(materials);
    m_objectIds.swap(objectIds);
  }
  const std::vector<int32_t>& materials() const { return m_materials; }  // material id of primitive i
  const std::vector<int32_t>& objectIds() const { return m_objectIds; }  // scene object id of primitive i

 private:
  std::vector<int32_t> m_materials;
  std::vector<int32_t> m_objectIds;
};

}  // namespace durer
