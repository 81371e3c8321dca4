// Load-generator node: publisher (absolute-deadline timer at F Hz from the common start time) or
// subscriber (one waitset over all its readers, stamps on receipt, per-message CSV).
#include "sensor_rig/bench/perf/node.hpp"

#include <sched.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <thread>
#include <vector>

#include <fstream>
#include <nlohmann/json.hpp>

#include "node_io.hpp"
#include "node_types.hpp"
#include "sensor_rig/bench/perf/records.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/common/thread_priority.hpp"
#include "sensor_rig/dds/shared_memory.hpp"
#include "sensor_rig/dds/view_reader.hpp"
#include "sensor_rig/dds/waitset.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::bench::perf {
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const noexcept { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

File open_csv(const std::string& path) {
  File f(std::fopen(path.c_str(), "w"));
  if (!f) throw std::runtime_error("cannot write '" + path + "': " + std::strerror(errno));
  return f;
}

dds::QosSpec perf_qos(int depth) {
  dds::QosSpec q;  // reliable, volatile (ROS 2 default QoS)
  q.depth = depth;
  q.max_blocking_ms = 100;
  return q;
}

void sleep_until_realtime(Nanos t) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(t % 1'000'000'000);
  while (::clock_nanosleep(CLOCK_REALTIME, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    if (shutdown_requested()) return;
  }
}

// A sample to copy from (no loans): payload filled once; the payload seq field stays default.
// PointCloud2 as the LIDAR driver fills it (lidar_driver.cpp): the rig's 24-byte point layout, one
// row; S is rarely a multiple of 24, so the row holds S / 24 points and row_step = S (trailing pad).
template <class T>
struct OwnedSample {
  std::unique_ptr<T> sample = std::make_unique<T>();
  std::vector<std::uint8_t> bytes;
  std::vector<char> frame_id;                // heap: stays put if this struct moves
  std::vector<msg::PointField> fields;
  explicit OwnedSample(std::uint32_t size) {
    std::memset(static_cast<void*>(sample.get()), 0, sizeof(T));
    if constexpr (std::is_same_v<T, PerfSeq>) {
      bytes.assign(size, 0x5a);
      sample->header.frame_id = const_cast<char*>("perf");
      sample->data._buffer = bytes.data();
      sample->data._length = sample->data._maximum = size;
      sample->data._release = false;
    } else if constexpr (std::is_same_v<T, PointCloud2>) {
      bytes.assign(size, 0x5a);
      frame_id.assign(kCloudFrameIdSize, '\0');
      fields = msg::point_fields(lidar::kPointFields);
      T& pc = *sample;
      pc.header.frame_id = frame_id.data();
      pc.height = 1;
      pc.point_step = sizeof(lidar::PointXYZIRT);
      pc.width = size / pc.point_step;
      pc.row_step = size;
      pc.fields._buffer = fields.data();
      pc.fields._length = pc.fields._maximum = static_cast<std::uint32_t>(fields.size());
      pc.fields._release = false;
      pc.is_bigendian = false;
      pc.is_dense = true;
      pc.data._buffer = bytes.data();
      pc.data._length = pc.data._maximum = size;
      pc.data._release = false;
    }
  }
};

// How the samples travelled (summary.json "loans"): loaned iceoryx chunks or copies.
struct DataPath {
  bool shared_memory = false;  // Cyclone uses iceoryx for this endpoint
  bool loan_available = false; // writer: loans possible (fixed-size types over shm)
  std::uint64_t loaned_writes = 0, copied_writes = 0, failed_writes = 0;
  std::uint64_t zero_copy_takes = 0, copied_takes = 0;
  std::uint64_t malformed_drops = 0;  // --reader view: samples whose bytes did not parse
};

void write_stats(const std::string& path, Role role, const DataPath& d) {
  if (path.empty()) return;
  nlohmann::json j = {{"role", role == Role::kPublisher ? "pub" : "sub"}, {"shared_memory", d.shared_memory}};
  if (role == Role::kPublisher) {
    j["loan_available"] = d.loan_available;
    j["loaned_writes"] = d.loaned_writes;
    j["copied_writes"] = d.copied_writes;
    j["failed_writes"] = d.failed_writes;
  } else {
    j["zero_copy_takes"] = d.zero_copy_takes;
    j["copied_takes"] = d.copied_takes;
    j["malformed_drops"] = d.malformed_drops;
  }
  std::ofstream(path) << j.dump() << "\n";
}

template <class T>
int run_publisher(const NodeArgs& a, const dds::Participant& p) {
  const int topic_index = a.topics.front();
  dds::Topic<T> topic(p, topic_name(a.run_id, topic_index), perf_qos(a.depth));
  dds::Writer<T> writer(p, topic, perf_qos(a.depth));
  DataPath path;
  path.loan_available = dds::loan_available(writer.handle());
  path.shared_memory = dds::uses_shared_memory(writer.handle());
  const bool loan = a.loan && path.loan_available;
  if (!writer.wait_for_readers(static_cast<std::uint32_t>(a.expected_matches), a.discovery_timeout_ms)) {
    log::error("perf", "publisher " + std::to_string(a.index) + ": only " + std::to_string(writer.matched()) + " of " +
                           std::to_string(a.expected_matches) + " readers matched");
    return 1;
  }
  log::info("perf", "publisher " + std::to_string(a.index) + ": shared memory " + (path.shared_memory ? "yes" : "no") +
                        ", loans " + (loan ? "yes" : "no"));
  OwnedSample<T> owned(a.size);
  std::vector<PubRecord> records(a.count);
  announce_ready();
  const auto t0 = wait_for_start();
  if (!t0) return 1;

  const double period_d = 1e9 / a.rate_hz;
  const auto period = static_cast<Nanos>(period_d);
  const Nanos end = *t0 + static_cast<Nanos>(std::llround(period_d * a.count));
  const auto pub_id = static_cast<std::uint32_t>(topic_index);
  for (std::uint32_t i = 0; i < a.count; ++i) {
    PubRecord& r = records[i];
    r.seq = i;
    r.deadline_ns = *t0 + static_cast<Nanos>(std::llround(period_d * i));
    if (vehicle_now_ns() < r.deadline_ns) sleep_until_realtime(r.deadline_ns);
    if (shutdown_requested() || vehicle_now_ns() >= end) break;  // the rest stay "not sent"
    T* sample = owned.sample.get();
    if (loan) {
      void* loaned = dds::loan_sample(writer.handle());
      if (loaned == nullptr) {
        ++path.failed_writes;
        continue;  // no chunk: not sent
      }
      sample = static_cast<T*>(loaned);
    }
    write_ids(*sample, pub_id, i);
    const Nanos stamp = vehicle_now_ns();  // immediately before publishing
    write_stamp(*sample, stamp);
    const dds::Result rc = writer.write(*sample, stamp);
    const Nanos after = vehicle_now_ns();
    if (!rc.ok()) {
      ++path.failed_writes;
      continue;
    }
    ++(loan ? path.loaned_writes : path.copied_writes);
    r.stamp_ns = stamp;
    r.write_ns = after - stamp;
    r.status = classify_send(stamp, r.deadline_ns, period);
  }
  for (std::uint32_t i = 0; i < a.count; ++i) {
    records[i].seq = i;
    if (records[i].deadline_ns == 0) records[i].deadline_ns = *t0 + static_cast<Nanos>(std::llround(period_d * i));
  }
  // Nothing heavy (CSV, teardown) before the run's end: with every publisher on the same deadlines,
  // one that finished first must not take the CPU from the others' last messages.
  // The writer also lingers 200 ms: Cyclone drops shared-memory samples that arrive after their
  // writer was deleted, so an early exit would lose the last message.
  sleep_until_realtime(std::max(end, vehicle_now_ns()) + 200'000'000);
  if (a.rt_priority > 0) {
    sched_param sp{};
    ::sched_setscheduler(0, SCHED_OTHER, &sp);  // this thread: wrap-up at normal priority
  }
  // Let reliable delivery finish before the writer goes (bounded).
  dds::wait_for_acks(writer.handle(), 5'000'000'000);
  File f = open_csv(a.csv);
  write_pub_csv(f.get(), records);
  write_stats(a.stats, Role::kPublisher, path);
  if (path.failed_writes > 0) {
    log::warn("perf", "publisher " + std::to_string(a.index) + ": " + std::to_string(path.failed_writes) + " writes failed");
  }
  return 0;
}

template <class T>
int run_subscriber(const NodeArgs& a, const dds::Participant& p) {
  std::vector<std::unique_ptr<dds::Topic<T>>> topics;
  std::vector<std::unique_ptr<dds::Reader<T>>> readers;
  for (int t : a.topics) {
    topics.push_back(std::make_unique<dds::Topic<T>>(p, topic_name(a.run_id, t), perf_qos(a.depth)));
    readers.push_back(std::make_unique<dds::Reader<T>>(p, *topics.back(), perf_qos(a.depth)));
  }
  // One waitset over every reader plus a guard condition the stop watcher triggers.
  dds::WaitSet waitset(p);
  for (std::size_t i = 0; i < readers.size(); ++i) waitset.attach_reader(readers[i]->handle(), static_cast<std::int64_t>(i));
  waitset.attach_guard(-1);

  const auto deadline = monotonic_now_ns() + static_cast<Nanos>(a.discovery_timeout_ms) * 1'000'000;
  for (const auto& r : readers) {
    const auto left = static_cast<int>((deadline - monotonic_now_ns()) / 1'000'000);
    if (!r->wait_for_writers(1, left > 0 ? left : 0)) {
      log::error("perf", "subscriber " + std::to_string(a.index) + ": a writer did not match");
      return 1;
    }
  }
  File f = open_csv(a.csv);
  std::setvbuf(f.get(), nullptr, _IOFBF, 1 << 16);
  write_sub_header(f.get());
  std::fflush(f.get());
  announce_ready();
  StopWatcher stop([&waitset] { waitset.wake(); });

  constexpr bool kFixed = !std::is_same_v<T, PerfSeq> && !std::is_same_v<T, PointCloud2>;
  DataPath path;
  path.shared_memory = dds::uses_shared_memory(readers.front()->handle());
  const bool zero_copy = kFixed && a.loan && path.shared_memory;
  const bool view = std::is_same_v<T, PointCloud2> && a.reader == ReaderMode::kView;
  log::info("perf", "subscriber " + std::to_string(a.index) + ": shared memory " + (path.shared_memory ? "yes" : "no") +
                        ", zero-copy take " + (zero_copy ? "yes" : "no") + ", reader " + to_string(a.reader));
  dds::PointCloud2View cloud_view;  // its field list reused sample to sample
  OwnedSample<T> scratch(0);
  // Large samples one at a time: a loaned take allocates sizeof(T) x the batch size per reader.
  const int batch = sizeof(T) > 4096 ? 1 : 32;
  auto take_all = [&](std::size_t ri) {
    const auto topic = static_cast<std::uint32_t>(a.topics[ri]);
    auto record = [&](const T& s) {
      const Nanos recv = vehicle_now_ns();  // stamp on receipt
      const PerfStamp st = read_stamp(s);
      write_sub_row(f.get(), SubRecord{topic, st.seq, st.stamp_ns, recv});
    };
    if (view) {
      // Serialized samples read in place (in the chunk over shm): stamped once the view is valid.
      dds::ViewCounts counts;
      const int n = dds::take_views(readers[ri]->handle(), cloud_view, counts, [&](const dds::PointCloud2View& v, const dds_sample_info_t&) {
        const Nanos recv = vehicle_now_ns();
        const PerfStamp st = read_stamp(v);
        write_sub_row(f.get(), SubRecord{topic, st.seq, st.stamp_ns, recv});
      });
      path.zero_copy_takes += counts.in_chunk;
      path.copied_takes += counts.in_serdata;
      path.malformed_drops += counts.malformed;
      return n;
    }
    if (zero_copy) {
      dds::TakeCounts counts;
      const int n = dds::take_in_place(readers[ri]->handle(), *scratch.sample, counts, record);
      path.zero_copy_takes += counts.zero_copy;
      path.copied_takes += counts.copied;
      return n;
    }
    int total = 0;
    for (int got = 1; got > 0;) {
      got = readers[ri]->take([&](const T& s, const dds_sample_info_t&) { record(s); }, batch);
      total += got;
      if (batch > 1) break;
    }
    path.copied_takes += static_cast<std::uint64_t>(total);
    return total;
  };
  std::vector<std::int64_t> triggered;
  Nanos last_flush = monotonic_now_ns();
  while (!stop.stopped() && !shutdown_requested()) {
    waitset.wait(triggered, 1'000'000'000);
    for (const auto tag : triggered) {
      if (tag >= 0) take_all(static_cast<std::size_t>(tag));
    }
    if (monotonic_now_ns() - last_flush > 1'000'000'000) {  // a killed node keeps what it had
      std::fflush(f.get());
      last_flush = monotonic_now_ns();
    }
  }
  // Drain: whatever is still queued, until 200 ms pass with nothing new.
  const Nanos drain_end = monotonic_now_ns() + 2'000'000'000;
  Nanos idle_since = monotonic_now_ns();
  while (monotonic_now_ns() < drain_end && monotonic_now_ns() - idle_since < 200'000'000) {
    int got = 0;
    for (std::size_t i = 0; i < readers.size(); ++i) got += take_all(i);
    if (got > 0) idle_since = monotonic_now_ns();
    else std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::fflush(f.get());
  write_stats(a.stats, Role::kSubscriber, path);
  return 0;
}

template <class T>
int run_typed(const NodeArgs& a) {
  if (a.rt_priority > 0) {  // before the participant: Cyclone's threads inherit the policy
    if (const auto r = try_realtime_priority(a.rt_priority); !r)
      log::warn("perf", "SCHED_FIFO not available: " + r.why_not);
  }
  dds::Participant p(dds::DomainConfig{static_cast<dds_domainid_t>(a.domain), a.profile});
  return a.role == Role::kPublisher ? run_publisher<T>(a, p) : run_subscriber<T>(a, p);
}

}  // namespace

std::string topic_name(const std::string& run_id, int topic) {
  return "/perf/r" + run_id + "/t" + std::to_string(topic);
}

int run_node(const NodeArgs& a) {
  if (a.topics.empty()) throw std::invalid_argument("node without topics");
  if (a.role == Role::kPublisher && a.topics.size() != 1) throw std::invalid_argument("a publisher has one topic");
  if (a.message == Message::kSeq) return run_typed<PerfSeq>(a);
  if (a.message == Message::kPointCloud2) return run_typed<PointCloud2>(a);
  switch (a.size) {
    case 0: return run_typed<PerfFixed0>(a);
    case 16: return run_typed<PerfFixed16>(a);
    case 65536: return run_typed<PerfFixed64k>(a);
    case 524288: return run_typed<PerfFixed512k>(a);
    case 1048576: return run_typed<PerfFixed1m>(a);
    case 2097152: return run_typed<PerfFixed2m>(a);
    default: throw std::invalid_argument("no fixed-size perf type for " + std::to_string(a.size) + " bytes");
  }
}

}  // namespace sensor_rig::bench::perf
