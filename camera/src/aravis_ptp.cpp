// AravisSource's PTP state (camera/README.md "PTP"): the enable at open, the status thread's poll
// (a GVCP round trip every status_poll_ms, never on the capture thread), resets, the lock flag.
#include <algorithm>
#include <chrono>
#include <mutex>

#include "aravis_internal.hpp"

namespace sensor_rig::camera {

using detail::feature_text;
using detail::take_error;
using detail::unref;

// The PTP status thread: a GVCP round trip every status_poll_ms, never on the capture thread.
void AravisSource::status_loop() {
  const auto period = std::chrono::milliseconds(std::max(cfg_.ptp.status_poll_ms, 10));
  std::unique_lock pl(ptp_mutex_);
  while (!ptp_cv_.wait_for(pl, period, [this] { return ptp_stop_; })) {
    pl.unlock();
    {
      std::lock_guard gl(*gc_mutex_);
      if (!control_lost_.load()) poll_ptp();
    }
    pl.lock();
  }
}
std::string AravisSource::read_ptp_status(ArvDevice* dev, std::string& error) {
  const Nanos t0 = monotonic_now_ns();
  if (!ptp_latch_feature_.empty()) {  // SFNC: the status is the latched data set's
    GError* err = nullptr;
    arv_device_execute_command(dev, ptp_latch_feature_.c_str(), &err);
    if (err != nullptr) error = ptp_latch_feature_ + ": " + take_error(err);
  }
  std::string status = error.empty() ? feature_text(dev, ptp_status_feature_.c_str(), error) : std::string();
  const auto us = static_cast<std::int64_t>((monotonic_now_ns() - t0) / 1000);
  std::lock_guard pl(ptp_mutex_);
  ++ptp_.polls;
  ptp_.poll_max_us = std::max(ptp_.poll_max_us, us);
  return status;
}

// Disable and enable; "" or what failed. The caller counts it with the status read after it.
std::string AravisSource::ptp_reset(ArvDevice* dev, const std::string& status) {
  std::string name;
  {
    std::lock_guard pl(ptp_mutex_);
    name = ptp_.enable_feature;
  }
  GError* err = nullptr;
  arv_device_set_boolean_feature_value(dev, name.c_str(), FALSE, &err);
  if (err == nullptr) arv_device_set_boolean_feature_value(dev, name.c_str(), TRUE, &err);
  return err == nullptr ? std::string() : "reset of " + name + " (status " + status + "): " + take_error(err);
}

// One update of what ptp() reports: a reset is counted with the status read after it.
void AravisSource::publish_ptp(const std::string& status, bool reset, const std::string& error) {
  std::lock_guard pl(ptp_mutex_);
  if (reset) ++ptp_.resets;
  if (!error.empty()) ptp_.error = error;
  ptp_.status = status;
  // Only Slave follows the PU's grandmaster; Master is the camera's own clock unless it is meant to be.
  ptp_.locked = status == "Slave" || (status == "Master" && cfg_.ptp.grandmaster);
  ptp_locked_.store(ptp_.locked);
}

void AravisSource::setup_ptp(ArvDevice* dev) {
  std::string name;
  for (const char* f : {"PtpEnable", "GevIEEE1588"})
    if (arv_device_is_feature_available(dev, f, nullptr) != FALSE) {
      name = f;
      break;
    }
  if (name.empty())
    throw CameraError("aravis " + cfg_.device + ": ptp enabled but the device has no PtpEnable or GevIEEE1588 feature");
  ptp_status_feature_ = name == "PtpEnable" ? "PtpStatus" : "GevIEEE1588Status";
  if (arv_device_is_feature_available(dev, ptp_status_feature_.c_str(), nullptr) == FALSE)
    throw CameraError("aravis " + cfg_.device + ": ptp enabled but the device has " + name + " and no " + ptp_status_feature_);
  ptp_latch_feature_ = name == "PtpEnable" ? "PtpDataSetLatch" : "GevIEEE1588DataSetLatch";
  if (arv_device_is_feature_available(dev, ptp_latch_feature_.c_str(), nullptr) == FALSE) ptp_latch_feature_.clear();
  GError* err = nullptr;
  arv_device_set_boolean_feature_value(dev, name.c_str(), TRUE, &err);
  if (err != nullptr) throw CameraError("aravis " + cfg_.device + ": " + name + "=true: " + take_error(err));
  {
    std::lock_guard pl(ptp_mutex_);
    ptp_.enabled = true;
    ptp_.enable_feature = name;
  }
  std::string error;
  std::string status = read_ptp_status(dev, error);
  if (!error.empty()) throw CameraError("aravis " + cfg_.device + ": " + error);
  // Not running (yet): disable and enable once, as a faulty clock servo needs.
  const bool reset = status == "Faulty" || status == "Disabled" || status == "Initializing";
  std::string reset_error;
  if (reset) {
    reset_error = ptp_reset(dev, status);
    status = read_ptp_status(dev, error);
    if (!error.empty()) throw CameraError("aravis " + cfg_.device + ": " + error);
  }
  publish_ptp(status, reset, reset_error);
}

void AravisSource::poll_ptp() {
  ArvDevice* dev = st_->device;
  if (dev == nullptr) return;
  std::string error;
  std::string status = read_ptp_status(dev, error);
  // Faulty/Disabled: reset. Initializing is what a reset leads to: wait for it.
  const bool reset = error.empty() && (status == "Faulty" || status == "Disabled");
  if (reset) {
    const std::string reset_error = ptp_reset(dev, status);
    status = read_ptp_status(dev, error);
    if (error.empty()) error = reset_error;
  }
  if (!error.empty() && status.empty()) status = "unknown";  // the read failed
  publish_ptp(status, reset, error);
}

void AravisSource::stop_ptp_thread() noexcept {
  if (!ptp_thread_.joinable()) return;
  {
    std::lock_guard pl(ptp_mutex_);
    ptp_stop_ = true;
  }
  ptp_cv_.notify_all();
  ptp_thread_.join();
}

PtpState AravisSource::ptp() const {
  std::lock_guard pl(ptp_mutex_);
  return ptp_;
}
}  // namespace sensor_rig::camera
