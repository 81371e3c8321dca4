# rig_dds: the only library that links Cyclone DDS (with the generated message types).
rig_library(rig_dds
  SOURCES src/dds_qos.cpp src/dds_participant.cpp
  DEPS rig_common rig_config rig_msgs CycloneDDS::ddsc)
target_compile_definitions(rig_dds PRIVATE RIG_DEFAULT_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
