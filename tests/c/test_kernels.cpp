// The filter kernels themselves (libdpc/src/cpu/cpu_kernel_*.c), below the public API: every
// ISA path and the 16-lane arrangement of the AVX-512 path (dpc_block_packed16, portable, so it
// runs here even without AVX-512) give the same bits as the scalar path on random jobs: subspace
// sizes 1-6, small (register) and large (gathered) tables, one range or many (concatenated in
// chunks past DPC_GATHER_CAP), odd and even numbers of query points, and local blocks (which skip
// the minimum image) the bits of those that do not. The list kernels (one query
// over an explicit candidate list, the neighbour lists' path) give the all-pairs bits for any
// candidate list that holds the points in the window. And the sums match a float64 evaluation of
// the formula to float rounding.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include <gtest/gtest.h>

extern "C" {
#include "cpu/cpu_kernels.h"

// The AVX-512 path's 16-lane arrangement with portable primitives (cpu_kernel_packed16.c, built
// into this test only).
void dpc_block_packed16(const dpc_sub_job *job, const float *xs, unsigned count, const uint32_t *ranges,
                        unsigned n_ranges, int local, float *acc, float *scratch);
void dpc_list_packed16(const dpc_sub_job *job, const float *x, const uint32_t *cand, unsigned n, float *acc);
}

namespace {

bool has_avx2() {
#if defined(__x86_64__)
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
    return false;
#endif
}
bool has_avx512() {
#if defined(__x86_64__)
    __builtin_cpu_init();
    return has_avx2() && __builtin_cpu_supports("avx512f");
#else
    return false;
#endif
}

struct Job {
    unsigned k;
    std::vector<std::vector<float>> cols; // candidate coordinates, padded for vector reads
    std::vector<float> w, dw;
    std::vector<uint32_t> ranges;
    std::vector<float> xs;
    unsigned count;
    dpc_sub_job job;
};

Job make_job(std::mt19937 &rng, unsigned k, unsigned bins, unsigned n_cand, unsigned n_ranges, unsigned count) {
    Job j;
    j.k = k;
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const unsigned padded = n_cand + 64;
    j.cols.assign(k, std::vector<float>(padded));
    for (auto &c : j.cols)
        for (unsigned i = 0; i < padded; i++) c[i] = u(rng);
    j.w.resize(bins);
    j.dw.resize(bins + 8);
    for (unsigned b = 0; b < bins; b++) j.w[b] = 0.2f * (u(rng) - 0.5f);
    for (unsigned b = 0; b + 1 < bins; b++) j.dw[b] = j.w[b + 1] - j.w[b];
    j.dw[bins - 1] = 0.0f;
    // n_ranges disjoint ascending ranges covering parts of [0, n_cand)
    std::vector<uint32_t> cuts;
    for (unsigned r = 0; r < 2 * n_ranges; r++) cuts.push_back(std::uniform_int_distribution<uint32_t>(0, n_cand)(rng));
    std::sort(cuts.begin(), cuts.end());
    for (unsigned r = 0; r < n_ranges; r++)
        if (cuts[2 * r + 1] > cuts[2 * r]) j.ranges.insert(j.ranges.end(), {cuts[2 * r], cuts[2 * r + 1]});
    if (j.ranges.empty()) j.ranges = {0, n_cand};
    j.count = count;
    for (unsigned p = 0; p < count * k; p++) j.xs.push_back(u(rng));
    std::memset(&j.job, 0, sizeof j.job);
    j.job.k = k;
    for (unsigned q = 0; q < k; q++) j.job.coord[q] = j.cols[q].data();
    j.job.radius = 0.15f + 0.3f * u(rng);
    j.job.cutoff = 1e-4f * j.job.radius;
    j.job.scale = (float)(bins - 1) / j.job.radius;
    j.job.umax = (float)(bins - 1);
    j.job.qmax = (int32_t)bins - 2;
    j.job.w = j.w.data();
    j.job.dw = j.dw.data();
    return j;
}

std::vector<float> run(dpc_block_fn fn, Job &j, int local = 0) {
    std::vector<float> acc(j.count * j.k, -7.0f);
    std::vector<float> scratch(4 * DPC_GATHER_STRIDE);
    fn(&j.job, j.xs.data(), j.count, j.ranges.data(), (unsigned)j.ranges.size() / 2, local, acc.data(),
       j.k <= 4 ? scratch.data() : nullptr);
    return acc;
}

// The formula in float64, for the same candidates; mag gets the sum of the terms' magnitudes
// (the scale of float32 summation error).
std::vector<double> reference(const Job &j, std::vector<double> &mag) {
    std::vector<double> out(j.count * j.k, 0.0);
    mag.assign(j.count * j.k, 0.0);
    const double r = j.job.radius, e = j.job.cutoff;
    const unsigned bins = (unsigned)j.job.qmax + 2;
    for (unsigned p = 0; p < j.count; p++)
        for (size_t rg = 0; rg < j.ranges.size(); rg += 2)
            for (uint32_t c = j.ranges[rg]; c < j.ranges[rg + 1]; c++) {
                double t[8], d2 = 0;
                for (unsigned q = 0; q < j.k; q++) {
                    double v = (double)j.cols[q][c] - j.xs[p * j.k + q];
                    v -= std::nearbyint(v);
                    t[q] = v;
                    d2 += v * v;
                }
                const double d = std::sqrt(d2);
                if (!(d > e && d < r)) continue;
                double uu = std::min(d * (bins - 1) / r, (double)(bins - 1));
                unsigned b = std::min((unsigned)uu, bins - 2);
                double g = j.w[b] + (uu - b) * (j.w[b + 1] - j.w[b]);
                for (unsigned q = 0; q < j.k; q++) {
                    out[p * j.k + q] += g * t[q] / d;
                    mag[p * j.k + q] += std::fabs(g * t[q] / d);
                }
            }
    return out;
}

// Every block kernel this machine runs but the scalar path's.
std::vector<std::pair<const char *, dpc_block_fn>> block_paths() {
    std::vector<std::pair<const char *, dpc_block_fn>> paths = {{"packed16", dpc_block_packed16}};
#if defined(DPC_HAVE_AVX2)
    if (has_avx2()) paths.push_back({"scalar with fma", dpc_block_scalar_fma});
    if (has_avx2()) paths.push_back({"avx2", dpc_block_avx2});
    if (has_avx512()) paths.push_back({"avx512", dpc_block_avx512});
#endif
    return paths;
}

} // namespace

