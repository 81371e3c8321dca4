#pragma once
// Frames and the bounded buffer pool they live in. A source fills a pool buffer (or a V4L2 mmap
// buffer) once; the driver publishes that same memory as Image.data and then drops the Frame,
// which hands the buffer back to its source: no copy per frame, no allocation per frame.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

#include "sensor_rig/camera/pixel_format.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::camera {

// Which clock FrameMeta::device_ns is in; the driver maps it to vehicle time (timesync).
enum class TimeDomain : std::uint8_t {
  kDeviceTicks = 0,  // a free-running device clock (GigE timestamp): map through the estimator
  kMonotonic,        // host CLOCK_MONOTONIC (V4L2): map with the offset sampled at this frame
  kVehicle,          // already vehicle time (PTP-synced device)
};
const char* to_string(TimeDomain d) noexcept;

struct FrameMeta {
  std::uint64_t seq = 0;          // device frame id (or the source's counter)
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t step = 0;         // bytes per row
  PixelFormat format = PixelFormat::kMono8;
  Nanos device_ns = 0;            // exposure start in `domain`
  TimeDomain domain = TimeDomain::kDeviceTicks;
  // The device's own reading before any conversion (PTP TAI -> UTC): what the clock mapper is fed,
  // so a PTP stamp found implausible falls back to a fresh mapping. 0: the same as device_ns.
  Nanos device_ticks_ns = 0;
  Nanos first_rx_ns = 0;          // host CLOCK_REALTIME: first packet (GigE leader) / buffer ready
  Nanos complete_ns = 0;          // host CLOCK_REALTIME: frame complete, handed to the caller
  Nanos complete_mono_ns = 0;     // CLOCK_MONOTONIC sampled with complete_ns (same instant)
  std::uint32_t packets = 0;      // GigE packets of this frame (0: not packetised)
  // The exposure time of frame `exposure_seq` (this one or an earlier one) as the device reported
  // it, ns; 0: not known per frame. The clock mapping follows an exposure that changes while
  // streaming (auto exposure, another controller) with it (issue 27 item 9).
  std::uint64_t exposure_seq = 0;
  Nanos exposure_ns = 0;
  // The frame's ChunkTimestamp in ns of the device clock (the leader's clock, before any PTP
  // conversion), from a camera in chunk mode; 0: no chunk (issue 27 item 3).
  Nanos chunk_timestamp_ns = 0;
};

// A filled buffer on loan from its source; move-only; gives the buffer back when destroyed.
class Frame {
 public:
  Frame() = default;
  Frame(FrameMeta meta, std::span<std::uint8_t> data, std::function<void()> release)
      : meta_(meta), data_(data), release_(std::move(release)) {}
  Frame(Frame&& o) noexcept { *this = std::move(o); }
  Frame& operator=(Frame&& o) noexcept {
    if (this != &o) {
      reset();
      meta_ = o.meta_;
      data_ = o.data_;
      release_ = std::move(o.release_);
      o.release_ = nullptr;
      o.data_ = {};
    }
    return *this;
  }
  Frame(const Frame&) = delete;
  Frame& operator=(const Frame&) = delete;
  ~Frame() { reset(); }

  [[nodiscard]] const FrameMeta& meta() const noexcept { return meta_; }
  [[nodiscard]] FrameMeta& meta() noexcept { return meta_; }
  [[nodiscard]] std::span<std::uint8_t> data() const noexcept { return data_; }
  [[nodiscard]] bool empty() const noexcept { return data_.empty(); }
  void reset() noexcept {
    if (release_) release_();
    release_ = nullptr;
    data_ = {};
  }

 private:
  FrameMeta meta_;
  std::span<std::uint8_t> data_;
  std::function<void()> release_;
};

// `count` buffers of `bytes` each, allocated (and touched) once. Thread-safe.
class BufferPool {
 public:
  BufferPool(std::size_t count, std::size_t bytes);
  BufferPool(const BufferPool&) = delete;
  BufferPool& operator=(const BufferPool&) = delete;

  [[nodiscard]] std::optional<std::size_t> acquire();  // nullopt: all on loan (an underrun)
  void release(std::size_t index);
  [[nodiscard]] std::span<std::uint8_t> buffer(std::size_t index) const noexcept;
  [[nodiscard]] std::size_t count() const noexcept { return buffers_.size(); }
  [[nodiscard]] std::size_t bytes() const noexcept { return bytes_; }
  [[nodiscard]] std::size_t available() const;

 private:
  std::size_t bytes_;
  std::vector<std::unique_ptr<std::uint8_t[]>> buffers_;
  mutable std::mutex mutex_;
  std::vector<std::size_t> free_;
};

}  // namespace sensor_rig::camera
