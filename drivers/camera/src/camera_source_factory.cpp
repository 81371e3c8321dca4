#include "sensor_rig/camera/aravis_source.hpp"
#include "sensor_rig/camera/mock/fake_cameras.hpp"
#include "sensor_rig/camera/mock/fake_v4l2_device.hpp"
#include "sensor_rig/camera/v4l2_source.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/drivers/camera/camera_driver.hpp"

namespace sensor_rig::drivers {

std::unique_ptr<camera::FrameSource> make_camera_source(const CameraConfig& cfg) {
  using K = CameraMockConfig::Kind;
  auto s = cfg.source;
  switch (cfg.mock.kind) {
    case K::kAravisInProcess:
      // The fake's serial number register holds at most 15 characters (longer: no GenICam data).
      s.device = std::string(camera::mock::kFakePrefix) + cfg.name.substr(0, 15);
      // Under `rig chaos` (RIG_CHAOS_DIR): its truth record (it takes no faults).
      return std::make_unique<camera::AravisSource>(
          s, camera::mock::inprocess_fake_opener(faults::chaos_plan_path().empty() ? camera::mock::ChaosArgs{}
                                                                                  : camera::mock::chaos_from_env(cfg.name)));
    case K::kV4l2Fake: {
      camera::mock::FakeV4l2Options o;
      o.path = s.device;
      o.formats.push_back({camera::info(s.format).v4l2, s.width, s.height});
      // Under `rig chaos` (RIG_CHAOS_DIR): its v4l2.* faults and truth record.
      if (!faults::chaos_plan_path().empty()) o.chaos = camera::mock::chaos_from_env(cfg.name);
      return std::make_unique<camera::V4l2Source>(s, std::make_shared<camera::mock::FakeV4l2Device>(o));
    }
    case K::kGige:
    case K::kNone:
      break;
  }
  if (s.backend == "v4l2") return std::make_unique<camera::V4l2Source>(s, camera::system_v4l2());
  return std::make_unique<camera::AravisSource>(s);
}

}  // namespace sensor_rig::drivers
