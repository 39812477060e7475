// The input points (docs/model-format.md §5): the stratified generator against an independent
// transcription of the documented algorithm, its properties, and DPC_INPUT_STRATIFIED at load
// time (generate = filter of the stratified points; gridded models refuse it; older structs).
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <thread>

#include "test_util.h"

using namespace dpct;

namespace {

// docs/model-format.md §5, "Stratified input", written from the text with ordinary vectors.
std::vector<float> stratified_reference(uint64_t seed, size_t m, size_t n) {
    uint64_t g = 1;
    auto fits = [&](uint64_t b) {
        long double p = 1;
        for (size_t a = 0; a < n; a++) p *= (long double)b;
        return p <= (long double)m;
    };
    while (fits(g + 1)) g++;
    uint64_t cells = 1;
    for (size_t a = 0; a < n; a++) cells *= g;
    const uint64_t state1 = mix64(seed ^ 0x5354524154494649ull);
    uint64_t k = 0;
    auto below = [&](uint64_t bound) {
        k++;
        uint64_t z = mix64(state1 + k * 0x9E3779B97F4A7C15ull);
        return (uint64_t)(((z >> 32) * bound) >> 32);
    };
    std::vector<uint64_t> cell;
    for (uint64_t b = 0; b < m / cells; b++)
        for (uint64_t c = 0; c < cells; c++) cell.push_back(c);
    std::vector<uint64_t> perm(cells);
    for (uint64_t c = 0; c < cells; c++) perm[c] = c;
    for (uint64_t t = 0; t < m % cells; t++) {
        std::swap(perm[t], perm[t + below(cells - t)]);
        cell.push_back(perm[t]);
    }
    for (size_t i = m - 1; i > 0; i--) std::swap(cell[i], cell[below(i + 1)]);
    std::vector<float> x(m * n);
    for (size_t i = 0; i < m; i++) {
        uint64_t c = cell[i];
        for (size_t a = 0; a < n; a++) {
            double v = ((double)(c % g) + (double)uniform_value(seed, i * n + a)) / (double)g;
            c /= g;
            float f = (float)v;
            x[i * n + a] = f < 1.0f ? f : std::nextafter(1.0f, 0.0f);
        }
    }
    return x;
}

std::vector<float> stratified(uint64_t seed, size_t m, size_t n) {
    std::vector<float> x(m * n, -1.0f);
    EXPECT_EQ(dpc_stratified(seed, m, n, x.data()), DPC_OK) << dpc_last_error();
    return x;
}

ModelPtr load_input(const std::string &path, dpc_input input, uint32_t threads = 1) {
    dpc_load_options o;
    dpc_load_options_init(&o);
    o.input = input;
    o.threads = threads;
    o.backend = DPC_BACKEND_CPU;
    dpc_model *m = nullptr;
    EXPECT_EQ(dpc_model_load_file(path.c_str(), &o, &m), DPC_OK) << dpc_last_error();
    return ModelPtr(m);
}

struct Shape {
    size_t m, n;
};
// Powers of g (one point per cell), leftover cells (1000 = 31^2 + 39, 3000 = 14^3 + 256), several
// points per cell (8192 in 10-D: 2^10 cells of 8), 1-D, one point, and no grid at all (g = 1).
const Shape kShapes[] = {{1024, 2}, {1000, 2}, {3000, 3}, {4096, 3},  {8192, 10}, {1024, 10},
                         {7, 1},    {1, 2},    {5, 64},   {65536, 2}, {777, 4}};

} // namespace

TEST(Stratified, MatchesTheDocumentedGenerator) {
    for (const Shape &s : kShapes)
        for (uint64_t seed : {0ull, 1ull, 0xFFFFFFFFFFFFFFFFull})
            EXPECT_EQ(stratified(seed, s.m, s.n), stratified_reference(seed, s.m, s.n))
                << s.m << " x " << s.n << ", seed " << seed;
}

TEST(Stratified, EveryCellGetsItsShareAndTheOrderIsRandom) {
    for (const Shape &s : kShapes) {
        size_t g = 1;
        while (std::pow((double)(g + 1), (double)s.n) <= (double)s.m + 0.5) g++;
        size_t cells = 1;
        for (size_t a = 0; a < s.n; a++) cells *= g;
        std::vector<float> x = stratified(11, s.m, s.n);
        std::vector<size_t> count(cells, 0);
        for (size_t i = 0; i < s.m; i++) {
            size_t c = 0, scale = 1;
            for (size_t a = 0; a < s.n; a++) {
                const float v = x[i * s.n + a];
                ASSERT_TRUE(v >= 0.0f && v < 1.0f) << v;
                c += std::min((size_t)(v * (float)g), g - 1) * scale;
                scale *= g;
            }
            count[c]++;
        }
        const size_t base = s.m / cells;
        for (size_t c = 0; c < cells; c++)
            ASSERT_TRUE(count[c] == base || count[c] == base + 1) << s.m << " x " << s.n << ", cell " << c;
        if (g > 1 && s.m >= 64) { // the first quarter of the points is spread over the domain, not a corner
            double mean = 0;
            for (size_t i = 0; i < s.m / 4; i++) mean += x[i * s.n + s.n - 1];
            mean /= (double)(s.m / 4);
            EXPECT_NEAR(mean, 0.5, 0.1) << s.m << " x " << s.n;
        }
    }
}

TEST(Stratified, IsTheUniformInputWhereNoGridFits) {
    // m < 2^n: g = 1, one cell holds everything, and the points are the uniform ones.
    std::vector<float> u(5 * 64);
    ASSERT_EQ(dpc_uniform(3, 5, 64, u.data()), DPC_OK);
    EXPECT_EQ(stratified(3, 5, 64), u);
}

