// A foreign DDS subscriber, as a ROS 2 node with rmw_fastrtps and its defaults would be: Fast DDS
// (Debian's 2.9.1), the default participant (UDPv4 + SHM transports, OS socket buffers), a reader of
// `sensor_msgs::msg::dds_::PointCloud2_` with ROS 2's default QoS (reliable, volatile, keep-last 10)
// or its sensor-data QoS (best effort, keep-last 5), and what rmw_fastrtps sets on top (Iron,
// the rmw of Fast DDS 2.9/2.10: PREALLOCATED_WITH_REALLOC histories for types without a bound, data
// sharing off). No fastddsgen here: the type is written by hand and keeps the serialized payload;
// the CDR fields that identify a scan and prove it whole (header.stamp, height, width, point_step,
// row_step, data length) are read from it.
//
// fastdds_pointcloud_sub --topic rt/... [--topic rt/... ...] [--domain N] [--qos default|sensor_data]
//                        --count N [--take-in executor|listener] [--localhost-only 0|1] [--wait-s W]
//                        [--timeout-s S] [--quiet-ms MS]
// Several --topic: one participant (one socket, as one ROS 2 node) with a reader each; --count per
// topic; one JSON line per topic.
// --take-in executor (default): as rclcpp over rmw_fastrtps, the listener only signals; the main
//   thread (the executor) waits on a WaitSet of the readers' data-available conditions, and for each
//   reader with an untaken sample (get_first_untaken_info) takes one (take(..., 1), as rmw_take),
//   then waits again. listener: takes every sample inside on_data_available, on Fast DDS's receive
//   thread (what a plain Fast DDS application often does).
// --localhost-only 1: what rmw_fastrtps (Humble) does for ROS_LOCALHOST_ONLY=1: its own UDPv4
//   transport restricted to 127.0.0.1 (OS buffers) and SHM instead of the built-in ones. Needed
//   for the rig on `lo` when the host has another interface up (docs/foreign-subscribers.md).
// --wait-s W (60): bound for the readers to match and the first sample to arrive (a cold or loaded
//   host). --timeout-s S (30): the time for the scans, counted from the first sample taken.
// --quiet-ms MS (2000): stop once every topic had data and none came for MS.
// SIGTERM/SIGINT: stop and report as at the end (and delete the participant, so Fast DDS removes
// its /dev/shm files).
// With FASTRTPS_DEFAULT_PROFILES_FILE set, the participant is that profile's default one (U: its
// UDP receive buffer, 0 = the OS default). Prints, when a reader matched a writer,
// `matched <topic> writer <guid> reader <guid> udp <port>` (GUIDs in hex as on the wire, the
// reader's unicast port on 127.0.0.1), `data` at the first sample, then per topic one JSON line:
// {"topic":T,"take_in":"executor","udp_receive_buffer":U,"received":R,"whole":W,"broken":B,
//  "phantom":P,"phantom_bytes":PB,"repeated":D,"out_of_order":O,"lost_reported":L,"max_delay_ms":M,
//  "stamps":[ns,...]}
// received/whole/broken/stamps: samples from a writer. phantom: samples Fast DDS handed out that no
// writer sent (writer GUID unknown: a CacheChange already returned to its pool, the Fast DDS defect
// in docs/foreign-subscribers.md), PB the largest payload of one. repeated: a stamp taken again;
// out_of_order: a stamp older than the one before it; max_delay_ms: of the whole scans.
// Exit 0 with N whole scans on every topic and none broken, phantom, repeated or out of order; 1
// otherwise (also: nothing within --wait-s, said on stderr); 2 bad usage.
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastdds/dds/core/StackAllocatedSequence.hpp>
#include <fastdds/dds/core/condition/WaitSet.hpp>
#include <fastdds/dds/core/status/StatusMask.hpp>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
using Clock = std::chrono::steady_clock;

// The sample: the CDR payload as it came (encapsulation header included).
struct RawCloud {
  std::vector<std::uint8_t> cdr;
};

// Reads XCDR1 little-endian fields, aligned from the start of the body (after the 4-byte
// encapsulation header); every read checks the length.
class CdrReader {
 public:
  explicit CdrReader(const std::vector<std::uint8_t>& cdr) : cdr_(cdr) {}
  std::optional<std::uint32_t> u32() {
    align(4);
    if (pos_ + 4 > cdr_.size()) return std::nullopt;
    std::uint32_t v = 0;
    std::memcpy(&v, cdr_.data() + pos_, 4);  // x86: the host is little-endian, as the writer's CDR
    pos_ += 4;
    return v;
  }
  bool skip(std::size_t n) {
    if (pos_ + n > cdr_.size()) return false;
    pos_ += n;
    return true;
  }
  bool skip_string() {
    const auto len = u32();
    return len && skip(*len);
  }
  [[nodiscard]] std::size_t left() const { return cdr_.size() - pos_; }

