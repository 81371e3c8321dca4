#include "sensor_rig/common/heap.hpp"

#include <malloc.h>

namespace sensor_rig {
namespace {
// Blocks below this come from the heap and are reused; 32 MB is the most glibc accepts.
constexpr int kMmapThreshold = 32 << 20;
// The free top of the heap is given back to the kernel only beyond this: a few samples' worth.
constexpr int kTrimThreshold = 64 << 20;
}  // namespace

bool keep_large_buffers() noexcept {
  // Fixed values also turn off glibc's moving thresholds (they rise only after a block is freed,
  // so every cloud larger than any before was mmapped and faulted in anew).
  return mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1 && mallopt(M_TRIM_THRESHOLD, kTrimThreshold) == 1;
}

}  // namespace sensor_rig
