// Shared helpers of the libdpc C tests: test-data paths, file reading, the documented input
// generator written out independently (docs/model-format.md §5), CPU feature checks.
// Only the public header dpc/dpc.h is used.
#ifndef DPC_TEST_UTIL_H
#define DPC_TEST_UTIL_H

#include <dpc/dpc.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#ifndef DPC_TEST_DATA_DIR
#error "DPC_TEST_DATA_DIR must name tests/data (set by tests/c/CMakeLists.txt)"
#endif

namespace dpct {

// The five committed test models (tests/data/make_models.py).
inline const std::vector<std::string> &model_names() {
    static const std::vector<std::string> names = {"model_2d", "model_3d_proj", "model_3d_mixed", "model_grid_3to1",
                                                   "model_10d"};
    return names;
}

// DPC_TEST_DATA_DIR in the environment overrides the folder compiled in, so a test binary built
// here also runs from another checkout (bench/gpu_run.sh carries it to a GPU machine).
inline std::string data_path(const std::string &rel) {
    const char *env = std::getenv("DPC_TEST_DATA_DIR");
    return std::string(env && *env ? env : DPC_TEST_DATA_DIR) + "/" + rel;
}
inline std::string model_path(const std::string &name) { return data_path(name + ".onnx"); }

inline std::vector<uint8_t> read_file(const std::string &path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return {};
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

struct ModelDeleter {
    void operator()(dpc_model *m) const { dpc_model_free(m); }
};
using ModelPtr = std::unique_ptr<dpc_model, ModelDeleter>;

// Load a model file with the given ISA and thread count; fails the current test on error.
inline ModelPtr load(const std::string &path, dpc_isa isa = DPC_ISA_AUTO, uint32_t threads = 1) {
    dpc_load_options o;
    dpc_load_options_init(&o);
    o.isa = isa;
    o.threads = threads;
    dpc_model *m = nullptr;
    dpc_status st = dpc_model_load_file(path.c_str(), &o, &m);
    EXPECT_EQ(st, DPC_OK) << path << ": " << dpc_status_string(st) << ": " << dpc_last_error();
    return ModelPtr(m);
}

inline dpc_model_info info_of(const dpc_model *m) {
    dpc_model_info info{};
    EXPECT_EQ(dpc_model_get_info(m, &info), DPC_OK) << dpc_last_error();
    return info;
}

// Generate n points (0 = trained count) and return them; fails the test on error.
inline std::vector<float> generate(const dpc_model *m, uint64_t seed, size_t n = 0) {
    dpc_model_info info = info_of(m);
    size_t count = n ? n : info.n_points;
    std::vector<float> out(count * info.dims, -1.0f);
    dpc_status st = dpc_generate_n(m, seed, n, out.data());
    EXPECT_EQ(st, DPC_OK) << dpc_last_error();
    return out;
}

// SplitMix64 as written in docs/model-format.md §5, independently of libdpc.
inline uint64_t mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
inline uint64_t stream_value(uint64_t seed, uint64_t c) { return mix64(mix64(seed) + (c + 1) * 0x9E3779B97F4A7C15ull); }
inline float uniform_value(uint64_t seed, uint64_t c) {
    return (float)(stream_value(seed, c) >> 40) * (1.0f / 16777216.0f);
}

// Distance on the unit circle between two coordinates.
inline double torus_diff(double a, double b) {
    double d = std::fabs(a - b);
    return d < 1.0 - d ? d : 1.0 - d;
}
inline double max_torus_diff(const std::vector<float> &a, const std::vector<float> &b) {
    double worst = a.size() == b.size() ? 0.0 : INFINITY;
    for (size_t i = 0; i < a.size() && i < b.size(); i++) {
        double d = torus_diff(a[i], b[i]);
        if (!(d <= worst)) worst = d; // NaN propagates as "worse"
    }
    return worst;
}

inline bool cpu_has_avx2_fma() { return dpc_isa_supported(DPC_ISA_AVX2) != 0; }
inline bool cpu_has_avx512() { return dpc_isa_supported(DPC_ISA_AVX512) != 0; }

// The ISA paths to compare against scalar: every one this CPU supports.
inline std::vector<dpc_isa> vector_isas() {
    std::vector<dpc_isa> v;
    if (cpu_has_avx2_fma()) v.push_back(DPC_ISA_AVX2);
    if (cpu_has_avx512()) v.push_back(DPC_ISA_AVX512);
    return v;
}

inline std::string isa_name(dpc_isa isa) {
    switch (isa) {
    case DPC_ISA_AUTO: return "auto";
    case DPC_ISA_SCALAR: return "scalar";
    case DPC_ISA_AVX2: return "avx2";
    case DPC_ISA_AVX512: return "avx512";
    }
    return "unknown";
}

// The pinned status values and their names, as dpc.h documents them.
struct StatusName {
    dpc_status status;
    const char *name;
};
inline const std::vector<StatusName> &status_names() {
    static const std::vector<StatusName> v = {
        {DPC_OK, "DPC_OK"},
        {DPC_ERROR_INVALID_ARGUMENT, "DPC_ERROR_INVALID_ARGUMENT"},
        {DPC_ERROR_IO, "DPC_ERROR_IO"},
        {DPC_ERROR_FORMAT, "DPC_ERROR_FORMAT"},
        {DPC_ERROR_UNSUPPORTED, "DPC_ERROR_UNSUPPORTED"},
        {DPC_ERROR_OUT_OF_MEMORY, "DPC_ERROR_OUT_OF_MEMORY"},
        {DPC_ERROR_LIMIT, "DPC_ERROR_LIMIT"},
        {DPC_ERROR_INTERNAL, "DPC_ERROR_INTERNAL"},
    };
    return v;
}
inline bool status_from_name(const std::string &name, dpc_status *out) {
    for (const StatusName &s : status_names())
        if (name == s.name) {
            *out = s.status;
            return true;
        }
    return false;
}

} // namespace dpct

#endif