 private:
  void align(std::size_t n) { pos_ = kBody + (pos_ - kBody + n - 1) / n * n; }
  static constexpr std::size_t kBody = 4;
  const std::vector<std::uint8_t>& cdr_;
  std::size_t pos_ = kBody;
};

struct CloudSummary {
  std::int64_t stamp_ns = 0;
  bool whole = false;
};

// A scan is whole when its data is height x row_step bytes, row_step covers width points, and the
// payload ends with is_dense right after the data.
CloudSummary summarize(const RawCloud& c) {
  CloudSummary s;
  if (c.cdr.size() < 4 || c.cdr[1] != 0x01) return s;  // CDR_LE
  CdrReader r(c.cdr);
  const auto sec = r.u32();
  const auto nsec = r.u32();
  if (!sec || !nsec || !r.skip_string()) return s;
  s.stamp_ns = static_cast<std::int64_t>(static_cast<std::int32_t>(*sec)) * 1'000'000'000 + *nsec;
  const auto height = r.u32();
  const auto width = r.u32();
  const auto fields = r.u32();
  if (!height || !width || !fields) return s;
  for (std::uint32_t i = 0; i < *fields; ++i) {
    // name, offset, datatype (1 byte), count
    if (!r.skip_string() || !r.u32() || !r.skip(1) || !r.u32()) return s;
  }
  if (!r.skip(1)) return s;  // is_bigendian
  const auto point_step = r.u32();
  const auto row_step = r.u32();
  const auto data_len = r.u32();
  if (!point_step || !row_step || !data_len) return s;
  const std::uint64_t expected = std::uint64_t{*height} * *row_step;
  s.whole = *data_len == expected && std::uint64_t{*row_step} >= std::uint64_t{*width} * *point_step &&
            r.skip(*data_len) && r.left() >= 1;  // + is_dense
  return s;
}

std::int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

class PointCloud2Type : public fdds::TopicDataType {
 public:
  PointCloud2Type() {
    setName("sensor_msgs::msg::dds_::PointCloud2_");
    m_typeSize = 4096;          // unbounded: an initial payload size, grown per sample (as rmw_fastrtps)
    m_isGetKeyDefined = false;  // ROS 2 types have no key
    auto_fill_type_object(false);
    auto_fill_type_information(false);
  }
  bool serialize(void* data, rtps::SerializedPayload_t* payload) override {
    const auto& c = *static_cast<RawCloud*>(data);
    if (payload->max_size < c.cdr.size()) return false;  // sized by getSerializedSizeProvider
    std::memcpy(payload->data, c.cdr.data(), c.cdr.size());
    payload->length = static_cast<std::uint32_t>(c.cdr.size());
    return true;
  }
  bool deserialize(rtps::SerializedPayload_t* payload, void* data) override {
    auto& c = *static_cast<RawCloud*>(data);
    c.cdr.assign(payload->data, payload->data + payload->length);
    return true;
  }
  std::function<std::uint32_t()> getSerializedSizeProvider(void* data) override {
    return [data] { return static_cast<std::uint32_t>(static_cast<RawCloud*>(data)->cdr.size()); };
  }
  void* createData() override { return new RawCloud(); }
  void deleteData(void* data) override { delete static_cast<RawCloud*>(data); }
  bool getKey(void*, rtps::InstanceHandle_t*, bool) override { return false; }
};

enum class TakeIn { kExecutor, kListener };

struct Options {
  std::vector<std::string> topics;  // --topic, repeatable: one participant reading them all, as one node
  int domain = 0;
  bool sensor_data = false;
  int count = 0;
  TakeIn take_in = TakeIn::kExecutor;
  bool localhost_only = false;
  int wait_s = 60;
  int timeout_s = 30;
  int quiet_ms = 2000;
};

