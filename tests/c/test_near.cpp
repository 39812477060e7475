// The neighbour prefilter of large all-pairs subspaces (libdpc/src/cpu/cpu_near*.c and its use
// in cpu_cascade.c, with the lists kept across layers, cpu_lists.c), below the public API: its
// ranges are aligned blocks that hold every point within the radius, its point lists hold every
// such point, the scalar, AVX2 and (points) AVX-512 filters agree (columns and rows), the two-tier
// lists give every point its points in reach through builds, refreshes, warm moves and re-anchored far ones,
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
#include "cpu/cpu_lists.h"
#include "cpu/cpu_near.h"
#include "model/model.h"
}

namespace {

bool has_avx2() { return dpc_cpu_isa_available(DPC_ISA_AVX2) != 0; }
#if defined(DPC_HAVE_AVX2)
bool has_avx512bw() { return dpc_cpu_isa_available(DPC_ISA_AVX512) && __builtin_cpu_supports("avx512bw"); }
#endif

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
#if defined(DPC_HAVE_AVX2)
                    if (has_avx512bw()) {
                        ASSERT_EQ(dpc_near_points_avx512(&c.job, i, from, pb.data(), m), npa) << "avx512";
                        ASSERT_TRUE(std::equal(pa.begin(), pa.begin() + npa, pb.begin()));
                    }
#endif
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

TEST(Prefilter, RowFilterIsTheColumnFilter) {
    std::mt19937 rng(8);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (unsigned k : {5u, 10u, 16u, 17u, 33u}) {
        const uint32_t m = 600;
        std::vector<float> x((size_t)m * k);
        for (auto &v : x) v = u(rng);
        const double ball = std::pow(M_PI, 0.5 * k) / std::tgamma(0.5 * k + 1.0);
        const float r = (float)std::min(0.9, std::pow(20.0 / (ball * m), 1.0 / k));
        Codes c = make_codes(x, k, m, r);
        const unsigned row_bytes = (k + 15) / 16 * 16;
        std::vector<uint8_t> rows((size_t)m * row_bytes, 0);
        for (uint32_t j = 0; j < m; j++)
            for (unsigned q = 0; q < k; q++) rows[(size_t)j * row_bytes + q] = c.cols[q / 2][2 * j + q % 2];
        std::vector<uint32_t> all(m);
        for (uint32_t j = 0; j < m; j++) all[j] = j;
        long passed = 0;
        for (uint32_t i = 0; i < m; i += 5) {
            std::vector<uint32_t> want(m), got(m);
            const unsigned n = dpc_near_points_scalar(&c.job, i, 0, want.data(), m);
            const unsigned ns = dpc_near_list_scalar(rows.data(), row_bytes, i, all.data(), m, c.job.limit, got.data());
            ASSERT_EQ(ns, n) << "k " << k << " query " << i;
            ASSERT_TRUE(std::equal(want.begin(), want.begin() + n, got.begin()));
#if defined(DPC_HAVE_AVX2)
            if (has_avx2()) {
                for (unsigned len : {m, m - 1, 1u}) { // odd and even counts
                    std::vector<uint32_t> g2(m);
                    const unsigned na =
                        dpc_near_list_avx2(rows.data(), row_bytes, i, all.data(), len, c.job.limit, g2.data());
                    const unsigned nw =
                        (unsigned)std::count_if(want.begin(), want.begin() + n, [&](uint32_t j) { return j < len; });
                    ASSERT_EQ(na, nw) << "k " << k << " query " << i << " count " << len;
                    ASSERT_TRUE(std::equal(want.begin(), want.begin() + nw, g2.begin()));
                }
            }
#endif
            passed += n;
        }
        if (k <= 17) EXPECT_GT(passed, 120 * 5) << "k " << k; // about 20 in reach per query (33-D: r capped)
    }
}

// A subspace for the lists: m points in k dimensions, as columns and rows (the kernels') and codes.
struct Moving {
    unsigned k;
    uint32_t m;
    float r;
    std::vector<float> x; // m x k
    std::vector<std::vector<float>> cols;
    std::vector<float> rows; // the list kernel's rows (dpc_sub_job.row), which the lists also read
    Codes codes;
    dpc_sub_job job;
    void sync() {
        const unsigned stride = (k + 15) / 16 * 16;
        cols.assign(k, std::vector<float>(m + 16, 0.0f));
        rows.assign((size_t)m * stride, 0.0f);
        for (uint32_t j = 0; j < m; j++)
            for (unsigned q = 0; q < k; q++) cols[q][j] = rows[(size_t)j * stride + q] = x[(size_t)j * k + q];
        codes = make_codes(x, k, m, r);
        std::memset(&job, 0, sizeof job);
        job.k = k;
        job.radius = r;
        for (unsigned q = 0; q < k; q++) job.coord[q] = cols[q].data();
        job.row = rows.data();
        job.row_stride = stride;
    }
    // move `share` of the points (every point when 1) by `dist` in a random direction
    void move(std::mt19937 &rng, double share, double dist) {
        std::normal_distribution<double> g(0.0, 1.0);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        for (uint32_t j = 0; j < m; j++) {
            if (u(rng) >= share) continue;
            std::vector<double> v(k);
            double len = 0.0;
            for (auto &c : v) c = g(rng), len += c * c;
            len = std::sqrt(len);
            for (unsigned q = 0; q < k; q++) {
                double y = x[(size_t)j * k + q] + dist * v[q] / len;
                y -= std::floor(y);
                x[(size_t)j * k + q] = y < 1.0 ? (float)y : 0.0f;
            }
        }
        sync();
    }
};

TEST(Lists, EveryPointKeepsItsPointsInReachThroughEveryKindOfMove) {
    struct Fns {
        const char *name;
        dpc_near_points_fn points;
        dpc_near_list_fn list;
    };
    std::vector<Fns> fns = {{"scalar", dpc_near_points_scalar, dpc_near_list_scalar}};
#if defined(DPC_HAVE_AVX2)
    if (has_avx2()) fns.push_back({"avx2", dpc_near_points_avx2, dpc_near_list_avx2});
    if (has_avx512bw()) fns.push_back({"avx512", dpc_near_points_avx512, dpc_near_list_avx2});
#endif
    for (const Fns &f : fns)
        for (unsigned threads : {1u, 2u}) {
            std::mt19937 rng(21);
            std::uniform_real_distribution<float> u(0.0f, 1.0f);
            Moving mv;
            mv.k = 10;
            mv.m = 3001;
            mv.r = 0.45f; // about 3 points in reach
            mv.x.resize((size_t)mv.m * mv.k);
            for (auto &v : mv.x) v = u(rng);
            mv.sync();
            dpc_lists L;
            dpc_lists_init(&L, mv.m);
            // each step: a move (share of points, distance in r), and which path the lists take
            struct Step {
                double share, dist;
                int build, refresh, hot, reanchor;
            };
            const double r = mv.r;
            const std::vector<Step> steps = {
                {0.0, 0.0, 1, 1, 0, 0},       // the first pass builds (and fills the near lists)
                {1.0, 0.01 * r, 0, 0, 0, 0},  // every point barely moves: nothing to do
                {0.04, 0.08 * r, 0, 0, 1, 0}, // a few warm points: their wide lists
                {0.3, 0.08 * r, 0, 1, 0, 1},  // many warm points: the near lists are refreshed (the few
                                              // moved in both steps are far: re-anchored first)
                {0.02, 0.4 * r, 0, 0, 1, 1},  // a few far points: re-anchored, then warm
                {0.03, 0.08 * r, 0, 0, 1, 1}, // warm points, and far ones again (moved in earlier steps too)
                {0.5, 0.4 * r, 1, 1, 0, 0},   // many far points: a build
            };
            long in_reach = 0;
            for (size_t st = 0; st < steps.size(); st++) {
                const Step &s = steps[st];
                if (s.share > 0.0) mv.move(rng, s.share, s.dist);
                const size_t b0 = L.builds, r0 = L.refreshes, h0 = L.hot_passes, a0 = L.reanchors;
                ASSERT_EQ(dpc_lists_update(&L, 0x3FF, &mv.job, &mv.codes.job, f.points, f.list, threads), 1);
                EXPECT_EQ((int)(L.builds - b0), s.build) << f.name << " step " << st;
                EXPECT_EQ((int)(L.refreshes - r0), s.refresh) << f.name << " step " << st;
                EXPECT_EQ((int)(L.hot_passes - h0), s.hot) << f.name << " step " << st;
                EXPECT_EQ((int)(L.reanchors - a0), s.reanchor) << f.name << " step " << st;
                std::vector<uint32_t> cand(mv.m);
                for (uint32_t i = 0; i < mv.m; i++) {
                    unsigned n = 0;
                    const uint32_t *got = dpc_lists_candidates(&L, i, cand.data(), mv.m, &n);
                    ASSERT_NE(got, nullptr);
                    std::copy(got, got + n, cand.begin());
                    std::vector<char> in(mv.m, 0);
                    for (unsigned c = 0; c < n; c++) {
                        ASSERT_NE(cand[c], i);
                        if (c) ASSERT_LT(cand[c - 1], cand[c]) << "ascending, no repeats";
                        in[cand[c]] = 1;
                    }
                    for (uint32_t j = 0; j < mv.m; j++)
                        if (j != i && torus_distance(mv.x, mv.k, i, j) < r * (1.0 + 1e-5)) {
                            ASSERT_TRUE(in[j])
                                << f.name << " threads " << threads << " step " << st << ": " << j << " near " << i;
                            in_reach++;
                        }
                }
            }
            EXPECT_GT(in_reach, 7 * 3001); // about 3 per point and step
            dpc_lists_free(&L);
        }
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
