# The pbrt-v4 integration's mapping test (test_dpc_pbrt_map.cpp), included by tests/c/CMakeLists.txt:
# built and run wherever dpc's C tests are, with no pbrt. The models are the repository's own,
# found by name through $DPC_MODEL_PATH (libdpc's model search, as pbrt's Sampler "dpc" finds them).
add_executable(dpc_test_pbrt_map ${CMAKE_CURRENT_LIST_DIR}/test_dpc_pbrt_map.cpp ${CMAKE_CURRENT_LIST_DIR}/src/dpc_pbrt_map.cpp)
target_include_directories(dpc_test_pbrt_map PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src)
target_link_libraries(dpc_test_pbrt_map PRIVATE dpc GTest::gtest GTest::gtest_main Threads::Threads)
target_compile_features(dpc_test_pbrt_map PRIVATE cxx_std_17)
set_target_properties(dpc_test_pbrt_map PROPERTIES CXX_EXTENSIONS OFF)
if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
  target_compile_options(dpc_test_pbrt_map PRIVATE -Wall -Wextra)
endif()
gtest_discover_tests(dpc_test_pbrt_map
  DISCOVERY_TIMEOUT 120
  PROPERTIES ENVIRONMENT "DPC_ISA=;DPC_MODEL_PATH=${PROJECT_SOURCE_DIR}/models" LABELS "dpc;c;pbrt" TIMEOUT 300)
