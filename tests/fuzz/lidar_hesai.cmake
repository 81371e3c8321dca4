# Hesai decoder fuzzer: build/fuzz_hesai, corpus in tests/fuzz/corpus/hesai.
rig_fuzzer(hesai SOURCES ${CMAKE_CURRENT_LIST_DIR}/fuzz_hesai.cpp DEPS rig_lidar_hesai)
if(TARGET fuzz_hesai)
  target_include_directories(fuzz_hesai PRIVATE ${CMAKE_SOURCE_DIR}/tests/lidar_hesai)
endif()
