#pragma once
// Opens Aravis sources from one thread each, all released at the same instant (as the rig's
// capture threads open their cameras), then takes frames from each. The last source can be
// reopened as its watchdog does (marked lost, opened again) while the others open.
#include <latch>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/camera/aravis_source.hpp"
#include "next_frame.hpp"

namespace sensor_rig::camera::test {

struct OpenOutcome {
  std::string error;  // CameraError of an open, "" when all opened
  int opens = 0;
  int frames = 0;     // frames taken (up to frames_per_open after each open)
};

inline std::vector<OpenOutcome> open_at_once(const std::vector<AravisSource*>& cams, int frames_per_open,
                                             int reopens_of_last = 0, int budget_ms = 3000) {
  std::vector<OpenOutcome> out(cams.size());
  std::latch go(static_cast<std::ptrdiff_t>(cams.size()));
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < cams.size(); ++i)
    threads.emplace_back([&cams, &out, &go, i, frames_per_open, reopens_of_last, budget_ms] {
      AravisSource& cam = *cams[i];
      OpenOutcome& o = out[i];
      go.arrive_and_wait();
      try {
        for (int round = 0; round <= (i + 1 == cams.size() ? reopens_of_last : 0); ++round) {
          if (cam.is_open()) cam.mark_lost();  // a lost device: its old handles go on another thread
          cam.open();
          ++o.opens;
          for (int k = 0; k < frames_per_open; ++k)
            if (next_frame(cam, budget_ms, /*skip_incomplete=*/true).status == CaptureStatus::kFrame) ++o.frames;
        }
      } catch (const CameraError& e) {
        o.error = e.what();
      }
    });
  for (auto& t : threads) t.join();
  return out;
}

}  // namespace sensor_rig::camera::test
