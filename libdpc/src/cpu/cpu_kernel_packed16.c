/* The AVX-512 path's arrangement (16-lane vectors, two query points each; cpu_kernel_avx512.c)
 * with portable primitives, compiled for every CPU: not an ISA path anyone selects, but the
 * kernel tests compare it bit for bit with the scalar path, which checks the 16-lane code on
 * machines that cannot run AVX-512. */
#define VW 16
#define KERNEL dpc_block_packed16
#define LIST_KERNEL dpc_list_packed16
#include "cpu/cpu_kernel_portable.h"
