#include "durer/HugeArray.h"

#include <mutex>

namespace durer {
namespace {

struct Kept {
  std::mutex mutex;
  HugeBlocks::Block blocks[HugeBlocks::kKept];  // oldest first
  int count = 0;
  size_t total = 0;

  void remove(int i) {
    for (int j = i + 1; j < count; ++j) blocks[j - 1] = blocks[j];
    --count;
  }
};

// Never destroyed: arrays freed while the process exits still find it.
Kept& kept() {
  static Kept* k = new Kept;
  return *k;
}

}  // namespace

HugeBlocks::Block HugeBlocks::take(size_t bytes) {
  Kept& k = kept();
  const std::unique_lock<std::mutex> lock(k.mutex, std::try_to_lock);
  if (!lock.owns_lock()) return {nullptr, 0};
  int best = -1;
  for (int i = 0; i < k.count; ++i) {
    const size_t size = k.blocks[i].bytes;
    if (size >= bytes && size / 2 <= bytes && (best < 0 || size < k.blocks[best].bytes)) best = i;
  }
  if (best < 0) return {nullptr, 0};
  const Block block = k.blocks[best];
  k.total -= block.bytes;
  k.remove(best);
  return block;
}

void HugeBlocks::give(Block block) {
#if defined(__linux__) && defined(MADV_FREE)
  Block evicted[kKept];
  int count = 0;
  if (block.bytes <= kKeptBytes && madvise(block.memory, block.bytes, MADV_FREE) == 0) {
    Kept& k = kept();
    std::unique_lock<std::mutex> lock(k.mutex, std::try_to_lock);
    if (lock.owns_lock()) {
      while (k.count == kKept || k.total + block.bytes > kKeptBytes) {
        evicted[count++] = k.blocks[0];
        k.total -= k.blocks[0].bytes;
        k.remove(0);
      }
      k.blocks[k.count++] = block;
      k.total += block.bytes;
      lock.unlock();
      for (int i = 0; i < count; ++i) std::free(evicted[i].memory);  // not under the lock: it takes milliseconds
      return;
    }
  }
#endif
  std::free(block.memory);
}

}  // namespace durer