std::optional<Options> parse(int argc, char** argv) {
  Options o;
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.size() % 2 != 0) return std::nullopt;
  try {
    for (std::size_t i = 0; i + 1 < args.size(); i += 2) {
      const std::string& k = args[i];
      const std::string& v = args[i + 1];
      if (k == "--topic")
        o.topics.push_back(v);
      else if (k == "--domain")
        o.domain = std::stoi(v);
      else if (k == "--qos" && (v == "default" || v == "sensor_data"))
        o.sensor_data = v == "sensor_data";
      else if (k == "--count")
        o.count = std::stoi(v);
      else if (k == "--take-in" && (v == "executor" || v == "listener"))
        o.take_in = v == "executor" ? TakeIn::kExecutor : TakeIn::kListener;
      else if (k == "--localhost-only" && (v == "0" || v == "1"))
        o.localhost_only = v == "1";
      else if (k == "--wait-s")
        o.wait_s = std::stoi(v);
      else if (k == "--timeout-s")
        o.timeout_s = std::stoi(v);
      else if (k == "--quiet-ms")
        o.quiet_ms = std::stoi(v);
      else
        return std::nullopt;
    }
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (o.topics.empty() || o.count <= 0 || o.wait_s <= 0 || o.timeout_s <= 0) return std::nullopt;
  return o;
}

// What one reader got. Filled by whichever thread takes (the executor or Fast DDS's listener).
class Tally {
 public:
  void add(const RawCloud& c, const fdds::SampleInfo& info) {
    const CloudSummary s = summarize(c);
    // A sample no writer sent: Fast DDS hands out a CacheChange it has already returned to its pool
    // (writer GUID and sequence number reset; docs/foreign-subscribers.md). Counted apart: not in
    // the stamps, whole or broken.
    const std::lock_guard<std::mutex> lock(mutex_);
    if (info.sample_identity.writer_guid() == rtps::c_Guid_Unknown) {
      ++phantom_;
      phantom_bytes_ = std::max(phantom_bytes_, c.cdr.size());
      return;
    }
    (s.whole ? whole_ : broken_) += 1;
    if (!stamps_.empty() && s.stamp_ns == stamps_.back())
      ++repeated_;
    else if (!stamps_.empty() && s.stamp_ns < stamps_.back())
      ++out_of_order_;
    stamps_.push_back(s.stamp_ns);
    if (s.whole) max_delay_ns_ = std::max(max_delay_ns_, wall_ns() - s.stamp_ns);
    last_ = Clock::now();
  }
  int whole() {
    const std::lock_guard<std::mutex> lock(mutex_);
    return whole_;
  }
  bool any() {
    const std::lock_guard<std::mutex> lock(mutex_);
    return !stamps_.empty();
  }
  bool quiet_for(std::chrono::milliseconds ms) {
    const std::lock_guard<std::mutex> lock(mutex_);
    return !stamps_.empty() && Clock::now() - last_ > ms;
  }
  bool clean() {
    const std::lock_guard<std::mutex> lock(mutex_);
    return broken_ == 0 && phantom_ == 0 && repeated_ == 0 && out_of_order_ == 0;
  }
  std::string json(const std::string& topic, const char* take_in, std::uint32_t udp_receive_buffer,
                   std::uint64_t lost) {
    const std::lock_guard<std::mutex> lock(mutex_);
    std::ostringstream o;
    o << R"({"topic":")" << topic << R"(","take_in":")" << take_in << R"(","udp_receive_buffer":)" << udp_receive_buffer
      << R"(,"received":)" << stamps_.size() << R"(,"whole":)" << whole_ << R"(,"broken":)" << broken_
      << R"(,"phantom":)" << phantom_ << R"(,"phantom_bytes":)" << phantom_bytes_ << R"(,"repeated":)" << repeated_
      << R"(,"out_of_order":)" << out_of_order_ << R"(,"lost_reported":)" << lost << R"(,"max_delay_ms":)"
      << static_cast<double>(max_delay_ns_) / 1e6 << R"(,"stamps":[)";
    for (std::size_t i = 0; i < stamps_.size(); ++i) o << (i ? "," : "") << stamps_[i];
    o << "]}";
    return o.str();
  }

 private:
  std::mutex mutex_;
  int whole_ = 0;
  int broken_ = 0;
  int phantom_ = 0;
  std::size_t phantom_bytes_ = 0;  // the largest payload of one
  int repeated_ = 0;
  int out_of_order_ = 0;
  std::vector<std::int64_t> stamps_;
  std::int64_t max_delay_ns_ = 0;  // header.stamp (the writer's clock, same host) -> taken here
  Clock::time_point last_;
};

std::string hex(const rtps::octet* v, std::size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (std::size_t i = 0; i < n; ++i) (s += digits[v[i] >> 4]) += digits[v[i] & 15];
  return s;
}

// SIGTERM/SIGINT: stop waiting, report and leave as usual (Fast DDS removes its shared-memory files
// only when its participant is deleted).
std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) { g_stop = true; }

