/* Its only job: prove dpc.h is C99 + -pedantic -Werror clean and usable from C. */
#include "dpc/dpc.h"

int dpc_header_c99_check(void);
int dpc_header_c99_check(void) {
    dpc_load_options options;
    dpc_model_info info;
    dpc_status status = DPC_OK;
    (void)options;
    (void)info;
    return (int)status + DPC_VERSION_NUMBER * 0 + DPC_FORMAT_VERSION * 0;
}
