# Velodyne decode throughput (ns/packet, points/s) over the shared captures, or synthetic packets.
get_filename_component(_rig_data_default ${CMAKE_SOURCE_DIR}/../shared/data ABSOLUTE)
add_executable(bench_lidar_decode ${CMAKE_CURRENT_LIST_DIR}/bench_lidar_decode.cpp)
target_link_libraries(bench_lidar_decode PRIVATE rig_lidar_velodyne rig_lidar_pcap benchmark::benchmark rig_warnings)
target_compile_definitions(bench_lidar_decode PRIVATE RIG_TEST_DATA_DEFAULT="${_rig_data_default}")
set_target_properties(bench_lidar_decode PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR})