TEST(Stratified, BadArgumentsAreStatuses) {
    float buf[4];
    EXPECT_EQ(dpc_stratified(0, 2, 2, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_stratified(0, 0, 2, buf), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_stratified(0, 2, 0, buf), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_stratified(0, (size_t)DPC_MAX_POINTS + 1, 1, buf), DPC_ERROR_LIMIT);
    EXPECT_GT(std::strlen(dpc_last_error()), 0u);
}

TEST(StratifiedInput, GenerateFiltersTheStratifiedPoints) {
    ModelPtr m = load_input(model_path("model_2d"), DPC_INPUT_STRATIFIED);
    ASSERT_TRUE(m);
    for (size_t n : {1024u, 1500u}) {
        std::vector<float> x = stratified(42, n, 2);
        ASSERT_EQ(dpc_filter(m.get(), n, x.data()), DPC_OK) << dpc_last_error();
        EXPECT_EQ(generate(m.get(), 42, n), x) << n;
    }
    std::vector<float> batch(3 * 1024 * 2);
    ASSERT_EQ(dpc_generate_batch(m.get(), 7, 3, 0, batch.data()), DPC_OK) << dpc_last_error();
    for (size_t c = 0; c < 3; c++)
        EXPECT_TRUE(
            std::equal(batch.begin() + c * 2048, batch.begin() + (c + 1) * 2048, generate(m.get(), 7 + c).begin()))
            << "set " << c;
    ModelPtr uni = load_input(model_path("model_2d"), DPC_INPUT_UNIFORM);
    EXPECT_NE(generate(uni.get(), 42), generate(m.get(), 42)) << "the option changes the input";
}

TEST(StratifiedInput, ThreadCountDoesNotChangeBits) {
    ModelPtr one = load_input(model_path("model_3d_proj"), DPC_INPUT_STRATIFIED, 1);
    ModelPtr three = load_input(model_path("model_3d_proj"), DPC_INPUT_STRATIFIED, 3);
    ASSERT_TRUE(one && three);
    EXPECT_EQ(generate(one.get(), 5, 12345), generate(three.get(), 5, 12345));
}

TEST(StratifiedInput, GriddedModelsRefuseIt) {
    dpc_load_options o;
    dpc_load_options_init(&o);
    o.input = DPC_INPUT_STRATIFIED;
    dpc_model *m = reinterpret_cast<dpc_model *>(0x1);
    EXPECT_EQ(dpc_model_load_file(model_path("model_grid_3to1").c_str(), &o, &m), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(m, nullptr);
    EXPECT_NE(std::string(dpc_last_error()).find("grid"), std::string::npos) << dpc_last_error();
}

TEST(StratifiedInput, UnknownInputIsRejected) {
    dpc_load_options o;
    dpc_load_options_init(&o);
    o.input = (dpc_input)9;
    dpc_model *m = reinterpret_cast<dpc_model *>(0x1);
    EXPECT_EQ(dpc_model_load_file(model_path("model_2d").c_str(), &o, &m), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(m, nullptr);
    EXPECT_NE(std::string(dpc_last_error()).find("input"), std::string::npos) << dpc_last_error();
}

dpc_input input_of(const dpc_model *m) {
    dpc_input k = DPC_INPUT_AUTO;
    EXPECT_EQ(dpc_model_get_input(m, &k), DPC_OK) << dpc_last_error();
    return k;
}

TEST(StratifiedInput, AutoTakesTheModelsMetadataAndIsReported) {
    // The test models carry no "dpc.input": AUTO is uniform, and the query never says AUTO.
    ModelPtr a = load_input(model_path("model_2d"), DPC_INPUT_AUTO);
    ModelPtr u = load_input(model_path("model_2d"), DPC_INPUT_UNIFORM);
    ModelPtr s = load_input(model_path("model_2d"), DPC_INPUT_STRATIFIED);
    ASSERT_TRUE(a && u && s);
    EXPECT_EQ(input_of(a.get()), DPC_INPUT_UNIFORM);
    EXPECT_EQ(input_of(u.get()), DPC_INPUT_UNIFORM);
    EXPECT_EQ(input_of(s.get()), DPC_INPUT_STRATIFIED);
    EXPECT_EQ(generate(a.get(), 4), generate(u.get(), 4));
    dpc_input k;
    EXPECT_EQ(dpc_model_get_input(nullptr, &k), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_model_get_input(a.get(), nullptr), DPC_ERROR_INVALID_ARGUMENT);
}

TEST(StratifiedInput, StructWithoutInputFieldLoadsAsAuto) {
    // A caller compiled before `input` existed passes the smaller size; the bytes where `input`
    // now lives are not read (here they hold garbage).
    dpc_load_options o;
    dpc_load_options_init(&o);
    o.struct_size = (uint32_t)offsetof(dpc_load_options, input);
    o.backend = DPC_BACKEND_CPU;
    o.input = (dpc_input)77;
    dpc_model *raw = nullptr;
    ASSERT_EQ(dpc_model_load_file(model_path("model_2d").c_str(), &o, &raw), DPC_OK) << dpc_last_error();
    ModelPtr m(raw);
    EXPECT_EQ(input_of(m.get()), DPC_INPUT_UNIFORM);
    ModelPtr uni = load_input(model_path("model_2d"), DPC_INPUT_UNIFORM);
    EXPECT_EQ(generate(m.get(), 3), generate(uni.get(), 3));
}
