#pragma once
// glibc's heap in processes that move samples of 0.2-2 MB (point clouds, images) ten times a second.

namespace sensor_rig {

// Keeps freed buffers of up to 32 MB in the process for the next sample instead of returning them
// to the kernel. Cyclone allocates a new buffer per received sample (reassembly) and per take
// (deserialisation); with glibc's defaults a 1.2 MB cloud's were fresh pages on each copy: ~300
// page faults, ~1.3 ms on this VM, twice per cloud in the subscriber (dds/README.md). Call once,
// first thing in main(). Returns false if glibc refused a setting (then nothing is promised).
bool keep_large_buffers() noexcept;

}  // namespace sensor_rig
