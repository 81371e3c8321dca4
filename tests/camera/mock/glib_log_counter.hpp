#pragma once
// Counts GLib's warnings and criticals (Aravis' `g_return_if_fail` failures, GObject type checks)
// while a test runs, so a test can assert that Aravis complained about nothing. One structured log
// writer for the whole process (GLib takes it once); messages are still printed as usual.
#include <glib.h>

#include <mutex>
#include <string>
#include <vector>

namespace sensor_rig::camera::test {

class GlibLogCounter {
 public:
  GlibLogCounter() {
    static std::once_flag installed;
    std::call_once(installed, [] { g_log_set_writer_func(&GlibLogCounter::write, nullptr, nullptr); });
    std::lock_guard lock(mutex());
    messages() = {};
  }
  // "CRITICAL: <domain>: <message>" / "WARNING: ..." since this counter was made.
  [[nodiscard]] std::vector<std::string> complaints() const {
    std::lock_guard lock(mutex());
    return messages();
  }

 private:
  static GLogWriterOutput write(GLogLevelFlags level, const GLogField* fields, gsize n, gpointer user) {
    if ((level & (G_LOG_LEVEL_CRITICAL | G_LOG_LEVEL_WARNING)) != 0) {
      std::string domain = "?", text;
      for (gsize i = 0; i < n; ++i) {
        const std::string key = fields[i].key;
        const auto* value = static_cast<const char*>(fields[i].value);
        if (fields[i].length >= 0 || value == nullptr) continue;  // only NUL-terminated text fields
        if (key == "GLIB_DOMAIN") domain = value;
        if (key == "MESSAGE") text = value;
      }
      std::lock_guard lock(mutex());
      messages().push_back(std::string((level & G_LOG_LEVEL_CRITICAL) != 0 ? "CRITICAL: " : "WARNING: ") + domain + ": " + text);
    }
    return g_log_writer_default(level, fields, n, user);
  }
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static std::vector<std::string>& messages() {
    static std::vector<std::string> v;
    return v;
  }
};

}  // namespace sensor_rig::camera::test