class Listener : public fdds::DataReaderListener {
 public:
  Listener(std::string topic, TakeIn take_in, Tally& tally)
      : topic_(std::move(topic)), take_in_(take_in), tally_(tally) {}
  void on_subscription_matched(fdds::DataReader* reader, const fdds::SubscriptionMatchedStatus& s) override {
    if (s.current_count_change <= 0) return;
    matched_ = true;
    // The writer and this reader (GUIDs as on the wire) and the reader's UDP port on 127.0.0.1.
    std::ostringstream o;
    o << "matched " << topic_ << " writer " << hex(s.last_publication_handle.value, 16) << " reader ";
    const rtps::GUID_t& g = reader->guid();
    o << hex(g.guidPrefix.value, 12) << hex(g.entityId.value, 4);
    rtps::LocatorList_t locators;
    std::uint32_t port = 0;
    if (reader->get_listening_locators(locators) == ReturnCode_t::RETCODE_OK)
      for (const auto& l : locators)
        if (l.kind == LOCATOR_KIND_UDPv4 && port == 0) port = l.port;
    o << " udp " << port;
    std::cout << o.str() << std::endl;
  }
  void on_sample_lost(fdds::DataReader*, const fdds::SampleLostStatus& s) override {
    lost_reported_ = static_cast<std::uint64_t>(s.total_count);
  }
  // rmw_fastrtps' listener only tells the wait set (here: the reader's status condition does);
  // --take-in listener takes right here, on the receive thread.
  void on_data_available(fdds::DataReader* reader) override {
    if (take_in_ != TakeIn::kListener) return;
    RawCloud c;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&c, &info) == ReturnCode_t::RETCODE_OK)
      if (info.valid_data) tally_.add(c, info);
  }
  [[nodiscard]] bool matched() const { return matched_; }
  [[nodiscard]] std::uint64_t lost_reported() const { return lost_reported_; }

 private:
  std::string topic_;
  TakeIn take_in_;
  Tally& tally_;
  std::atomic<bool> matched_{false};
  std::atomic<std::uint64_t> lost_reported_{0};
};

fdds::DataReaderQos reader_qos(const fdds::Subscriber& sub, bool sensor_data) {
  fdds::DataReaderQos q = sub.get_default_datareader_qos();
  q.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  q.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  if (sensor_data) {  // rmw_qos_profile_sensor_data
    q.reliability().kind = fdds::BEST_EFFORT_RELIABILITY_QOS;
    q.history().depth = 5;
  } else {  // rmw_qos_profile_default
    q.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    q.history().depth = 10;
  }
  // What rmw_fastrtps sets (unless the user asks for the middleware's defaults).
  q.endpoint().history_memory_policy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
  q.data_sharing().off();
  return q;
}

// The receive buffer a UDPv4 transport of a profile asks for; 0: the built-in transports (OS default).
std::uint32_t udp_receive_buffer(const fdds::DomainParticipant& p) {
  for (const auto& t : p.get_qos().transport().user_transports)
    if (const auto udp = std::dynamic_pointer_cast<eprosima::fastdds::rtps::UDPv4TransportDescriptor>(t))
      return udp->receiveBufferSize;
  return 0;
}

struct Read {
  std::string name;
  Tally tally;
  std::unique_ptr<Listener> listener;
  fdds::Topic* topic = nullptr;
  fdds::DataReader* reader = nullptr;
};

