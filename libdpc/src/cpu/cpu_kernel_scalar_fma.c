/* The scalar path compiled with -mfma (cpu_kernel_scalar.c explains why). */
#define KERNEL dpc_block_scalar_fma
#define LIST_KERNEL dpc_list_scalar_fma
#include "cpu_kernel_scalar.c"
