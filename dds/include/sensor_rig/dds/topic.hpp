#pragma once
// Typed topics, writers and readers over idlc-generated C types.
// Register a type once with RIG_DDS_TYPE(c_type, descriptor) (see sensor_rig/dds/types.hpp).
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dds/entity.hpp"
#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/dds/payload_sertype.h"
#include "sensor_rig/dds/qos.hpp"

namespace sensor_rig::dds {

template <class T>
struct TypeSupport;  // specialised per message type: static const dds_topic_descriptor_t* descriptor()

#define RIG_DDS_TYPE(CType, Descriptor)                                          \
  template <>                                                                    \
  struct sensor_rig::dds::TypeSupport<CType> {                                   \
    static const dds_topic_descriptor_t* descriptor() { return &(Descriptor); } \
  }

// A type whose last variable-size member is a large sequence<uint8> `Member` followed only by 1-byte
// members (PointCloud2.data, Image.data): its topics size shared-memory chunks without serializing
// each sample twice (payload_sertype.h).
#define RIG_DDS_TYPE_WITH_PAYLOAD(CType, Descriptor, Member)                     \
  template <>                                                                    \
  struct sensor_rig::dds::TypeSupport<CType> {                                   \
    static const dds_topic_descriptor_t* descriptor() { return &(Descriptor); } \
    static constexpr std::size_t payload_offset = offsetof(CType, Member);       \
  }

// ROS topic "/a/b" -> DDS topic "rt/a/b" (rmw_cyclonedds convention).
std::string ros_to_dds_topic(const std::string& ros_name);
std::string dds_to_ros_topic(const std::string& dds_name);

template <class T>
class Topic {
 public:
  Topic(const Participant& p, const std::string& ros_name, const QosSpec& qos = {})
      : ros_name_(ros_name) {
    auto q = make_qos(qos);
    const std::string name = ros_to_dds_topic(ros_name);
    if constexpr (requires { TypeSupport<T>::payload_offset; }) {
      topic_ = Entity(check(rig_create_payload_topic(p.handle(), TypeSupport<T>::descriptor(), name.c_str(), q.get(),
                                                     TypeSupport<T>::payload_offset),
                            "dds_create_topic"));
    } else {
      topic_ = Entity(check(dds_create_topic(p.handle(), TypeSupport<T>::descriptor(), name.c_str(), q.get(), nullptr),
                            "dds_create_topic"));
    }
  }
  [[nodiscard]] dds_entity_t handle() const noexcept { return topic_.handle(); }
  [[nodiscard]] const std::string& ros_name() const noexcept { return ros_name_; }

 private:
  std::string ros_name_;
  Entity topic_;
};

// Publication/subscription match counts, for "wait for discovery".
std::uint32_t publication_matched(dds_entity_t writer);
std::uint32_t subscription_matched(dds_entity_t reader);
// Polls `count()` until it reaches `n` or `timeout_ms` passes. Returns whether it did.
template <class F>
bool wait_until(F&& done, int timeout_ms) {
  const auto deadline = monotonic_now_ns() + static_cast<Nanos>(timeout_ms) * 1'000'000;
  while (!done()) {
    if (monotonic_now_ns() > deadline) return false;
    dds_sleepfor(DDS_MSECS(5));
  }
  return true;
}

template <class T>
class Writer {
 public:
  Writer(const Participant& p, const Topic<T>& t, const QosSpec& qos = {}) {
    auto q = make_qos(qos);
    writer_ = Entity(check(dds_create_writer(p.handle(), t.handle(), q.get(), nullptr), "dds_create_writer"));
  }
  // Writes with the given source timestamp (vehicle ns), so publish time is exact and known.
  Result write(const T& sample, Nanos source_ts) const noexcept {
    return Result(dds_write_ts(writer_.handle(), &sample, static_cast<dds_time_t>(source_ts)));
  }
  Result write(const T& sample) const noexcept { return Result(dds_write(writer_.handle(), &sample)); }
  [[nodiscard]] std::uint32_t matched() const { return publication_matched(writer_.handle()); }
  bool wait_for_readers(std::uint32_t n, int timeout_ms) const {
    return wait_until([&] { return matched() >= n; }, timeout_ms);
  }
  [[nodiscard]] dds_entity_t handle() const noexcept { return writer_.handle(); }

 private:
  Entity writer_;
};

template <class T>
class Reader {
 public:
  Reader(const Participant& p, const Topic<T>& t, const QosSpec& qos = {}) {
    auto q = make_qos(qos);
    reader_ = Entity(check(dds_create_reader(p.handle(), t.handle(), q.get(), nullptr), "dds_create_reader"));
    waitset_ = Entity(check(dds_create_waitset(p.handle()), "dds_create_waitset"));
    cond_ = Entity(check(dds_create_readcondition(reader_.handle(), DDS_ANY_STATE), "dds_create_readcondition"));
    check(dds_waitset_attach(waitset_.handle(), cond_.handle(), 0), "dds_waitset_attach");
  }
  ~Reader() {
    // The condition must go before the reader it belongs to; the waitset with it.
    if (waitset_ && cond_) dds_waitset_detach(waitset_.handle(), cond_.handle());
  }
  Reader(Reader&&) noexcept = default;

  // Blocks until data is available or timeout; true when data is there.
  bool wait(int timeout_ms) const noexcept {
    return dds_waitset_wait(waitset_.handle(), nullptr, 0, DDS_MSECS(timeout_ms)) > 0;
  }

  // Takes up to `max` samples as loans and calls fn(const T&, const dds_sample_info_t&) for each
  // valid one. No copies, no allocations by the caller. Returns the number of valid samples.
  template <class F>
  int take(F&& fn, int max = 32) const {
    constexpr int kBatch = 32;
    void* ptrs[kBatch] = {};
    dds_sample_info_t infos[kBatch];
    int valid = 0;
    int left = max;
    while (left > 0) {
      const int want = left < kBatch ? left : kBatch;
      const dds_return_t n = dds_take(reader_.handle(), ptrs, infos, static_cast<size_t>(want),
                                      static_cast<uint32_t>(want));
      if (n <= 0) break;
      for (int i = 0; i < n; ++i) {
        if (infos[i].valid_data) {
          fn(*static_cast<const T*>(ptrs[i]), infos[i]);
          ++valid;
        }
      }
      dds_return_loan(reader_.handle(), ptrs, n);
      left -= n;
      if (n < want) break;
    }
    return valid;
  }
  [[nodiscard]] std::uint32_t matched() const { return subscription_matched(reader_.handle()); }
  bool wait_for_writers(std::uint32_t n, int timeout_ms) const {
    return wait_until([&] { return matched() >= n; }, timeout_ms);
  }
  [[nodiscard]] dds_entity_t handle() const noexcept { return reader_.handle(); }

 private:
  Entity reader_;
  Entity waitset_;
  Entity cond_;
};

}  // namespace sensor_rig::dds
