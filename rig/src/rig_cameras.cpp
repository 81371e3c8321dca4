#include "rig_cameras.hpp"

#include <algorithm>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include <unistd.h>

#include "sensor_rig/camera/mock/fake_cameras.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/log.hpp"

namespace sensor_rig::rig {

std::vector<drivers::CameraConfig> parse_cameras(const config::Node& root) {
  std::vector<drivers::CameraConfig> out;
  std::set<std::string> names;
  std::set<std::string> devices;
  for (const auto& item : root.items("cameras")) {
    auto c = drivers::parse_camera_config(item);
    if (!c.name.empty() && !names.insert(c.name).second) item.fail("name", "duplicate camera name '" + c.name + "'");
    if (!c.source.device.empty() && !devices.insert(c.source.backend + ":" + c.source.device).second)
      item.fail("device", "device '" + c.source.device + "' used by two cameras");
    out.push_back(std::move(c));
  }
  // A software trigger group ticks at one rate, or is fired by one LIDAR crossing: its members
  // must agree on both (the first member sets them).
  std::map<std::string, std::size_t> group_first;
  const auto items = root.items("cameras");
  for (std::size_t i = 0; i < out.size() && i < items.size(); ++i) {
    const auto& c = out[i];
    if (c.trigger_group.empty()) continue;
    auto [it, fresh] = group_first.emplace(c.trigger_group, i);
    if (fresh) continue;
    const auto& first = out[it->second];
    const std::string group = "trigger group '" + c.trigger_group + "'";
    if (first.source.frame_rate != c.source.frame_rate) items[i].fail("frame_rate", group + " members need the same frame_rate");
    const auto& a = first.lidar_trigger;
    const auto& b = c.lidar_trigger;
    const char* key = a.lidar != b.lidar ? (b.enabled() ? "lidar" : "group")
                      : a.azimuth_deg != b.azimuth_deg ? "azimuth_deg"
                      : a.latency_us != b.latency_us   ? "latency_us"
                                                       : nullptr;
    if (key == nullptr) continue;
    std::ostringstream how;
    if (a.enabled())
      how << "lidar " << a.lidar << " at azimuth_deg " << a.azimuth_deg << ", latency_us " << a.latency_us;
    else
      how << "its own tick (no lidar)";
    if (auto t = items[i].child("trigger"))
      t->fail(key, group + ": one trigger fires all its members, and camera '" + first.name + "' is triggered by " + how.str());
  }
  return out;
}

std::string describe_cameras(const std::vector<drivers::CameraConfig>& cameras) {
  std::ostringstream o;
  for (const auto& c : cameras) {
    o << "  camera " << c.name << ": " << c.source.backend << " " << c.source.device << " "
      << (camera::info(c.source.format).genicam != nullptr && c.source.backend == "aravis" ? camera::info(c.source.format).genicam
                                                                                           : camera::info(c.source.format).v4l2_name)
      << " " << c.source.width << "x" << c.source.height << " @ " << c.source.frame_rate << " Hz, trigger "
      << camera::to_string(c.source.trigger) << (c.trigger_group.empty() ? "" : " (group " + c.trigger_group + ")")
      << (c.lidar_trigger.enabled() ? " (lidar " + c.lidar_trigger.lidar + " sweep at " + std::to_string(c.lidar_trigger.azimuth_deg) + " deg)" : "")
      << (c.info.calibrated() ? ", calibrated" : ", uncalibrated") << " -> /sensors/camera/" << c.name << "/image_raw";
    if (c.mock.kind != drivers::CameraMockConfig::Kind::kNone) o << " [mock: " << drivers::to_string(c.mock.kind) << "]";
    o << "\n";
  }
  return o.str();
}

std::vector<drivers::CameraConfig> resolve_camera_mocks(std::vector<drivers::CameraConfig> cameras,
                                                        std::vector<LoopbackAddress>& addresses) {
  for (auto& c : cameras) {
    if (c.mock.kind != drivers::CameraMockConfig::Kind::kGige) continue;
    std::string why;
    if (auto lease = LoopbackAddress::take(c.source.device, why)) {
      addresses.push_back(std::move(*lease));
      continue;
    }
    log::warn("rig", "camera " + c.name + ": no GigE fake on " + c.source.device + " (" + why +
                         "): running an in-process Aravis fake instead");
    c.mock.kind = drivers::CameraMockConfig::Kind::kAravisInProcess;
  }
  return cameras;
}

namespace {
// rig-fake-gige-camera beside this executable (exposes on the trigger), else Aravis's own fake
// (exposes on its 40 ms grid: the phase then reads 0-40 ms).
std::string trigger_following_fake() {
  const std::string self = self_executable();
  const std::string beside = self.substr(0, self.rfind('/') + 1) + camera::mock::kTriggerFollowingFake;
  if (::access(beside.c_str(), X_OK) == 0) return beside;
  static bool warned = false;
  if (!std::exchange(warned, true))
    log::warn("rig", beside + " not found: GigE mocks run arv-fake-gv-camera-0.8 (triggered frames on its 40 ms grid)");
  return camera::mock::GigeFakeOptions{}.program;
}
}  // namespace

struct CameraRig::Impl {
  struct Fake {
    camera::mock::GigeFakeOptions options;
    ChildProcess process;
    std::string camera;
    bool reported = false;
  };
  std::vector<drivers::CameraConfig> cameras;
  std::map<std::string, std::unique_ptr<drivers::TriggerGroup>> groups;
  std::vector<std::unique_ptr<drivers::LidarTrigger>> lidar_triggers;  // one per LIDAR-triggered camera or group
  std::vector<int> lidar_trigger_priority;
  std::vector<std::unique_ptr<drivers::CameraDriver>> drivers;
  std::vector<Fake> fakes;
  std::vector<LoopbackAddress> addresses;  // the GigE fakes' addresses on lo, given back after them
};

CameraRig::CameraRig(const std::vector<drivers::CameraConfig>& cameras, const dds::Participant& participant,
                     dds::StampsWriter& stamps)
    : impl_(std::make_unique<Impl>()) {
  impl_->cameras = resolve_camera_mocks(cameras, impl_->addresses);
  std::map<std::string, std::size_t> lidar_trigger_of_group;
  for (const auto& c : impl_->cameras) {
    drivers::TriggerSource* group = nullptr;
    if (c.lidar_trigger.enabled()) {
      // One LidarTrigger per camera, or per trigger group (a stereo pair fired by one crossing).
      const auto known = lidar_trigger_of_group.find(c.trigger_group);
      std::size_t index = known != lidar_trigger_of_group.end() ? known->second : impl_->lidar_triggers.size();
      if (c.trigger_group.empty() || known == lidar_trigger_of_group.end()) {
        index = impl_->lidar_triggers.size();
        const std::string name = c.trigger_group.empty() ? c.name : c.trigger_group;
        impl_->lidar_triggers.push_back(std::make_unique<drivers::LidarTrigger>(name, c.lidar_trigger));
        impl_->lidar_trigger_priority.push_back(c.realtime_priority);
        if (!c.trigger_group.empty()) lidar_trigger_of_group.emplace(c.trigger_group, index);
      }
      auto& priority = impl_->lidar_trigger_priority[index];
      priority = std::max(priority, c.realtime_priority);
      group = impl_->lidar_triggers[index].get();
    } else if (c.source.trigger == camera::TriggerMode::kSoftware) {
      const std::string key = c.trigger_group.empty() ? "camera:" + c.name : c.trigger_group;
      auto& g = impl_->groups[key];
      if (!g) g = std::make_unique<drivers::TriggerGroup>(key, c.source.frame_rate);
      group = g.get();
    }
    impl_->drivers.push_back(std::make_unique<drivers::CameraDriver>(c, participant, stamps, group));
  }
}

CameraRig::~CameraRig() { stop(); }

std::vector<std::pair<std::string, timesync::SweepObserver*>> CameraRig::sweep_observers() const {
  std::vector<std::pair<std::string, timesync::SweepObserver*>> out;
  for (const auto& t : impl_->lidar_triggers) out.emplace_back(t->config().lidar, t.get());
  return out;
}

void CameraRig::start() {
  for (const auto& c : impl_->cameras) {
    if (c.mock.kind != drivers::CameraMockConfig::Kind::kGige) continue;
    Impl::Fake f;
    f.options.address = c.source.device;
    f.options.lost_packets_per_thousand = c.mock.lost_packets_per_thousand;
    f.options.program = trigger_following_fake();
    // The mock stands for camera hardware, whose timing does not wait for the host: its threads
    // real-time too, but one below the camera's own (capture, Aravis stream) threads, which in the
    // car never share a core with the camera's sending. At the same priority the two stereo fakes'
    // sending held the rig's stream threads off their leaders: +0.6 ms on the mapped exposure.
    // A camera without a priority of its own gets the lowest SCHED_FIFO one (1): above every normal
    // thread, below every real-time thread of the rig. At normal priority a loaded host held the
    // free-running fakes' leaders 2-4 ms past the exposure end for tens of seconds, and the rig's
    // clock mapping (leader = exposure start + exposure) carried that as a 2 ms bias (issue 27).
    if (f.options.program != camera::mock::GigeFakeOptions{}.program)
      f.options.realtime_priority = c.realtime_priority > 1 ? c.realtime_priority - 1 : 1;
    f.camera = c.name;
    // Under `rig chaos` (RIG_CHAOS_DIR): the camera's faults from the plan, its truth record (only
    // rig-fake-gige-camera takes them; Aravis's own fake would refuse the options).
    if (!faults::chaos_plan_path().empty() && f.options.program != camera::mock::GigeFakeOptions{}.program)
      f.options.chaos = camera::mock::chaos_from_env(c.name);
    try {
      f.process = camera::mock::start_gige_fake(f.options);
      log::info("rig", "mock for camera " + c.name + ": " + f.options.program + " on " + c.source.device + ", pid " +
                           std::to_string(f.process.pid()));
    } catch (const std::exception& e) {
      log::error("rig", "camera " + c.name + ": " + e.what());
    }
    impl_->fakes.push_back(std::move(f));
  }
  for (auto& d : impl_->drivers) d->start();  // they open (and reopen) their cameras themselves
  for (auto& [name, g] : impl_->groups) g->start();
  for (std::size_t i = 0; i < impl_->lidar_triggers.size(); ++i) impl_->lidar_triggers[i]->start(impl_->lidar_trigger_priority[i]);
}

void CameraRig::supervise(std::vector<dds::DriverStatus>& statuses) {
  for (auto& f : impl_->fakes) {
    if (f.process.pid() > 0 && f.process.running()) continue;
    if (!f.reported) {
      log::warn("rig", "GigE fake of camera " + f.camera + " exited (status " + std::to_string(f.process.exit_status()) +
                           "): restarting it");
      f.reported = true;
    }
    try {
      f.process = camera::mock::start_gige_fake(f.options);
      f.reported = false;
      log::info("rig", "mock for camera " + f.camera + " restarted, pid " + std::to_string(f.process.pid()));
    } catch (const std::exception& e) {
      log::error("rig", "camera " + f.camera + ": " + e.what());
    }
  }
  for (const auto& d : impl_->drivers) statuses.push_back(d->status());
}

void CameraRig::stop() {
  for (auto& [name, g] : impl_->groups) g->stop();
  for (auto& t : impl_->lidar_triggers) t->stop();
  for (auto& d : impl_->drivers) d->request_stop();  // all at once, then each joined (issue 27 item 1)
  for (auto& d : impl_->drivers) d->stop();
  for (auto& f : impl_->fakes)
    if (f.process.pid() > 0) f.process.stop(1000);
  impl_->fakes.clear();
  impl_->addresses.clear();  // after the fakes that were bound to them
}

}  // namespace sensor_rig::rig
