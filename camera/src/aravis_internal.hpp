#pragma once
// Private to AravisSource's files (aravis_source.cpp: capture and triggers; aravis_open.cpp: open,
// configuration, reopen and close; aravis_ptp.cpp: the PTP state): the per-connection state and
// the GLib helpers they share. Nothing outside camera/src includes it.
#include <arv.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gvsp_payload.hpp"
#include "sensor_rig/camera/aravis_source.hpp"
#include "sensor_rig/camera/frame.hpp"

namespace sensor_rig::camera {
namespace detail {

// GError -> CameraError text; frees the error.
inline std::string take_error(GError*& e) {
  std::string s = e != nullptr && e->message != nullptr ? e->message : "unknown error";
  if (e != nullptr) g_error_free(e);
  e = nullptr;
  return s;
}

template <class T>
inline void unref(T*& p) noexcept {
  if (p != nullptr) g_object_unref(p);
  p = nullptr;
}

// A GenICam feature's value as text; "" and `error` set when absent or unreadable.
inline std::string feature_text(ArvDevice* dev, const char* name, std::string& error) {
  ArvGcNode* node = arv_device_get_feature(dev, name);
  if (node == nullptr || !ARV_IS_GC_FEATURE_NODE(node)) {
    error = std::string("no feature ") + name;
    return {};
  }
  GError* err = nullptr;
  const char* v = arv_gc_feature_node_get_value_as_string(reinterpret_cast<ArvGcFeatureNode*>(node), &err);
  if (err != nullptr) {
    error = std::string(name) + ": " + take_error(err);
    return {};
  }
  return v != nullptr ? v : "";
}

inline void on_control_lost(ArvDevice* /*device*/, gpointer user) {
  static_cast<std::atomic<bool>*>(user)->store(true);
}

}  // namespace detail

struct AravisSource::State {
  ArvCamera* camera = nullptr;
  ArvDevice* device = nullptr;  // borrowed from camera
  ArvStream* stream = nullptr;
  bool gv = false;
  std::string address;  // a GigE camera's IPv4 address (close() asks it whether it still answers)
  std::unique_ptr<BufferPool> pool;
  std::vector<ArvBuffer*> buffers;  // owned by the stream once pushed
  std::size_t payload = 0;
  std::uint64_t seq = 0;
  detail::ChunkReader chunks;  // the capture thread's
};

}  // namespace sensor_rig::camera
