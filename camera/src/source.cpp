#include "sensor_rig/camera/source.hpp"

namespace sensor_rig::camera {

const char* to_string(TriggerMode m) noexcept {
  switch (m) {
    case TriggerMode::kFreeRun: return "free_run";
    case TriggerMode::kSoftware: return "software";
    case TriggerMode::kLine: return "line";
  }
  return "?";
}

const char* to_string(CaptureStatus s) noexcept {
  switch (s) {
    case CaptureStatus::kFrame: return "frame";
    case CaptureStatus::kTimeout: return "timeout";
    case CaptureStatus::kIncomplete: return "incomplete";
    case CaptureStatus::kDisconnected: return "disconnected";
    case CaptureStatus::kError: return "error";
  }
  return "?";
}

}  // namespace sensor_rig::camera
