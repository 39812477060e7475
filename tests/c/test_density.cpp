// Blue noise that follows a density (dpc_generate_density): where points go, zero-density cells,
// the same bits on every ISA path and thread count, and bad requests refused before any work.
#include "test_util.h"

#include <cstring>
#include <limits>
#include <thread>

using namespace dpct;

namespace {

std::vector<float> density_points(const dpc_model *m, const std::vector<float> &d, uint32_t w, uint32_t h,
                                  uint64_t seed, size_t n) {
    std::vector<float> out(n * 2, -1.0f);
    dpc_status st = dpc_generate_density(m, d.data(), w, h, seed, n, out.data());
    EXPECT_EQ(st, DPC_OK) << dpc_last_error();
    return out;
}

// Points per cell of a w x h grid over [0,1)^2 (row-major, row = second coordinate).
std::vector<size_t> counts(const std::vector<float> &p, uint32_t w, uint32_t h) {
    std::vector<size_t> c((size_t)w * h, 0);
    for (size_t i = 0; i < p.size() / 2; i++) {
        const uint32_t cx = (uint32_t)((double)p[2 * i] * w), cy = (uint32_t)((double)p[2 * i + 1] * h);
        c[(size_t)cy * w + cx]++;
    }
    return c;
}

dpc_status request(const dpc_model *m, const float *d, uint32_t w, uint32_t h, size_t n = 256) {
    std::vector<float> out(n * 2);
    return dpc_generate_density(m, d, w, h, 1, n, out.data());
}

} // namespace

TEST(Density, PointsFollowTheDensityAndAvoidZeroCells) {
    ModelPtr m = load(model_path("model_2d"));
    // row 0 (y < 1/2): 1, 3; row 1: 0, 4
    const std::vector<float> d = {1.0f, 3.0f, 0.0f, 4.0f};
    const size_t n = 4000;
    std::vector<float> p = density_points(m.get(), d, 2, 2, 7, n);
    for (float v : p) {
        ASSERT_GE(v, 0.0f);
        ASSERT_LT(v, 1.0f);
    }
    std::vector<size_t> c = counts(p, 2, 2);
    EXPECT_EQ(c[2], 0u) << "a point in the zero-density cell";
    const double expected[4] = {500.0, 1500.0, 0.0, 2000.0};
    for (int k : {0, 1, 3}) EXPECT_NEAR((double)c[k], expected[k], 0.05 * expected[k]) << "cell " << k;
}

TEST(Density, ZeroRegionsOfAFineGridStayEmpty) {
    ModelPtr m = load(model_path("model_2d"));
    const uint32_t w = 37, h = 23; // a checkerboard of 3 x 3-cell blocks with zeros
    std::vector<float> d((size_t)w * h);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) d[(size_t)y * w + x] = ((x / 3 + y / 3) % 2) ? 0.0f : 1.0f + (float)(x % 5);
    std::vector<float> p = density_points(m.get(), d, w, h, 3, 3000);
    std::vector<size_t> c = counts(p, w, h);
    for (size_t k = 0; k < c.size(); k++)
        if (d[k] == 0.0f) {
            ASSERT_EQ(c[k], 0u) << "cell " << k % w << ", " << k / w;
        }
}

TEST(Density, SameBitsOnEveryIsaThreadCountAndRun) {
    // a few walls (scanned whole) and many (a checkerboard with zero blocks and 1 : 9 steps:
    // buckets and the distance field), each point near one adding its mirror images
    std::vector<float> many((size_t)40 * 24);
    for (uint32_t y = 0; y < 24; y++)
        for (uint32_t x = 0; x < 40; x++)
            many[(size_t)y * 40 + x] = ((x / 4 + y / 3) % 3 == 0) ? 0.0f : ((x / 4 + y / 3) % 3 == 1) ? 1.0f : 9.0f;
    const struct {
        std::vector<float> d;
        uint32_t w, h;
    } cases[] = {{{0.2f, 1.0f, 3.0f, 0.5f, 0.0f, 2.0f}, 3, 2}, {many, 40, 24}};
    const size_t n = 5000; // above the engine's parallel threshold, so threads split the work
    for (const auto &c : cases) {
        ModelPtr ref_model = load(model_path("model_2d"), DPC_ISA_SCALAR, 1);
        const std::vector<float> ref = density_points(ref_model.get(), c.d, c.w, c.h, 11, n);
        EXPECT_EQ(ref, density_points(ref_model.get(), c.d, c.w, c.h, 11, n)) << "run to run";
        EXPECT_NE(ref, density_points(ref_model.get(), c.d, c.w, c.h, 12, n)) << "another seed";
        for (dpc_isa isa : {DPC_ISA_SCALAR, DPC_ISA_AVX2, DPC_ISA_AVX512}) {
            if (!dpc_isa_supported(isa)) continue;
            for (uint32_t threads : {1u, 2u, 3u}) {
                ModelPtr m = load(model_path("model_2d"), isa, threads);
                EXPECT_EQ(ref, density_points(m.get(), c.d, c.w, c.h, 11, n))
                    << c.w << " x " << c.h << ", isa " << isa << ", threads " << threads;
            }
        }
    }
}