// rmw_take: take(…, 1) until a sample with data comes or none is left.
void take_one(Read& r) {
  RawCloud c;
  fdds::StackAllocatedSequence<void*, 1> data_values;
  const_cast<void**>(data_values.buffer())[0] = &c;
  fdds::SampleInfoSeq infos{1};
  while (r.reader->take(data_values, infos, 1) == ReturnCode_t::RETCODE_OK) {
    const fdds::SampleInfo info = infos[0];
    const bool valid = info.valid_data;
    data_values.length(0);
    infos.length(0);
    if (valid) {
      r.tally.add(c, info);
      return;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const auto opt = parse(argc, argv);
  if (!opt) {
    std::cerr << "usage: fastdds_pointcloud_sub --topic rt/... [--topic rt/... ...] [--domain N] "
                 "[--qos default|sensor_data] --count N [--take-in executor|listener] [--wait-s W] [--timeout-s S] "
                 "[--quiet-ms MS]\n";
    return 2;
  }
  const char* take_in_name = opt->take_in == TakeIn::kExecutor ? "executor" : "listener";
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  // The default participant QoS, or what a FASTRTPS_DEFAULT_PROFILES_FILE sets as default profile
  // (rmw_fastrtps loads the profiles, takes the default, then sets its own on top).
  factory->load_profiles();
  fdds::DomainParticipantQos pqos = factory->get_default_participant_qos();
  pqos.name("fastdds_pointcloud_sub");
  pqos.wire_protocol().builtin.readerHistoryMemoryPolicy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
  pqos.wire_protocol().builtin.writerHistoryMemoryPolicy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
  if (opt->localhost_only) {  // rmw_fastrtps (Humble) with ROS_LOCALHOST_ONLY=1
    pqos.transport().use_builtin_transports = false;
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList.emplace_back("127.0.0.1");
    pqos.transport().user_transports.push_back(udp);
    pqos.transport().user_transports.push_back(
        std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>());
  }
  fdds::DomainParticipant* participant = factory->create_participant(opt->domain, pqos);
  if (participant == nullptr) {
    std::cerr << "fastdds_pointcloud_sub: no participant\n";
    return 1;
  }
  fdds::TypeSupport type(new PointCloud2Type());
  type.register_type(participant);
  fdds::Subscriber* sub = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (sub == nullptr) {
    std::cerr << "fastdds_pointcloud_sub: no subscriber\n";
    return 1;
  }
  std::vector<std::unique_ptr<Read>> reads;
  fdds::WaitSet wait_set;
  for (const std::string& name : opt->topics) {
    auto r = std::make_unique<Read>();
    r->name = name;
    r->listener = std::make_unique<Listener>(name, opt->take_in, r->tally);
    r->topic = participant->create_topic(name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    if (r->topic != nullptr)
      r->reader = sub->create_datareader(r->topic, reader_qos(*sub, opt->sensor_data), r->listener.get());
    if (r->reader == nullptr) {
      std::cerr << "fastdds_pointcloud_sub: no reader for " << name << "\n";
      return 1;
    }
    // As rmw_fastrtps: the executor waits on each reader's data-available condition.
    r->reader->get_statuscondition().set_enabled_statuses(fdds::StatusMask::data_available());
    wait_set.attach_condition(r->reader->get_statuscondition());
    reads.push_back(std::move(r));
  }

  const auto all = [&](auto pred) {
    return std::all_of(reads.begin(), reads.end(), [&](auto& r) { return pred(*r); });
  };
  const auto any = [&](auto pred) {
    return std::any_of(reads.begin(), reads.end(), [&](auto& r) { return pred(*r); });
  };
  std::signal(SIGTERM, on_stop_signal);
  std::signal(SIGINT, on_stop_signal);
  const auto start = Clock::now();
  std::optional<Clock::time_point> first_data;
  bool timed_out = false;
  for (;;) {
    if (opt->take_in == TakeIn::kExecutor) {
      // rmw_wait: no wait when a reader already has an untaken sample; then the executor runs each
      // ready subscription once (one take each) and waits again.
      fdds::SampleInfo info;
      if (!any([&](Read& r) { return r.reader->get_first_untaken_info(&info) == ReturnCode_t::RETCODE_OK; })) {
        fdds::ConditionSeq triggered;
        wait_set.wait(triggered, eprosima::fastrtps::Duration_t(0, 50'000'000));
      }
      for (auto& r : reads)
        if (r->reader->get_first_untaken_info(&info) == ReturnCode_t::RETCODE_OK) take_one(*r);
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    const auto now = Clock::now();
    if (g_stop) break;
    if (!first_data && any([](Read& r) { return r.tally.any(); })) {
      first_data = now;
      std::cout << "data" << std::endl;
    }
    if (all([&](Read& r) { return r.tally.whole() >= opt->count; })) break;
    if (all([&](Read& r) { return r.tally.quiet_for(std::chrono::milliseconds(opt->quiet_ms)); })) break;
    if (first_data ? now - *first_data > std::chrono::seconds(opt->timeout_s)
                   : now - start > std::chrono::seconds(opt->wait_s)) {
      timed_out = !first_data;
      break;
    }
  }
  if (timed_out) {
    int matched = 0;
    for (auto& r : reads) matched += r->listener->matched() ? 1 : 0;
    std::cerr << "fastdds_pointcloud_sub: no sample within " << opt->wait_s << " s (" << matched << " of "
              << reads.size() << " readers matched a writer)\n";
  }
  bool ok = true;
  std::string summary;
  for (auto& r : reads) {
    wait_set.detach_condition(r->reader->get_statuscondition());
    sub->delete_datareader(r->reader);
    participant->delete_topic(r->topic);
    summary +=
        r->tally.json(r->name, take_in_name, udp_receive_buffer(*participant), r->listener->lost_reported()) + "\n";
    ok = ok && r->tally.clean() && r->tally.whole() >= opt->count;
  }
  participant->delete_subscriber(sub);
  factory->delete_participant(participant);
  std::cout << summary << std::flush;
  return ok ? 0 : 1;
}
