// The neighbour prefilter of large all-pairs subspaces (libdpc/src/cpu/cpu_near*.c and its use
// in cpu_cascade.c, with the lists kept across layers, cpu_lists.c), below the public API: its
// ranges are aligned blocks that hold every point within the radius, its point lists hold every
// such point, the scalar and AVX2 filters agree,
// and a cascade run through it gives bit for bit the points of the all-pairs scan (every ISA,
// one and two threads, point counts that are not multiples of 8).
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

extern "C" {
#include "cpu/cpu_cascade.h"
#include "cpu/cpu_near.h"
#include "model/model.h"
}

namespace {

bool has_avx2() { return dpc_cpu_isa_available(DPC_ISA_AVX2) != 0; }

struct Codes {
    std::vector<std::vector<uint8_t>> cols;
    dpc_near_job job;
};

// Codes as cpu_cascade.c's fill_codes makes them.
Codes make_codes(const std::vector<float> &x, unsigned k, uint32_t m, float r) {
    Codes c;
    const unsigned pairs = (k + 1) / 2;
    c.cols.assign(pairs, std::vector<uint8_t>(2 * (size_t)m + 160, 0));
    for (unsigned p = 0; p < pairs; p++)
        for (unsigned e = 0; e < 2; e++)
            if (2 * p + e < k)
                for (uint32_t j = 0; j < m; j++)
                    c.cols[p][2 * j + e] = (uint8_t)(x[(size_t)j * k + 2 * p + e] * 256.0f);
    std::memset(&c.job, 0, sizeof c.job);
    c.job.pairs = pairs;
    c.job.m = m;
    c.job.limit = dpc_near_limit(r);
    for (unsigned p = 0; p < pairs; p++) c.job.code[p] = c.cols[p].data();
    return c;
}

double torus_distance(const std::vector<float> &x, unsigned k, uint32_t i, uint32_t j) {
    double d2 = 0.0;
    for (unsigned q = 0; q < k; q++) {
        double t = (double)x[(size_t)j * k + q] - (double)x[(size_t)i * k + q];
        t -= std::nearbyint(t);
        d2 += t * t;
    }
    return std::sqrt(d2);
}

TEST(Prefilter, RangesAreAlignedBlocksHoldingEveryPointInReach) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    long checked = 0, listed = 0, total = 0;
    for (unsigned k : {5u, 6u, 7u, 10u, 13u})
        for (uint32_t m : {257u, 1000u, 4099u}) {
            std::vector<float> x((size_t)m * k);
            for (auto &v : x) v = u(rng);
            // a radius holding about 4 points on average, and the largest one (half the torus)
            const double ball = std::pow(M_PI, 0.5 * k) / std::tgamma(0.5 * k + 1.0);
            for (float r : {(float)std::min(0.5, std::pow(4.0 / (ball * m), 1.0 / k)), 0.5f}) {
                Codes c = make_codes(x, k, m, r);
                for (uint32_t i = 0; i < m; i += 7) {
                    std::vector<uint32_t> a(2 * 512), b(2 * 512);
                    const unsigned na = dpc_near_scalar(&c.job, i, a.data(), 512);
                    if (has_avx2()) {
                        const unsigned nb = dpc_near_avx2(&c.job, i, b.data(), 512);
                        ASSERT_EQ(na, nb) << "k " << k << " m " << m << " query " << i;
                        if (na <= 512) ASSERT_TRUE(std::equal(a.begin(), a.begin() + 2 * na, b.begin()));
                    }
                    // the passing points themselves, from a point on (the lists' builds and hot scans)
                    const uint32_t from = (i * 13) % m;
                    std::vector<uint32_t> pa(m), pb(m);
                    const unsigned npa = dpc_near_points_scalar(&c.job, i, from, pa.data(), m);
                    if (has_avx2()) {
                        ASSERT_EQ(dpc_near_points_avx2(&c.job, i, from, pb.data(), m), npa);
                        ASSERT_TRUE(std::equal(pa.begin(), pa.begin() + npa, pb.begin()));
                    }
                    std::vector<char> pass(m, 0);
                    for (unsigned g = 0; g < npa; g++) {
                        ASSERT_GE(pa[g], from);
                        if (g) ASSERT_LT(pa[g - 1], pa[g]);
                        pass[pa[g]] = 1;
                    }
                    for (uint32_t j = from; j < m; j++)
                        if (torus_distance(x, k, i, j) < r) ASSERT_TRUE(pass[j]) << "point " << j << " near " << i;
                    if (na > 512) continue; // r = 1/2 in 5-D: most blocks pass
                    std::vector<char> in(m, 0);
                    for (unsigned g = 0; g < na; g++) {
                        ASSERT_EQ(a[2 * g] % 8, 0u);
                        ASSERT_LT(a[2 * g], a[2 * g + 1]);
                        ASSERT_LE(a[2 * g + 1], m);
                        if (g + 1 < na) {
                            ASSERT_EQ(a[2 * g + 1] % 8, 0u);
                            ASSERT_LT(a[2 * g + 1], a[2 * g + 2]); // merged: never adjacent
                        }
                        for (uint32_t j = a[2 * g]; j < a[2 * g + 1]; j++) in[j] = 1;
                    }
                    for (uint32_t j = 0; j < m; j++) {
                        if (torus_distance(x, k, i, j) < r) {
                            ASSERT_TRUE(in[j]) << "k " << k << " m " << m << " r " << r << ": " << j << " near " << i;
                            checked++;
                        }
                        listed += in[j];
                    }
                    total += m;
                }
            }
        }
    EXPECT_GT(checked, 5000); // points in reach that were found
    EXPECT_LT(listed, total / 2);
}

