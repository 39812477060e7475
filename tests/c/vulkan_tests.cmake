# The backend-choice and Vulkan tests (test_vulkan.cpp), included by tests/c/CMakeLists.txt. Built
# in every configuration: without DPC_VULKAN they check that explicit Vulkan is
# DPC_ERROR_UNSUPPORTED and skip the device tests, saying so. All carry the label "vulkan":
# run_all.sh runs them on lavapipe with leak detection off (ASAN_OPTIONS=detect_leaks=0; the
# Vulkan driver leaks a little), the rest of the suite keeps it on.
add_executable(dpc_test_vulkan test_vulkan.cpp)
target_link_libraries(dpc_test_vulkan PRIVATE dpc GTest::gtest GTest::gtest_main Threads::Threads)
target_compile_features(dpc_test_vulkan PRIVATE cxx_std_17)
set_target_properties(dpc_test_vulkan PROPERTIES CXX_EXTENSIONS OFF)
if(DPC_VULKAN)
  set(dpc_test_have_vulkan 1)
else()
  set(dpc_test_have_vulkan 0)
endif()
target_compile_definitions(dpc_test_vulkan PRIVATE DPC_TEST_DATA_DIR="${PROJECT_SOURCE_DIR}/tests/data"
                                                   DPC_TEST_HAVE_VULKAN=${dpc_test_have_vulkan})
if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
  target_compile_options(dpc_test_vulkan PRIVATE -Wall -Wextra)
endif()
gtest_discover_tests(dpc_test_vulkan
  DISCOVERY_TIMEOUT 120
  PROPERTIES ENVIRONMENT "DPC_ISA=" LABELS "dpc;c;vulkan" TIMEOUT 600)

# A machine without Vulkan, simulated: the loader library cannot be found.
add_test(NAME vulkan.no_loader
         COMMAND dpc_test_vulkan --gtest_filter=NoVulkanLoader.*)
set_tests_properties(vulkan.no_loader PROPERTIES
  ENVIRONMENT "DPC_ISA=;DPC_VULKAN_LOADER=/nonexistent/dpc-test/libvulkan.so.1"
  LABELS "dpc;c;vulkan" SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]")

# A machine with the loader but no driver, simulated: the environment names a missing manifest
# before the process starts (libdpc reads it once, at its one Vulkan instance).
add_test(NAME vulkan.no_driver
         COMMAND dpc_test_vulkan --gtest_filter=NoVulkanDriver.*)
set_tests_properties(vulkan.no_driver PROPERTIES
  ENVIRONMENT "DPC_ISA=;VK_DRIVER_FILES=/nonexistent/dpc-test/no_icd.json;VK_ICD_FILENAMES=/nonexistent/dpc-test/no_icd.json"
  LABELS "dpc;c;vulkan" SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]")

if(DPC_VULKAN AND DPC_GLSLC)
  # The checked-in SPIR-V is what the checked-in GLSL compiles to (skipped when this glslc is not
  # the version that wrote the header: other versions emit other words).
  add_test(NAME vulkan.spirv_header_is_current
           COMMAND ${CMAKE_COMMAND} -DGLSLC=${DPC_GLSLC} -DOUT=${CMAKE_CURRENT_BINARY_DIR}/vk_spirv_check.h
                   -DCHECKED_IN=${PROJECT_SOURCE_DIR}/libdpc/src/vulkan/vk_spirv.h
                   -P ${CMAKE_CURRENT_SOURCE_DIR}/vulkan_spirv_check.cmake)
  set_tests_properties(vulkan.spirv_header_is_current PROPERTIES LABELS "dpc;c;vulkan" SKIP_REGULAR_EXPRESSION "dpc-skip:")
endif()
