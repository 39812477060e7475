#include "common/error.h"

#include <stdarg.h>
#include <stdio.h>

/* C11 thread-local storage: one message per thread, no locking, nothing to free. Room for the
 * longest message, the model search's (its folders and the names it could find). */
static _Thread_local char g_message[4096];

dpc_status dpc_fail(dpc_status status, const char *fmt, ...) {
    va_list args;
    va_start(args, fmt);
    vsnprintf(g_message, sizeof g_message, fmt, args);
    va_end(args);
    return status;
}

void dpc_clear_error(void) { g_message[0] = '\0'; }

const char *dpc_last_error(void) { return g_message; }

/* The statuses' names live here, beside the message, so every layer can name a status. */
const char *dpc_status_string(dpc_status status) {
    switch (status) {
    case DPC_OK: return "DPC_OK";
    case DPC_ERROR_INVALID_ARGUMENT: return "DPC_ERROR_INVALID_ARGUMENT";
    case DPC_ERROR_IO: return "DPC_ERROR_IO";
    case DPC_ERROR_FORMAT: return "DPC_ERROR_FORMAT";
    case DPC_ERROR_UNSUPPORTED: return "DPC_ERROR_UNSUPPORTED";
    case DPC_ERROR_OUT_OF_MEMORY: return "DPC_ERROR_OUT_OF_MEMORY";
    case DPC_ERROR_LIMIT: return "DPC_ERROR_LIMIT";
    case DPC_ERROR_INTERNAL: return "DPC_ERROR_INTERNAL";
    case DPC_ERROR_CANCELLED: return "DPC_ERROR_CANCELLED";
    }
    return "DPC_ERROR_UNKNOWN";
}