TEST(Prefilter, SaysWhenTheRangesDoNotFit) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const unsigned k = 5;
    const uint32_t m = 2048;
    std::vector<float> x((size_t)m * k);
    for (auto &v : x) v = u(rng);
    Codes c = make_codes(x, k, m, 0.5f); // most blocks pass
    std::vector<uint32_t> a(2 * 4);
    EXPECT_EQ(dpc_near_scalar(&c.job, 3, a.data(), 4), 5u);
    if (has_avx2()) EXPECT_EQ(dpc_near_avx2(&c.job, 3, a.data(), 4), 5u);
}

std::vector<uint8_t> read_file(const std::string &path) {
    std::ifstream f(path, std::ios::binary);
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), {});
}

std::vector<float> filtered(const dpc_cascade &c, dpc_isa isa, unsigned threads, int prefilter,
                            const std::vector<float> &x0, size_t m) {
    dpc_cpu_engine e;
    EXPECT_EQ(dpc_cpu_engine_init(&e, isa, threads), DPC_OK);
    e.prefilter = prefilter;
    std::vector<float> x = x0;
    EXPECT_EQ(dpc_cpu_filter(&c, &e, m, x.data()), DPC_OK);
    return x;
}

TEST(Prefilter, CascadeGivesTheBitsOfAllPairs) {
    struct Case {
        std::string path;
        std::vector<size_t> counts;
    };
    const std::vector<Case> cases = {
        {DPC_TEST_MODELS_DIR "/bnot-10d.onnx", {1000, 2053}}, // 40 trained layers: lists kept and rebuilt
        {DPC_TEST_MODELS_DIR "/bnot-5d.onnx", {4099}},        // denser: lists off, filtered every layer
        {DPC_TEST_DATA_DIR "/model_10d.onnx", {8200}},        // two threads split the points
    };
    std::vector<dpc_isa> isas = {DPC_ISA_SCALAR};
    if (has_avx2()) isas.push_back(DPC_ISA_AVX2);
    if (dpc_cpu_isa_available(DPC_ISA_AVX512)) isas.push_back(DPC_ISA_AVX512);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (const Case &cs : cases) {
        const std::vector<uint8_t> bytes = read_file(cs.path);
        ASSERT_FALSE(bytes.empty()) << cs.path;
        dpc_cascade c;
        ASSERT_EQ(dpc_cascade_parse(bytes.data(), bytes.size(), &c), DPC_OK) << cs.path;
        for (size_t m : cs.counts) {
            std::vector<float> x0(m * c.dims);
            for (auto &v : x0) v = u(rng);
            const std::vector<float> want = filtered(c, has_avx2() ? DPC_ISA_AVX2 : DPC_ISA_SCALAR, 1, 0, x0, m);
            ASSERT_NE(std::memcmp(want.data(), x0.data(), want.size() * sizeof(float)), 0) << "the points moved";
            for (dpc_isa isa : isas)
                for (unsigned threads : {1u, 2u}) {
                    if (isa == DPC_ISA_SCALAR && m > 2048) continue; // the portable kernel is slow there
                    const std::vector<float> got = filtered(c, isa, threads, 1, x0, m);
                    EXPECT_EQ(std::memcmp(got.data(), want.data(), want.size() * sizeof(float)), 0)
                        << cs.path << " m " << m << " isa " << isa << " threads " << threads;
                }
        }
        dpc_cascade_release(&c);
    }
}

} // namespace
