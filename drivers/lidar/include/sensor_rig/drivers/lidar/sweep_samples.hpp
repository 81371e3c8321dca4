#pragma once
// A scan's points as sweep samples for timesync::SweepPhase (cameras triggered by this LIDAR's
// sweep): azimuth in the LIDAR frame (REP 103: atan2(y, x), 0 = forward, 90 = left) and the
// point's firing time in vehicle time (header.stamp + t). Up to `max_samples`, evenly over the
// scan's points in firing order; points nearer than `min_range_m` horizontally are skipped (the
// lasers' few-cm offsets from the axis turn their azimuth by degrees).
#include <cstddef>
#include <vector>

#include "sensor_rig/lidar/point_cloud.hpp"
#include "sensor_rig/timesync/sweep_phase.hpp"

namespace sensor_rig::drivers {

void sweep_samples(const lidar::Scan& scan, std::vector<timesync::SweepSample>& out, std::size_t max_samples = 1024,
                   double min_range_m = 2.0);

}  // namespace sensor_rig::drivers