TEST(Density, OneModelServesThreadsAtOnce) {
    ModelPtr m = load(model_path("model_2d"));
    const std::vector<float> d = {1.0f, 2.0f, 3.0f, 4.0f};
    const std::vector<float> ref = density_points(m.get(), d, 2, 2, 5, 1500);
    std::vector<std::vector<float>> got(4, std::vector<float>(3000));
    std::vector<dpc_status> st(4);
    std::vector<std::thread> pool;
    for (int t = 0; t < 4; t++)
        pool.emplace_back([&, t] { st[t] = dpc_generate_density(m.get(), d.data(), 2, 2, 5, 1500, got[t].data()); });
    for (auto &t : pool) t.join();
    for (int t = 0; t < 4; t++) {
        EXPECT_EQ(st[t], DPC_OK);
        EXPECT_EQ(got[t], ref);
    }
}

TEST(Density, BadDensitiesAreRefusedWithAMessage) {
    ModelPtr m = load(model_path("model_2d"));
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    const std::vector<float> ok = {1.0f, 1.0f};
    struct Case {
        std::vector<float> d;
        dpc_status want;
        const char *what;
    } cases[] = {
        {{1.0f, -1.0f}, DPC_ERROR_INVALID_ARGUMENT, "negative"},
        {{1.0f, nan}, DPC_ERROR_INVALID_ARGUMENT, "NaN"},
        {{inf, 1.0f}, DPC_ERROR_INVALID_ARGUMENT, "infinite"},
        {{0.0f, 0.0f}, DPC_ERROR_INVALID_ARGUMENT, "all zero"},
        {{-0.0f, 0.0f}, DPC_ERROR_INVALID_ARGUMENT, "all (negative) zero"},
    };
    for (const Case &c : cases) {
        EXPECT_EQ(request(m.get(), c.d.data(), 2, 1), c.want) << c.what;
        EXPECT_STRNE(dpc_last_error(), "") << c.what;
    }
    EXPECT_EQ(request(m.get(), nullptr, 2, 1), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(request(m.get(), ok.data(), 0, 1), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(request(m.get(), ok.data(), 2, 0), DPC_ERROR_INVALID_ARGUMENT);
    // Too many cells: refused before a value is read (the buffer holds two).
    EXPECT_EQ(request(m.get(), ok.data(), 1u << 13, 1u << 12), DPC_ERROR_LIMIT);
    EXPECT_EQ(request(m.get(), ok.data(), UINT32_MAX, UINT32_MAX), DPC_ERROR_LIMIT);
    std::vector<float> out(4);
    EXPECT_EQ(dpc_generate_density(nullptr, ok.data(), 2, 1, 0, 2, out.data()), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_generate_density(m.get(), ok.data(), 2, 1, 0, 2, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_generate_density(m.get(), ok.data(), 2, 1, 0, (size_t)DPC_MAX_POINTS + 1, out.data()),
              DPC_ERROR_LIMIT);
}

TEST(Density, ModelsThatCannotFollowADensityAreRefused) {
    const std::vector<float> d = {1.0f, 2.0f};
    for (const char *name :
         {"model_3d_proj", "model_3d_mixed", "model_grid_3to1", "model_10d", "model_2d_progressive"}) {
        ModelPtr m = load(model_path(name));
        EXPECT_EQ(request(m.get(), d.data(), 2, 1), DPC_ERROR_UNSUPPORTED) << name;
        EXPECT_NE(std::strstr(dpc_last_error(), "density"), nullptr) << name << ": " << dpc_last_error();
    }
}

TEST(Density, TinyAndExtremeDensitiesStayInTheSquare) {
    ModelPtr m = load(model_path("model_2d"));
    // one bright cell in a huge dark field, and a point count of 1
    std::vector<float> d(64 * 64, 1e-30f);
    d[5 * 64 + 60] = 1e30f;
    for (size_t n : {size_t(1), size_t(2), size_t(300)}) {
        std::vector<float> p = density_points(m.get(), d, 64, 64, 9, n);
        for (float v : p) {
            ASSERT_GE(v, 0.0f);
            ASSERT_LT(v, 1.0f);
        }
    }
}
