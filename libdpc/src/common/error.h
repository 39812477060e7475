/* Thread-local error message: every failing path records why, the API returns the status. */
#ifndef DPC_COMMON_ERROR_H
#define DPC_COMMON_ERROR_H

#include "dpc/dpc.h"

#if defined(__GNUC__)
#define DPC_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define DPC_PRINTF(f, a)
#endif

/* Record a message for status and return status, so callers write `return dpc_fail(...)`. */
dpc_status dpc_fail(dpc_status status, const char *fmt, ...) DPC_PRINTF(2, 3);
/* Forget the message (called at the start of every API entry point). */
void dpc_clear_error(void);

#endif
