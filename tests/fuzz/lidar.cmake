# Velodyne decoder fuzzer: build/fuzz_velodyne, corpus in tests/fuzz/corpus/velodyne.
rig_fuzzer(velodyne SOURCES ${CMAKE_CURRENT_LIST_DIR}/fuzz_velodyne.cpp DEPS rig_lidar_velodyne)
