// A foreign DDS subscriber, as a ROS 2 node with rmw_fastrtps and its defaults would be: Fast DDS
// (Debian's 2.9), the default participant (UDPv4 + SHM transports, OS socket buffers), a reader of
// `sensor_msgs::msg::dds_::PointCloud2_` with ROS 2's default QoS (reliable, volatile, keep-last 10)
// or its sensor-data QoS (best effort, keep-last 5). No fastddsgen here: the type is written by
// hand and keeps the serialized payload; the CDR fields that identify a scan and prove it whole
// (header.stamp, height, width, point_step, row_step, data length) are read from it.
//
// fastdds_pointcloud_sub --topic rt/... [--topic rt/... ...] [--domain N] [--qos default|sensor_data]
//                        [--count N] [--timeout-s S] [--quiet-ms MS]
// Several --topic: one participant (one socket, as one ROS 2 node) with a reader each; --count per
// topic; one JSON line per topic.
// With FASTRTPS_DEFAULT_PROFILES_FILE set, the participant is that profile's default one (U: its
// UDP receive buffer, 0 = the OS default). Prints `matched` when a writer matched, then per topic one
// JSON line at the end:
// {"topic":T,"udp_receive_buffer":U,"received":R,"whole":W,"broken":B,"lost_reported":L,"max_delay_ms":D,"stamps":[ns,...]}
// Exit 0 with N whole scans on every topic, 1 otherwise (fewer, or broken ones), 2 bad usage.
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
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
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

