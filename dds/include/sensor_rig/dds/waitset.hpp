#pragma once
// One waitset over several readers plus a guard condition another thread triggers (stop): a node
// that serves many topics sleeps in one place and learns which readers have data.
#include <cstdint>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dds/participant.hpp"

namespace sensor_rig::dds {

class WaitSet {
 public:
  explicit WaitSet(const Participant& p);  // throws DdsError
  WaitSet(const WaitSet&) = delete;
  WaitSet& operator=(const WaitSet&) = delete;
  ~WaitSet();

  // Wakes wait() with `tag` when the reader has data (any sample state). Throws DdsError.
  void attach_reader(dds_entity_t reader, std::int64_t tag);
  // Detaches and deletes the read conditions of `reader` (before the reader goes, for a waitset
  // whose readers come and go, as `rig view`'s). Never throws.
  void detach_reader(dds_entity_t reader) noexcept;
  // Wakes wait() with `tag` after wake(); thread-safe.
  void attach_guard(std::int64_t tag);
  void wake() noexcept;
  // Untriggers the guard: a waitset whose guard carries repeated requests (not a one-off stop)
  // calls this before handling them, or every wait() returns at once.
  void clear_guard() noexcept;

  // Waits up to timeout_ns; `tags` gets the tags that triggered (empty on timeout).
  void wait(std::vector<std::int64_t>& tags, Nanos timeout_ns);

 private:
  Entity waitset_;
  Entity guard_;
  std::vector<Entity> conditions_;
  std::vector<dds_attach_t> triggered_;
};

}  // namespace sensor_rig::dds
