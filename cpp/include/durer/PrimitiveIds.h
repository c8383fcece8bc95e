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
  const std::vector<int32_t>& materials() const { return m_materials; }  // material id of primitive i
  const std::vector<int32_t>& objectIds() const { return m_objectIds; }  // scene object id of primitive i

 private:
  std::vector<int32_t> m_materials;
  std::vector<int32_t> m_objectIds;
};

}  // namespace durer