class PointCloud2Type : public fdds::TopicDataType {
 public:
  PointCloud2Type() {
    setName("sensor_msgs::msg::dds_::PointCloud2_");
    m_typeSize = 4096;  // unbounded: an initial payload size, grown per sample (as rmw_fastrtps)
    m_isGetKeyDefined = false;
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

struct Options {
  std::vector<std::string> topics;  // --topic, repeatable: one participant reading them all, as one node
  int domain = 0;
  bool sensor_data = false;
  int count = 0;
  int timeout_s = 30;
  int quiet_ms = 2000;
};

std::optional<Options> parse(int argc, char** argv) {
  Options o;
  const std::vector<std::string> args(argv + 1, argv + argc);
  for (std::size_t i = 0; i + 1 < args.size(); i += 2) {
    const std::string& k = args[i];
    const std::string& v = args[i + 1];
    if (k == "--topic") o.topics.push_back(v);
    else if (k == "--domain") o.domain = std::stoi(v);
    else if (k == "--qos" && (v == "default" || v == "sensor_data")) o.sensor_data = v == "sensor_data";
    else if (k == "--count") o.count = std::stoi(v);
    else if (k == "--timeout-s") o.timeout_s = std::stoi(v);
    else if (k == "--quiet-ms") o.quiet_ms = std::stoi(v);
    else return std::nullopt;
  }
  if (args.size() % 2 != 0 || o.topics.empty() || o.count <= 0) return std::nullopt;
  return o;
}

class Listener : public fdds::DataReaderListener {
 public:
  void on_subscription_matched(fdds::DataReader*, const fdds::SubscriptionMatchedStatus& s) override {
    if (s.current_count_change > 0) std::cout << "matched" << std::endl;
  }
  void on_sample_lost(fdds::DataReader*, const fdds::SampleLostStatus& s) override {
    lost_reported_ = static_cast<std::uint64_t>(s.total_count);
  }
  void on_data_available(fdds::DataReader* reader) override {
    RawCloud c;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&c, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      const CloudSummary s = summarize(c);
      const std::lock_guard<std::mutex> lock(mutex_);
      (s.whole ? whole_ : broken_) += 1;
      stamps_.push_back(s.stamp_ns);
      max_delay_ns_ = std::max(max_delay_ns_, wall_ns() - s.stamp_ns);
      last_ = std::chrono::steady_clock::now();
    }
  }
  int whole() {
    const std::lock_guard<std::mutex> lock(mutex_);
    return whole_;
  }
  bool quiet_for(std::chrono::milliseconds ms) {
    const std::lock_guard<std::mutex> lock(mutex_);
    return !stamps_.empty() && std::chrono::steady_clock::now() - last_ > ms;
  }
  std::string json(const std::string& topic, std::uint32_t udp_receive_buffer) {
    const std::lock_guard<std::mutex> lock(mutex_);
    std::ostringstream o;
    o << R"({"topic":")" << topic << R"(","udp_receive_buffer":)" << udp_receive_buffer << R"(,"received":)" << stamps_.size() << R"(,"whole":)" << whole_ << R"(,"broken":)" << broken_
      << R"(,"lost_reported":)" << lost_reported_.load() << R"(,"max_delay_ms":)" << static_cast<double>(max_delay_ns_) / 1e6
      << R"(,"stamps":[)";
    for (std::size_t i = 0; i < stamps_.size(); ++i) o << (i ? "," : "") << stamps_[i];
    o << "]}";
    return o.str();
  }

 private:
  std::mutex mutex_;
  int whole_ = 0;
  int broken_ = 0;
  std::vector<std::int64_t> stamps_;
  std::int64_t max_delay_ns_ = 0;  // header.stamp (the writer's clock, same host) -> taken here
  std::chrono::steady_clock::time_point last_;
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
  // What rmw_fastrtps sets for types without a bound.
  q.endpoint().history_memory_policy = rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
  return q;
}

// The receive buffer a UDPv4 transport of a profile asks for; 0: the built-in transports (OS default).
std::uint32_t udp_receive_buffer(const fdds::DomainParticipant& p) {
  for (const auto& t : p.get_qos().transport().user_transports)
    if (const auto udp = std::dynamic_pointer_cast<eprosima::fastdds::rtps::UDPv4TransportDescriptor>(t))
      return udp->receiveBufferSize;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const auto opt = parse(argc, argv);
  if (!opt) {
    std::cerr << "usage: fastdds_pointcloud_sub --topic rt/... [--topic rt/... ...] [--domain N] "
                 "[--qos default|sensor_data] --count N [--timeout-s S] [--quiet-ms MS]\n";
    return 2;
  }
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  // The default participant QoS, or what a FASTRTPS_DEFAULT_PROFILES_FILE sets as default profile.
  fdds::DomainParticipant* participant = factory->create_participant(opt->domain, fdds::PARTICIPANT_QOS_DEFAULT);
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
  struct Read {
    fdds::Topic* topic = nullptr;
    std::unique_ptr<Listener> listener = std::make_unique<Listener>();
    fdds::DataReader* reader = nullptr;
  };
  std::vector<Read> reads(opt->topics.size());
  for (std::size_t i = 0; i < reads.size(); ++i) {
    Read& r = reads[i];
    r.topic = participant->create_topic(opt->topics[i], type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    if (r.topic != nullptr) r.reader = sub->create_datareader(r.topic, reader_qos(*sub, opt->sensor_data), r.listener.get());
    if (r.reader == nullptr) {
      std::cerr << "fastdds_pointcloud_sub: no reader for " << opt->topics[i] << "\n";
      return 1;
    }
  }
  // Until every topic has its scans, the time is up, or every topic has gone quiet.
  const auto done = [&] {
    bool all_whole = true, all_quiet = true;
    for (auto& r : reads) {
      all_whole = all_whole && r.listener->whole() >= opt->count;
      all_quiet = all_quiet && r.listener->quiet_for(std::chrono::milliseconds(opt->quiet_ms));
    }
    return all_whole || all_quiet;
  };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(opt->timeout_s);
  while (!done() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  bool ok = true;
  std::string summary;
  for (std::size_t i = 0; i < reads.size(); ++i) {
    sub->delete_datareader(reads[i].reader);
    participant->delete_topic(reads[i].topic);
    const std::string line = reads[i].listener->json(opt->topics[i], udp_receive_buffer(*participant));
    ok = ok && line.find("\"broken\":0,") != std::string::npos && reads[i].listener->whole() >= opt->count;
    summary += line + "\n";
  }
  participant->delete_subscriber(sub);
  factory->delete_participant(participant);
  std::cout << summary << std::flush;
  return ok ? 0 : 1;
}
