// dpc against PMJ02BN in one process: times pmj-cpp's GetPMJ02SamplesWithBlueNoise (Christensen et
// al. 2018's progressive multi-jittered (0,2) sequence with best-candidate blue noise, Andrew
// Helmer's implementation, built from a checkout given to CMake as DPC_PMJ_SRC, never copied
// here) and dpc_generate_n of a model, on one thread:
//   dpc_bench_pmj MODEL ISA(avx2|avx512) ROUNDS M [M ...]
// Each round runs each generator in turn: one call to warm up, then a few timed ones (as many
// as fit 2^20 points, 1 to 8); prints one JSON line per count with the medians of thread CPU
// time over every timed call.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <vector>

#include "dpc/dpc.h"
#include "sample_generation/pmj02.h"

namespace {

double cpu_now() {
    timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

} // namespace

int main(int argc, char **argv) {
    if (argc < 5) {
        std::fprintf(stderr, "usage: %s MODEL avx2|avx512 ROUNDS M [M ...]\n", argv[0]);
        return 2;
    }
    dpc_load_options opt;
    dpc_load_options_init(&opt);
    opt.threads = 1;
    opt.isa = std::strcmp(argv[2], "avx512") == 0 ? DPC_ISA_AVX512 : DPC_ISA_AVX2;
    dpc_model *model;
    if (dpc_model_load_file(argv[1], &opt, &model) != DPC_OK) {
        std::fprintf(stderr, "load failed: %s\n", dpc_last_error());
        return 1;
    }
    const int rounds = std::atoi(argv[3]);
    for (int a = 4; a < argc; a++) {
        const size_t m = std::strtoull(argv[a], nullptr, 10);
        std::vector<float> out(dpc_output_size(model, 1, m));
        std::vector<double> t_dpc, t_pmj;
        double checksum = 0.0; // keeps the compiler from dropping a generated set
        if (dpc_generate_n(model, 0, m, out.data()) != DPC_OK) {
            std::fprintf(stderr, "generate failed: %s\n", dpc_last_error());
            return 1;
        }
        const int reps = (int)std::max<size_t>(1, std::min<size_t>(8, ((size_t)1 << 20) / m));
        uint64_t seed = 1;
        for (int r = 0; r < rounds; r++) {
            dpc_generate_n(model, seed++, m, out.data());
            for (int i = 0; i < reps; i++) {
                const double c0 = cpu_now();
                dpc_generate_n(model, seed++, m, out.data());
                t_dpc.push_back(cpu_now() - c0);
                checksum += out[m - 1];
            }
            checksum += pmj::GetPMJ02SamplesWithBlueNoise((int)m)[m - 1].x;
            for (int i = 0; i < reps; i++) {
                const double c0 = cpu_now();
                checksum += pmj::GetPMJ02SamplesWithBlueNoise((int)m)[m - 1].x;
                t_pmj.push_back(cpu_now() - c0);
            }
        }
        std::printf("{\"model\": \"%s\", \"isa\": \"%s\", \"m\": %zu, \"rounds\": %d, \"dpc_cpu_median_s\": %.9f, "
                    "\"pmj02bn_cpu_median_s\": %.9f, \"checksum\": %.6f}\n",
                    argv[1], argv[2], m, rounds, median(t_dpc), median(t_pmj), checksum);
        std::fflush(stdout);
    }
    dpc_model_free(model);
    return 0;
}
