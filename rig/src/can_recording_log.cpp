#include "can_recording_log.hpp"

#include <algorithm>

namespace sensor_rig::rig {
namespace {

constexpr std::size_t kAheadFrames = 65536;

McapChannelSpec can_channel() {
  McapChannelSpec spec;
  spec.schema = "sensor_rig_msgs/msg/CanFrame";
  spec.pick = [](const std::vector<std::string>& topics) {
    if (std::find(topics.begin(), topics.end(), kCanFramesTopic) != topics.end()) return std::string(kCanFramesTopic);
    return topics.size() == 1 ? topics.front() : std::string{};
  };
  spec.none = [schema = spec.schema](const std::vector<std::string>& topics) {
    std::string seen;
    for (const auto& t : topics) seen += (seen.empty() ? "" : ", ") + t;
    return "no " + schema + " channel " + kCanFramesTopic +
           (topics.empty() ? std::string(" (none in the file: recorded without --raw?)") : " (several: " + seen + ")");
  };
  spec.log_tag = "can";
  spec.ahead = kAheadFrames;
  return spec;
}

std::string decode(const dds::CanFrameView& view, const std::function<bool(dbw::can::LoggedFrame&&)>& push) {
  if (view.data.size() > dbw::can::kFdMaxLen) return "more than 64 data bytes";
  dbw::can::LoggedFrame f;
  f.stamp = static_cast<Nanos>(view.header.sec) * 1'000'000'000 + static_cast<Nanos>(view.header.nanosec);
  f.frame.id = view.id;
  f.frame.rtr = view.is_rtr;
  f.frame.extended = view.is_extended;
  f.frame.error = view.is_error;
  f.frame.fd = view.is_fd;
  f.frame.brs = view.brs;
  f.frame.esi = view.esi;
  f.frame.len = static_cast<std::uint8_t>(view.data.size());
  std::copy(view.data.begin(), view.data.end(), reinterpret_cast<std::byte*>(f.frame.data.data()));
  push(std::move(f));
  return {};
}

}  // namespace

McapCanLog::McapCanLog(const std::string& path)
    : pump_(recording_files(path), can_channel(), decode, [](const dbw::can::LoggedFrame&) -> std::size_t { return 1; }) {}

bool McapCanLog::next(dbw::can::LoggedFrame& out) {
  auto f = pump_.next();
  if (f) out = *f;
  return f.has_value();
}

std::uint64_t McapCanLog::malformed() const { return pump_.undecodable(); }

std::string McapCanLog::error() const { return pump_.error(); }

std::unique_ptr<dbw::can::FrameLog> open_can_recording(const std::string& path) {
  return std::make_unique<McapCanLog>(path);
}

}  // namespace sensor_rig::rig