TEST(Kernels, EveryArrangementGivesTheScalarBits) {
    std::mt19937 rng(12345);
    const auto paths = block_paths();
    int cases = 0;
    for (unsigned k : {1u, 2u, 3u, 4u, 5u, 6u})
        for (unsigned bins : {4u, 32u, 33u, 200u})
            for (unsigned n_ranges : {1u, 3u, 9u})
                for (unsigned count : {1u, 2u, 3u, 7u}) {
                    if (k > 4 && n_ranges > 1) continue; // large subspaces run all pairs: one range
                    const unsigned n_cand = n_ranges > 1 && count == 7 ? 9000 : 700; // 9000: > DPC_GATHER_CAP
                    Job j = make_job(rng, k, bins, n_cand, n_ranges, count);
                    const std::vector<float> want = run(dpc_block_scalar, j);
                    for (auto &p : paths) {
                        const std::vector<float> got = run(p.second, j);
                        ASSERT_EQ(std::memcmp(got.data(), want.data(), want.size() * sizeof(float)), 0)
                            << p.first << ": k " << k << ", bins " << bins << ", ranges " << n_ranges << ", count "
                            << count;
                    }
                    cases++;
                }
    EXPECT_GT(cases, 200);
}

// A local block (every candidate within 1/2 of every query on every axis, as a grid cell away
// from the domain's edges) skips the minimum image: the bits of the full computation, on every
// path. The points lie in [0.2, 0.7) on each axis, so differences go up to the promise's 1/2;
// the radius reaches most of them, so most terms count.
TEST(Kernels, LocalBlocksGiveTheBitsOfTheMinimumImage) {
    std::mt19937 rng(2024);
    auto paths = block_paths();
    paths.insert(paths.begin(), {"scalar", dpc_block_scalar}); // local: the scalar path's own variant too
    std::uniform_real_distribution<float> u(0.2f, 0.7f);
    int cases = 0;
    for (unsigned k : {1u, 2u, 3u, 4u})
        for (unsigned bins : {4u, 32u, 200u})
            for (unsigned n_ranges : {1u, 5u})
                for (unsigned count : {1u, 2u, 5u}) {
                    Job j = make_job(rng, k, bins, 600, n_ranges, count);
                    for (auto &c : j.cols)
                        for (float &v : c) v = u(rng);
                    for (float &v : j.xs) v = u(rng);
                    if (cases % 5 == 0) j.cols[0][j.ranges[0]] = 0.7f, j.xs[0] = 0.2f; // a difference of exactly 1/2
                    j.job.radius = 0.5f;
                    j.job.scale = (float)(bins - 1) / j.job.radius;
                    const std::vector<float> want = run(dpc_block_scalar, j);
                    for (auto &p : paths) {
                        const std::vector<float> got = run(p.second, j, 1);
                        ASSERT_EQ(std::memcmp(got.data(), want.data(), want.size() * sizeof(float)), 0)
                            << p.first << ": k " << k << ", bins " << bins << ", ranges " << n_ranges << ", count "
                            << count;
                    }
                    cases++;
                }
    EXPECT_EQ(cases, 72);
}

