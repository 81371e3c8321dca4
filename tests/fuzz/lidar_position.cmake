# Velodyne position packet / NMEA RMC fuzzer: build/fuzz_position, corpus in tests/fuzz/corpus/position.
rig_fuzzer(position SOURCES ${CMAKE_CURRENT_LIST_DIR}/fuzz_position_packet.cpp DEPS rig_lidar_position)
