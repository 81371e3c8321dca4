#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>

#include "sensor_rig/camera/v4l2_device.hpp"

namespace sensor_rig::camera {
namespace {

class SystemV4l2 final : public V4l2Device {
 public:
  int open(const std::string& path) override {
    const int fd = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    return fd >= 0 ? fd : -errno;
  }
  int close(int fd) override { return ::close(fd) == 0 ? 0 : -errno; }
  int ioctl(int fd, unsigned long request, void* arg) override {
    int rc = 0;
    do {
      rc = ::ioctl(fd, request, arg);
    } while (rc < 0 && errno == EINTR);
    return rc < 0 ? -errno : 0;
  }
  void* mmap(std::size_t length, int fd, off_t offset) override {
    void* p = ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, offset);
    return p == MAP_FAILED ? nullptr : p;
  }
  int munmap(void* addr, std::size_t length) override { return ::munmap(addr, length) == 0 ? 0 : -errno; }
  int poll(int fd, int timeout_ms) override {
    pollfd p{fd, POLLIN, 0};
    const int rc = ::poll(&p, 1, timeout_ms);
    if (rc < 0) return errno == EINTR ? 0 : -errno;
    if (rc > 0 && (p.revents & (POLLERR | POLLHUP | POLLNVAL)) != 0 && (p.revents & POLLIN) == 0) return -ENODEV;
    return rc;
  }
};

}  // namespace

std::shared_ptr<V4l2Device> system_v4l2() { return std::make_shared<SystemV4l2>(); }

}  // namespace sensor_rig::camera
