#include "exposure_watcher.hpp"

#include <cmath>

namespace sensor_rig::camera::detail {

struct ExposureWatcher::Shared {
  ArvDevice* device = nullptr;  // our own reference
  std::string feature;
  std::shared_ptr<std::timed_mutex> genicam;
  mutable std::mutex mutex;     // everything below
  std::condition_variable cv;
  bool stop = false;
  std::uint64_t want = 0;
  KnownExposure known;
  ~Shared() {
    if (device != nullptr) g_object_unref(device);
  }
};

ExposureWatcher::ExposureWatcher(ArvDevice* device, std::string feature, std::shared_ptr<std::timed_mutex> genicam)
    : sh_(std::make_shared<Shared>()) {
  sh_->device = static_cast<ArvDevice*>(g_object_ref(device));
  sh_->feature = std::move(feature);
  sh_->genicam = std::move(genicam);
  thread_ = std::thread([sh = sh_] {
    std::uint64_t read_for = 0;
    std::unique_lock lock(sh->mutex);
    for (;;) {
      sh->cv.wait(lock, [&] { return sh->stop || sh->want != read_for; });
      if (sh->stop) return;
      read_for = sh->want;
      lock.unlock();
      double us = 0.0;
      {
        std::lock_guard gl(*sh->genicam);
        GError* err = nullptr;
        us = arv_device_get_float_feature_value(sh->device, sh->feature.c_str(), &err);
        if (err != nullptr) {
          g_error_free(err);
          us = 0.0;
        }
      }
      lock.lock();
      if (us > 0) sh->known = {read_for, static_cast<Nanos>(std::llround(us * 1000.0))};
    }
  });
}

ExposureWatcher::~ExposureWatcher() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard lock(sh_->mutex);
    sh_->stop = true;
  }
  sh_->cv.notify_all();
  thread_.join();
}

void ExposureWatcher::abandon() noexcept {
  if (!thread_.joinable()) return;
  {
    std::lock_guard lock(sh_->mutex);
    sh_->stop = true;
  }
  sh_->cv.notify_all();
  thread_.detach();  // it holds sh_ (and the device) until its read returns
}

void ExposureWatcher::want(std::uint64_t seq) {
  {
    std::lock_guard lock(sh_->mutex);
    sh_->want = seq;
  }
  sh_->cv.notify_all();
}

KnownExposure ExposureWatcher::known() const {
  std::lock_guard lock(sh_->mutex);
  return sh_->known;
}

}  // namespace sensor_rig::camera::detail
