#pragma once
// A writer of an optional, costly topic (a LIDAR's raw packets, the CAN bus's frames) that its
// driver fills only while some reader is matched: a publication-matched listener keeps the count in
// an atomic, so the driver's hot path pays one relaxed load per batch when nobody records
// (docs/recording.md "Raw channels"). Publishing on demand instead of behind a config switch means
// `rig record --raw` (or a named raw topic) turns the channel on and off from the outside.
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "sensor_rig/dds/topic.hpp"

namespace sensor_rig::dds {

// The matched-reader count of one writer, kept by Cyclone's listener thread.
class MatchedCount {
 public:
  MatchedCount() = default;
  MatchedCount(const MatchedCount&) = delete;  // Cyclone holds its address
  MatchedCount& operator=(const MatchedCount&) = delete;
  // A listener that stores the count into `count` (the caller keeps `count` alive beyond the writer).
  static dds_listener_t* make_listener(MatchedCount* count);
  // After the writer exists: the count as it is (a match before the listener ran is not missed).
  void refresh(dds_entity_t writer) noexcept;
  [[nodiscard]] bool any() const noexcept { return n_.load(std::memory_order_relaxed) > 0; }

 private:
  static void on_matched(dds_entity_t writer, dds_publication_matched_status_t status, void* arg);
  std::atomic<std::uint32_t> n_{0};
};

template <class T>
class OnDemandWriter {
 public:
  OnDemandWriter(const Participant& p, const std::string& ros_name, const QosSpec& qos)
      : count_(std::make_unique<MatchedCount>()), topic_(p, ros_name, qos) {
    auto q = make_qos(qos);
    dds_listener_t* l = MatchedCount::make_listener(count_.get());
    const dds_entity_t w = dds_create_writer(p.handle(), topic_.handle(), q.get(), l);
    dds_delete_listener(l);
    // An optional channel the security grants do not name (permissions made before it existed)
    // stays off, and says so (refused()), rather than stopping the node it belongs to.
    if (w == DDS_RETCODE_NOT_ALLOWED_BY_SECURITY) {
      refused_ = true;
      return;
    }
    writer_ = Entity(check(w, "dds_create_writer"));
    count_->refresh(writer_.handle());
  }
  // Whether a reader is matched: only then is a sample worth making (never when refused()).
  [[nodiscard]] bool active() const noexcept { return count_->any(); }
  // Whether DDS Security refused this writer (its topic is not in the participant's grants).
  [[nodiscard]] bool refused() const noexcept { return refused_; }
  Result write(const T& sample, Nanos source_ts) const noexcept {
    return Result(dds_write_ts(writer_.handle(), &sample, static_cast<dds_time_t>(source_ts)));
  }
  [[nodiscard]] const std::string& ros_name() const noexcept { return topic_.ros_name(); }
  [[nodiscard]] dds_entity_t handle() const noexcept { return writer_.handle(); }

 private:
  std::unique_ptr<MatchedCount> count_;  // outlives writer_ (declared first, destroyed last)
  Topic<T> topic_;
  Entity writer_;
  bool refused_ = false;
};

}  // namespace sensor_rig::dds
