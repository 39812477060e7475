# The Vulkan benchmark program (bench_vulkan.c, run by bench_vulkan.py); included by bench/CMakeLists.txt.
add_executable(dpc_bench_vulkan ${CMAKE_CURRENT_SOURCE_DIR}/bench_vulkan.c)
target_link_libraries(dpc_bench_vulkan PRIVATE dpc)
set_target_properties(dpc_bench_vulkan PROPERTIES C_STANDARD 11)
