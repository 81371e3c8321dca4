# rig_timesync: pure time estimation (no clock reads, no I/O): device-clock mapping, Velodyne
# top-of-hour time, the per-packet LIDAR stamper, and the linuxptp pmc status parser.
rig_library(rig_timesync
  SOURCES
    src/clock_mapper.cpp
    src/envelope_fit.cpp
    src/top_of_hour.cpp
    src/stamper.cpp
    src/ptp_status.cpp
  DEPS rig_common)
