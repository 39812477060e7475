// The header from C++ (extern "C", no warnings) and the runtime version matching the macros.
#include <cstdio>
#include <cstring>

#include "dpc/dpc.h"

int main() {
    if (dpc_version_number() != DPC_VERSION_NUMBER) {
        std::printf("runtime version %u != header version %d\n", dpc_version_number(), DPC_VERSION_NUMBER);
        return 1;
    }
    if (std::strcmp(dpc_status_string(DPC_ERROR_FORMAT), "DPC_ERROR_FORMAT") != 0) return 1;
    char path[DPC_PATH_MAX] = "x";
    if (dpc_model_find("../escape", path, sizeof path) != DPC_ERROR_INVALID_ARGUMENT || path[0] != '\0') return 1;
    std::printf("libdpc %s\n", dpc_version_string());
    return 0;
}