TEST(Kernels, ListKernelsGiveTheBitsOfAllPairs) {
    std::mt19937 rng(99);
    std::vector<std::pair<const char *, dpc_list_fn>> paths = {{"scalar", dpc_list_scalar},
                                                               {"packed16", dpc_list_packed16}};
#if defined(DPC_HAVE_AVX2)
    if (has_avx2()) paths.push_back({"scalar with fma", dpc_list_scalar_fma});
    if (has_avx2()) paths.push_back({"avx2", dpc_list_avx2});
    if (has_avx512()) paths.push_back({"avx512", dpc_list_avx512});
#endif
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    int cases = 0, in_window = 0;
    for (unsigned k : {1u, 3u, 5u, 8u, 10u, 16u, 17u, 33u, 64u})
        for (unsigned bins : {4u, 32u, 200u})
            for (unsigned extra : {0u, 3u, 10u}) { // other candidates per 10 points: 0, 30%, all
                const unsigned n_cand = 400;
                Job j = make_job(rng, k, bins, n_cand, 1, 1);
                j.ranges = {0, n_cand}; // all pairs
                // a radius that holds about 20 points, so the window is never empty
                std::vector<double> dist(n_cand);
                for (unsigned c = 0; c < n_cand; c++) {
                    double d2 = 0.0;
                    for (unsigned q = 0; q < k; q++) {
                        double v = (double)j.cols[q][c] - j.xs[q];
                        v -= std::nearbyint(v);
                        d2 += v * v;
                    }
                    dist[c] = std::sqrt(d2);
                }
                std::vector<double> sorted = dist;
                std::sort(sorted.begin(), sorted.end());
                j.job.radius = (float)sorted[20];
                j.job.cutoff = 1e-4f * j.job.radius;
                j.job.scale = (float)(bins - 1) / j.job.radius;
                if (cases % 7 == 0) j.cols[0][5] = j.xs[0] + 0.0f; // a candidate at the query's own coordinate
                const std::vector<float> want = run(dpc_block_scalar, j);
                // rows, and a candidate list: every point within 1.001 r, plus `extra` in 10 of the others
                const unsigned stride = (k + 15) / 16 * 16;
                std::vector<float> rows((size_t)n_cand * stride, 0.0f);
                for (unsigned c = 0; c < n_cand; c++)
                    for (unsigned q = 0; q < k; q++) rows[(size_t)c * stride + q] = j.cols[q][c];
                j.job.row = rows.data();
                j.job.row_stride = stride;
                std::vector<uint32_t> cand;
                for (unsigned c = 0; c < n_cand; c++)
                    if (dist[c] < 1.001 * j.job.radius || std::uniform_int_distribution<unsigned>(0, 9)(rng) < extra)
                        cand.push_back(c);
                in_window += (int)std::count_if(dist.begin(), dist.end(), [&](double d) { return d < j.job.radius; });
                for (auto &p : paths) {
                    std::vector<float> got(k, -7.0f);
                    p.second(&j.job, j.xs.data(), cand.data(), (unsigned)cand.size(), got.data());
                    ASSERT_EQ(std::memcmp(got.data(), want.data(), k * sizeof(float)), 0)
                        << p.first << ": k " << k << ", bins " << bins << ", candidates " << cand.size();
                }
                cases++;
            }
    EXPECT_EQ(cases, 81);
    EXPECT_GT(in_window, 81 * 15);
    // no candidates: zero sums
    Job j = make_job(rng, 10, 32, 16, 1, 1);
    std::vector<float> rows(16 * 16, 0.0f), got(10, -7.0f);
    j.job.row = rows.data();
    j.job.row_stride = 16;
    for (auto &p : paths) {
        p.second(&j.job, j.xs.data(), nullptr, 0, got.data());
        for (float v : got) EXPECT_EQ(v, 0.0f) << p.first;
    }
}

TEST(Kernels, SumsMatchTheFormulaInDoublePrecision) {
    std::mt19937 rng(7);
    double worst = 0.0;
    for (unsigned k : {1u, 2u, 3u, 5u})
        for (unsigned trial = 0; trial < 6; trial++) {
            Job j = make_job(rng, k, 32, 900, k <= 4 ? 4 : 1, 5);
            const std::vector<float> got = run(dpc_block_scalar, j);
            std::vector<double> mag;
            const std::vector<double> want = reference(j, mag);
            for (size_t i = 0; i < got.size(); i++) {
                worst = std::max(worst, std::fabs(got[i] - want[i]) / std::max(mag[i], 1e-12));
            }
        }
    std::printf("[ info ] largest difference from float64, relative to the sum of |terms|: %.3g\n", worst);
    // float32 rounding (u = d * scale carries ~1e-7 of bins - 1, and the table slopes amplify it)
    // stays below 1e-4 of the terms' magnitude; one wrong or missing term would be about 1e-2
    EXPECT_LT(worst, 1e-4);
}
