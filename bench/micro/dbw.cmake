# dbw benchmarks: codec/E2E/safety hot paths (bench_dbw) and the bridge's command -> CAN latency,
# command silence -> first disengage frame, and CPU at 100 Hz (bench_dbw_latency).
if(TARGET rig_dbw_bridge)
  add_executable(bench_dbw ${CMAKE_CURRENT_LIST_DIR}/bench_dbw.cpp)
  target_link_libraries(bench_dbw PRIVATE rig_dbw_bridge rig_canlog benchmark::benchmark rig_warnings)
  target_compile_definitions(bench_dbw PRIVATE RIG_DBW_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
  set_target_properties(bench_dbw PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR})
endif()
if(TARGET rig_dbw_dds AND TARGET rig_dbw_mock)
  add_executable(bench_dbw_latency ${CMAKE_CURRENT_LIST_DIR}/bench_dbw_latency.cpp)
  target_link_libraries(bench_dbw_latency PRIVATE rig_dbw_dds rig_dbw_mock rig_warnings)
  target_compile_definitions(bench_dbw_latency PRIVATE RIG_DBW_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
  set_target_properties(bench_dbw_latency PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR})
endif()
