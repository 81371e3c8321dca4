# Hesai decode throughput (ns/packet, points/s): the Pandar40P capture, synthetic PandarXT32 packets.
get_filename_component(_rig_data_default ${CMAKE_SOURCE_DIR}/../shared/data ABSOLUTE)
add_executable(bench_lidar_hesai ${CMAKE_CURRENT_LIST_DIR}/bench_lidar_hesai.cpp)
target_include_directories(bench_lidar_hesai PRIVATE ${CMAKE_SOURCE_DIR}/tests/lidar_hesai)
target_link_libraries(bench_lidar_hesai PRIVATE rig_lidar_hesai rig_lidar_pcap benchmark::benchmark rig_warnings)
target_compile_definitions(bench_lidar_hesai PRIVATE RIG_TEST_DATA_DEFAULT="${_rig_data_default}")
set_target_properties(bench_lidar_hesai PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR})
