#pragma once
// Every access the V4L2 backend makes to a device goes through this interface, so a fake device
// (camera/mock) drives the real capture loop. Return values: >= 0 ok, -errno on failure.
#include <sys/types.h>

#include <cstddef>
#include <memory>
#include <string>

namespace sensor_rig::camera {

class V4l2Device {
 public:
  virtual ~V4l2Device() = default;
  virtual int open(const std::string& path) = 0;                       // fd or -errno
  virtual int close(int fd) = 0;
  virtual int ioctl(int fd, unsigned long request, void* arg) = 0;     // 0 or -errno
  virtual void* mmap(std::size_t length, int fd, off_t offset) = 0;    // nullptr on failure
  virtual int munmap(void* addr, std::size_t length) = 0;
  virtual int poll(int fd, int timeout_ms) = 0;                        // 1 ready, 0 timeout, -errno
};

// The kernel's: open(2), ioctl(2) (retried on EINTR), mmap(2), poll(2).
std::shared_ptr<V4l2Device> system_v4l2();

}  // namespace sensor_rig::camera
