#pragma once
// Cuts a synthetic sensor's packets into scans exactly as the rig's decoders do (UnitRule), so a
// truth record's units are the scans the rig should publish: each packet gets the units it has
// data in (a packet across a Velodyne cut or inside Hesai's window belongs to two, and the
// decoders count it in both), and a unit is closed, with its first firing and the packets it was
// made of, once no later packet can touch it. Pure: packets' truth in, units out.
#include <cstdint>
#include <span>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/mock/synthetic_sensor.hpp"

namespace sensor_rig::lidar::mock {

struct UnitSpan {
  std::int64_t first = 0;  // the unit of the packet's first group
  std::int64_t last = 0;   // the last unit it has data in
};

struct ClosedUnit {
  std::int64_t unit = 0;
  Nanos acq_ns = 0;  // its first firing (the decoder's scan stamp)
  Nanos dev_ns = 0;  // the sensor clock then
  std::uint32_t parts = 0;
};

class UnitTracker {
 public:
  explicit UnitTracker(UnitRule rule) noexcept : rule_(rule) {}
  // A new rule (the sensor was replaced mid-run); the scan in progress goes on.
  void set_rule(UnitRule rule) noexcept { rule_ = rule; }

  // One data packet in time order. `counted`: the sensor produced it (a blind sector's packets
  // are not parts of a scan, but their azimuths still move the cut).
  UnitSpan add(const PacketTruth& t, bool counted);
  // The sensor rebooted (a time jump to the decoders): the open units end, the next group starts one.
  void restart() noexcept;
  // Closes every open unit (end of the run).
  void finish();
  // Units closed so far; the caller takes them (clear()) as it writes them.
  std::vector<ClosedUnit>& closed() noexcept { return closed_; }

 private:
  struct Open {
    std::int64_t unit = 0;
    Nanos acq_ns = 0, dev_ns = 0;
    std::uint32_t parts = 0;
    bool started = false;
  };
  void start(Open& u, Nanos acq, Nanos dev) noexcept;
  void close_current();

  UnitRule rule_;
  Open cur_, next_;  // next_: Hesai's scan that started inside the window
  bool have_cur_ = false;
  bool have_prev_ = false;
  bool window_open_ = false;
  bool force_new_ = false;
  int prev_az_ = 0;
  std::uint32_t prev_frame_ = 0;
  std::int64_t next_unit_ = 0;
  std::vector<ClosedUnit> closed_;
};

}  // namespace sensor_rig::lidar::mock
