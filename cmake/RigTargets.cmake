# Common compile settings for every sensor-rig target.
add_library(rig_warnings INTERFACE)
target_compile_options(rig_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Werror -Wshadow -Wconversion -Wno-sign-conversion -Wcast-align
  -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough
  $<$<COMPILE_LANGUAGE:CXX>:-Wnon-virtual-dtor -Wold-style-cast -Woverloaded-virtual>)

# GCC 12 at -O3 reports std::string concatenation and assignment as overlapping memcpy
# (-Wrestrict false positives: GCC bugs 105329, 105651; fixed in GCC 13). The warning stays an
# error with other compilers and versions.
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_GREATER_EQUAL 12
   AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
  target_compile_options(rig_warnings INTERFACE -Wno-restrict)
endif()

if(RIG_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
  # GCC 12's object-size analysis at -O2 walks ASan's instrumented paths and reports impossible
  # sizes (e.g. a 2^64-byte memset in vector::resize). The uninstrumented builds keep these as errors.
  target_compile_options(rig_warnings INTERFACE -Wno-stringop-overflow -Wno-stringop-overread
    -Wno-array-bounds -Wno-restrict -Wno-maybe-uninitialized)
endif()

# A unity batch includes the target's .cpp files into one file, so GCC takes a class of one .cpp that
# holds a type from that .cpp's anonymous namespace for one "defined in a header" (-Wsubobject-linkage).
# Each .cpp is still its own unit in the per-file builds, which keep the warning.
if(RIG_UNITY_BUILD AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  target_compile_options(rig_warnings INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-Wno-subobject-linkage>)
endif()

# libFuzzer builds: the libraries under test carry the fuzzer's coverage and the sanitizers, not
# only the harness file; otherwise libFuzzer sees no branch of a decoder (it stalls at the harness's
# own ~20 edges) and ASan misses the decoders' out-of-bounds accesses.
if(RIG_FUZZ)
  # -fno-sanitize-recover: undefined behaviour is a finding that stops the run, as in the ASan
  # stage; recovering, libFuzzer only printed it (five DBC/Ouster UB cases went by unflagged).
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()

# The standard headers the project's files include most (counted over the sources), precompiled once
# for the libraries and once more, with GoogleTest, for the tests.
set(RIG_PCH_STD_HEADERS <algorithm> <array> <atomic> <chrono> <cmath> <condition_variable> <cstddef>
    <cstdint> <cstdio> <cstdlib> <cstring> <deque> <filesystem> <fstream> <functional> <map> <memory>
    <mutex> <optional> <set> <span> <sstream> <stdexcept> <string> <string_view> <thread> <utility> <vector>)

# GCC 12 with a precompiled <string> reports std::string copies as out of bounds (-Warray-bounds on
# char_traits' memcpy: the false-positive family of GCC bugs 105329/105651, seen on
# dds/src/security_checks.cpp, not without the PCH). Clang (make fuzz) keeps these warnings, and the
# ASan/UBSan stage checks bounds at run time.
set(_rig_gcc12_pch_flags "")
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
  set(_rig_gcc12_pch_flags -Wno-array-bounds -Wno-stringop-overflow -Wno-stringop-overread)
endif()

# -pthread for every file: Aravis's and GLib's pkg-config flags bring it (and with it _REENTRANT) to
# the camera libraries, and a precompiled header is only used where such macros are the same.
add_compile_options($<$<COMPILE_LANGUAGE:CXX>:-pthread>)

# rig_library(NAME SOURCES... DEPS ...): a static library with the area's public include dir.
function(rig_library name)
  cmake_parse_arguments(A "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${A_SOURCES})
  target_include_directories(${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
                                     PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(${name} PUBLIC ${A_DEPS} PRIVATE rig_warnings ${A_PRIVATE_DEPS})
  set_target_properties(${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  # One precompiled header of the standard library for every library's C++ files: parsing was
  # 40-77 % of a typical library file's compile at -O3 (-ftime-report on 8 files); with the PCH, 24
  # library files chosen at random compiled in 87 s instead of 109 s (-21 %, side by side, Release,
  # 2026-11-28), ~205 such files in each of make test's two full builds.
  # Only the standard library: a third-party or project header in it would let a file compile
  # here without its own #include.
  if(NOT TARGET rig_library_pch)
    add_library(rig_library_pch OBJECT ${CMAKE_SOURCE_DIR}/cmake/library_pch.cpp)
    target_link_libraries(rig_library_pch PRIVATE rig_warnings)
    target_compile_options(rig_library_pch PRIVATE ${_rig_gcc12_pch_flags})
    set_target_properties(rig_library_pch PROPERTIES POSITION_INDEPENDENT_CODE ON)
    target_precompile_headers(rig_library_pch PRIVATE ${RIG_PCH_STD_HEADERS})
  endif()
  target_precompile_headers(${name} REUSE_FROM rig_library_pch)
  target_compile_options(${name} PRIVATE ${_rig_gcc12_pch_flags})
  foreach(_src IN LISTS A_SOURCES)
    if(_src MATCHES "\\.c$")
      # The PCH is C++ only; a C file also stays out of unity batches, whose generated file would
      # otherwise be given the (absent) C precompiled header.
      set_source_files_properties(${_src} PROPERTIES SKIP_PRECOMPILE_HEADERS ON SKIP_UNITY_BUILD_INCLUSION ON)
    endif()
  endforeach()
endfunction()

# rig_command_unit(TARGET FILES...): a target's files that build CLI11 commands, compiled as one
# translation unit (CMake's unity build, this group only). CLI11 2.1 is header-only and defines its
# validators as objects in the header, so every file that includes it pays ~9 s of CPU at -O2 before
# any code of its own (a 12-line file adding five options: 15 s; bench/perf/src/grid.cpp 13.5 s with
# <CLI/CLI.hpp>, 4.8 s without, 2026-11-29): ~20 such files in each of make test's two full builds.
# The files of a group must not define the same file-local names.
# In a unity build (RIG_UNITY_BUILD) the target's other C++ files go to groups of 8 too; a group
# build would otherwise compile them one by one. Call it after the target's last target_sources().
function(rig_command_unit target)
  set_source_files_properties(${ARGN} TARGET_DIRECTORY ${target} PROPERTIES UNITY_GROUP commands)
  set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_MODE GROUP)
  if(RIG_UNITY_BUILD)
    get_target_property(_sources ${target} SOURCES)
    set(_n 0)
    foreach(_src IN LISTS _sources)
      if(_src MATCHES "\\.cpp$" AND NOT _src IN_LIST ARGN)
        math(EXPR _batch "${_n} / 8")
        set_source_files_properties(${_src} TARGET_DIRECTORY ${target} PROPERTIES UNITY_GROUP batch_${_batch})
        math(EXPR _n "${_n} + 1")
      endif()
    endforeach()
  endif()
endfunction()

# rig_test(NAME LABEL SOURCES... DEPS ...): a GoogleTest executable registered with ctest.
function(rig_test name)
  cmake_parse_arguments(A "" "LABEL;TIMEOUT" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${A_SOURCES})
  target_link_libraries(${name} PRIVATE ${A_DEPS} GTest::gtest GTest::gtest_main GTest::gmock rig_warnings)
  # One precompiled GoogleTest/GoogleMock header for every test executable: parsing them was ~1.8 s
  # of the ~6.7 s a test file takes at -O3 (measured on test_clock_mapper.cpp), times ~120 test files
  # in two CI builds. Where a test's flags ever differ, GCC ignores the PCH and reads the headers.
  # GCC 12 at -O2 with the PCH reports std::string copies in tests as out of bounds (-Warray-bounds
  # on char_traits' memcpy: the false-positive family of GCC bugs 105329/105651, seen on
  # sync_sets_test.cpp, not without the PCH); tests only, the libraries keep the warning, and the
  # ASan/UBSan stage checks the tests' bounds at run time.
  set(_gcc12_test_flags "")
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    set(_gcc12_test_flags -Wno-array-bounds -Wno-stringop-overflow -Wno-stringop-overread)
  endif()
  # The tests' own code at -Og in the optimized configurations: it drives the rig (sockets, mocks,
  # assertions) and does no work that needs -O3, while -O3 was most of a test file's compile after
  # the PCH (test_camera_isolation.cpp: 7.7 s at -O3, 5.5 s at -Og). The libraries and the rig they
  # test keep the configuration's level. GCC's -Wmaybe-uninitialized is unreliable at -Og (its
  # documented false positives), so tests leave it out there; -O3 builds of the libraries keep it.
  list(APPEND _gcc12_test_flags $<$<CONFIG:Release,RelWithDebInfo>:-Og> $<$<CONFIG:Release,RelWithDebInfo>:-Wno-maybe-uninitialized>)
  set(_rig_test_defaults RIG_DEFAULT_SOURCE_DIR="${CMAKE_SOURCE_DIR}" RIG_DEFAULT_BIN="${CMAKE_BINARY_DIR}/rig"
      RIG_DEFAULT_TEST_DATA="${RIG_TEST_DATA}")
  if(NOT TARGET rig_test_pch)
    add_library(rig_test_pch OBJECT ${CMAKE_SOURCE_DIR}/tests/support/test_pch.cpp)
    target_link_libraries(rig_test_pch PRIVATE GTest::gtest GTest::gmock rig_warnings)
    target_compile_options(rig_test_pch PRIVATE ${_gcc12_test_flags})
    target_compile_definitions(rig_test_pch PRIVATE ${_rig_test_defaults})
    target_precompile_headers(rig_test_pch PRIVATE ${RIG_PCH_STD_HEADERS} <gtest/gtest.h> <gmock/gmock.h>)
  endif()
  target_compile_options(${name} PRIVATE ${_gcc12_test_flags})
  # ctest's environment (below) as built-in defaults: an executable run by hand finds the rig and
  # the sources too. The same definitions on the PCH, whose flags must match.
  target_compile_definitions(${name} PRIVATE ${_rig_test_defaults})
  target_precompile_headers(${name} REUSE_FROM rig_test_pch)
  target_include_directories(${name} PRIVATE ${CMAKE_SOURCE_DIR}/tests/support)
  if(NOT A_LABEL)
    set(A_LABEL unit)
  endif()
  if(NOT A_TIMEOUT)
    set(A_TIMEOUT 120)
  endif()
  add_test(NAME ${name} COMMAND ${name})
  # Per label, the executables: `unit_tests` builds just the unit ones (the sanitizer stages).
  set_property(GLOBAL APPEND PROPERTY RIG_TEST_TARGETS_${A_LABEL} ${name})
  set_tests_properties(${name} PROPERTIES LABELS ${A_LABEL} TIMEOUT ${A_TIMEOUT}
    ENVIRONMENT "RIG_TEST_DATA=${RIG_TEST_DATA};RIG_BIN=${CMAKE_BINARY_DIR}/rig;RIG_SOURCE_DIR=${CMAKE_SOURCE_DIR}")
  rig_test_leaves_host_clean(${name})
endfunction()

# Every test runs between the host's snapshot and the check that it was left as it was
# (tests/CMakeLists.txt: host_state_snapshot, host_left_clean; ctest adds both to any selection).
function(rig_test_leaves_host_clean)
  set_property(TEST ${ARGN} APPEND PROPERTY FIXTURES_REQUIRED host_state)
endfunction()

# Where the real captures live; tests skip with a message when absent.
if(DEFINED ENV{RIG_TEST_DATA})
  set(RIG_TEST_DATA $ENV{RIG_TEST_DATA})
else()
  get_filename_component(RIG_TEST_DATA ${CMAKE_SOURCE_DIR}/../shared/data ABSOLUTE)
endif()
