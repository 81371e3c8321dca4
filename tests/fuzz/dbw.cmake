# DBC parser/codec and candump-line fuzzers: build/fuzz_dbc, build/fuzz_candump.
rig_fuzzer(dbc SOURCES ${CMAKE_CURRENT_LIST_DIR}/fuzz_dbc.cpp DEPS rig_dbc)
rig_fuzzer(candump SOURCES ${CMAKE_CURRENT_LIST_DIR}/fuzz_candump.cpp DEPS rig_canlog)
