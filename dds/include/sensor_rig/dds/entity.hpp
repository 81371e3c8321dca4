#pragma once
// RAII over Cyclone DDS C API handles. Only dds/ (rig_dds) includes <dds/dds.h>.
// One error style for Cyclone's return codes: setup (create, attach) goes through check() and
// throws DdsError; hot paths (write) return a Result that the caller counts and reports.
#include <dds/dds.h>

#include <stdexcept>
#include <string>
#include <utility>

namespace sensor_rig::dds {

struct DdsError : std::runtime_error {
  DdsError(const std::string& what, dds_return_t rc)
      : std::runtime_error(what + ": " + dds_strretcode(rc)), code(rc) {}
  // DDS Security's access control refused it (the permissions do not grant it).
  [[nodiscard]] bool not_allowed_by_security() const { return code == DDS_RETCODE_NOT_ALLOWED_BY_SECURITY; }
  dds_return_t code;
};

// Throws DdsError when `rc` is negative; returns it otherwise (entity handles are positive).
inline dds_return_t check(dds_return_t rc, const char* what) {
  if (rc < 0) throw DdsError(what, rc);
  return rc;
}

// The outcome of a hot-path call: ok, or Cyclone's code and its text. Never throws.
class Result {
 public:
  explicit Result(dds_return_t rc) noexcept : rc_(rc) {}
  [[nodiscard]] bool ok() const noexcept { return rc_ >= 0; }
  [[nodiscard]] dds_return_t code() const noexcept { return rc_; }
  [[nodiscard]] std::string message() const { return dds_strretcode(rc_); }

 private:
  dds_return_t rc_;
};

// Owns one entity; deleting it deletes its children too (Cyclone semantics).
class Entity {
 public:
  Entity() = default;
  explicit Entity(dds_entity_t h) noexcept : h_(h) {}
  Entity(const Entity&) = delete;
  Entity& operator=(const Entity&) = delete;
  Entity(Entity&& o) noexcept : h_(std::exchange(o.h_, 0)) {}
  Entity& operator=(Entity&& o) noexcept {
    if (this != &o) {
      reset();
      h_ = std::exchange(o.h_, 0);
    }
    return *this;
  }
  ~Entity() { reset(); }

  [[nodiscard]] dds_entity_t handle() const noexcept { return h_; }
  explicit operator bool() const noexcept { return h_ > 0; }
  void reset() noexcept {
    if (h_ > 0) dds_delete(h_);
    h_ = 0;
  }

 private:
  dds_entity_t h_ = 0;
};

}  // namespace sensor_rig::dds
