# Scan bookkeeping shared by the vendor decoders (pure): included by lidar/CMakeLists.txt before the
# vendor folders, which link it; the registry (decoders/CMakeLists.txt) comes after them.
rig_library(rig_lidar_scan SOURCES ${CMAKE_CURRENT_LIST_DIR}/src/scan_assembler.cpp DEPS rig_common)
target_include_directories(rig_lidar_scan PUBLIC ${CMAKE_CURRENT_LIST_DIR}/../include)
