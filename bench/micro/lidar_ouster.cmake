# Ouster decode throughput (ns/packet, points/s): the shared OS-1-32-G capture and synthetic OS-2-128 packets.
get_filename_component(_rig_data_default ${CMAKE_SOURCE_DIR}/../shared/data ABSOLUTE)
add_executable(bench_lidar_ouster ${CMAKE_CURRENT_LIST_DIR}/bench_lidar_ouster.cpp)
target_include_directories(bench_lidar_ouster PRIVATE ${CMAKE_SOURCE_DIR}/tests/lidar_ouster)
target_link_libraries(bench_lidar_ouster PRIVATE rig_lidar_ouster rig_lidar_pcap nlohmann_json::nlohmann_json
  benchmark::benchmark rig_warnings)
target_compile_definitions(bench_lidar_ouster PRIVATE RIG_TEST_DATA_DEFAULT="${_rig_data_default}")
set_target_properties(bench_lidar_ouster PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR})
