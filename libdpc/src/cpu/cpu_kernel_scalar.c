/* Portable path: the canonical kernel (cpu_kernel_body.h) on 8-lane GCC vectors, which the
 * compiler lowers to whatever the target has (SSE2 on a generic x86-64 build); FMAs and table
 * lookups lane by lane (cpu_kernel_portable.h). On x86-64 this file is compiled twice: generic
 * (dpc_block_scalar), and with -mfma as cpu_kernel_scalar_fma.c (dpc_block_scalar_fma), which
 * the scalar path runs on CPUs with FMA so that fmaf is one instruction instead of a library
 * call. Same source, same bits. */
#define VW 8
#ifndef KERNEL
#define KERNEL dpc_block_scalar
#define LIST_KERNEL dpc_list_scalar
#endif
#include "cpu/cpu_kernel_portable.h"
