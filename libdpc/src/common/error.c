#include "common/error.h"

#include <stdarg.h>
#include <stdio.h>

/* C11 thread-local storage: one message per thread, no locking, nothing to free. */
static _Thread_local char g_message[512];

dpc_status dpc_fail(dpc_status status, const char *fmt, ...) {
    va_list args;
    va_start(args, fmt);
    vsnprintf(g_message, sizeof g_message, fmt, args);
    va_end(args);
    return status;
}

void dpc_clear_error(void) { g_message[0] = '\0'; }

const char *dpc_last_error(void) { return g_message; }
