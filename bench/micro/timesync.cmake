# bench_timesync: cost of the time-mapping hot path (observe, to_vehicle, per-packet stamp).
if(TARGET rig_timesync)
  add_executable(bench_timesync ${CMAKE_CURRENT_LIST_DIR}/bench_timesync.cpp)
  target_link_libraries(bench_timesync PRIVATE rig_timesync benchmark::benchmark rig_warnings)
  set_target_properties(bench_timesync PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR})
endif()
