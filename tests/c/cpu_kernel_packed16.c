/* The AVX-512 path's arrangement (16-lane vectors, two query points each; libdpc's
 * cpu_kernel_avx512.c) with portable primitives, compiled for every CPU into the kernel tests
 * only (not libdpc): not an ISA path anyone selects, but test_kernels.cpp compares it bit for
 * bit with the scalar path, which checks the 16-lane code on machines that cannot run AVX-512.
 * Compiled with libdpc's floating-point flags (tests/c/CMakeLists.txt). */
#define VW 16
#define KERNEL dpc_block_packed16
#define LIST_KERNEL dpc_list_packed16
#include "cpu/cpu_kernel_portable.h"
