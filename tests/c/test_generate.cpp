// Generating point sets: determinism, thread independence, sharing one model between threads,
// batches, gridded dimensions, counts other than the trained one, ISA paths, equivalent files.
#include "test_util.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <set>
#include <sstream>
#include <thread>

using namespace dpct;

namespace {

// Input points of dpc_generate_n(model, seed, n): uniform, then gridded dims set to cell centres.
std::vector<float> input_points(const dpc_model_info &info, uint64_t seed, size_t n) {
    std::vector<float> x(n * info.dims);
    EXPECT_EQ(dpc_uniform(seed, n, info.dims, x.data()), DPC_OK);
    for (size_t i = 0; i < n; i++) {
        size_t rest = i;
        for (uint32_t g = 0; g < info.grid_dims; g++) {
            size_t cell = rest % info.grid_shape[g];
            rest /= info.grid_shape[g];
            x[i * info.dims + info.grid_axis[g]] = (float)((cell + 0.5) / info.grid_shape[g]);
        }
    }
    return x;
}

// A point count other than the trained 1024 (smaller in 10-D, where one subspace is the full
// space and costs O(m^2)); 0 for gridded models, which have only their grid's count.
size_t other_count(const dpc_model_info &info) {
    if (info.grid_dims) return 0;
    return info.dims >= 8 ? 600 : 1500;
}

// A count above the engine's threshold for splitting work between threads (8,192 points), and
// not a multiple of any tested thread count, so chunk boundaries cut through cells: 0 where the
// model takes only its trained count, or runs all pairs in 10-D (too slow under the sanitizers).
size_t parallel_count(const dpc_model_info &info) {
    if (info.grid_dims || info.dims >= 8) return 0;
    return 12345;
}

bool is_grid_axis(const dpc_model_info &info, uint32_t k) {
    for (uint32_t g = 0; g < info.grid_dims; g++)
        if (info.grid_axis[g] == k) return true;
    return false;
}

// Mean toroidal displacement over the non-gridded coordinates.
double mean_move(const dpc_model_info &info, const std::vector<float> &a, const std::vector<float> &b) {
    double sum = 0;
    size_t cnt = 0;
    for (size_t i = 0; i < a.size(); i++) {
        if (is_grid_axis(info, (uint32_t)(i % info.dims))) continue;
        sum += torus_diff(a[i], b[i]);
        cnt++;
    }
    return cnt ? sum / cnt : 0.0;
}

void expect_unit_cube(const std::vector<float> &x) {
    for (size_t i = 0; i < x.size(); i++) {
        ASSERT_TRUE(x[i] >= 0.0f && x[i] < 1.0f) << "coordinate " << i << " = " << x[i];
    }
}

class PerModel : public ::testing::TestWithParam<std::string> {
  protected:
    std::string path() const { return model_path(GetParam()); }
};

std::string param_name(const ::testing::TestParamInfo<std::string> &p) { return p.param; }

} // namespace

TEST_P(PerModel, SameSeedSameBits) {
    ModelPtr a = load(path()), b = load(path());
    ASSERT_TRUE(a && b);
    for (uint64_t seed : {0ull, 1ull, 123456789ull, ~0ull}) {
        std::vector<float> x = generate(a.get(), seed);
        EXPECT_EQ(x, generate(a.get(), seed)) << "seed " << seed << ": second call differs";
        EXPECT_EQ(x, generate(b.get(), seed)) << "seed " << seed << ": second handle differs";
        expect_unit_cube(x);
    }
    EXPECT_NE(generate(a.get(), 1), generate(a.get(), 2)) << "seeds 1 and 2 give the same set";
}

TEST_P(PerModel, PointsMoveNoticeably) {
    // The test models push points by a fraction of the spacing: a cascade that did nothing (or
    // almost nothing) would make the other tests meaningless.
    ModelPtr m = load(path());
    ASSERT_TRUE(m);
    dpc_model_info info = info_of(m.get());
    std::vector<float> x0 = input_points(info, 7, info.n_points);
    std::vector<float> y = generate(m.get(), 7);
    EXPECT_GT(mean_move(info, x0, y), 1e-3) << "mean displacement of the free coordinates";
}

TEST_P(PerModel, GenerateIsFilterOfTheDocumentedInput) {
    // docs/model-format.md §5: dpc_generate filters uniform(seed) with gridded dims overwritten.
    ModelPtr m = load(path());
    ASSERT_TRUE(m);
    dpc_model_info info = info_of(m.get());
    for (uint64_t seed : {3ull, 99ull}) {
        std::vector<float> x = input_points(info, seed, info.n_points);
        ASSERT_EQ(dpc_filter(m.get(), info.n_points, x.data()), DPC_OK) << dpc_last_error();
        EXPECT_EQ(x, generate(m.get(), seed)) << "seed " << seed;
    }
}

TEST_P(PerModel, ThreadCountDoesNotChangeBits) {
    std::vector<dpc_isa> isas = {DPC_ISA_SCALAR};
    for (dpc_isa v : vector_isas()) isas.push_back(v);
    for (dpc_isa isa : isas) {
        ModelPtr one = load(path(), isa, 1);
        ASSERT_TRUE(one);
        dpc_model_info info = info_of(one.get());
        std::vector<size_t> counts = {0};
        if (other_count(info)) counts.push_back(other_count(info));
        if (parallel_count(info)) counts.push_back(parallel_count(info));
        for (uint32_t threads : {2u, 3u, 8u}) {
            ModelPtr many = load(path(), isa, threads);
            ASSERT_TRUE(many);
            for (size_t n : counts)
                for (uint64_t seed : {5ull})
                    EXPECT_EQ(generate(one.get(), seed, n), generate(many.get(), seed, n))
                        << isa_name(isa) << ", 1 vs " << threads << " threads, n " << n << ", seed " << seed;
        }
    }
}

TEST_P(PerModel, EightThreadsSharingOneModelGiveTheSerialResults) {
    for (uint32_t handle_threads : {1u, 2u}) {
        ModelPtr m = load(path(), DPC_ISA_AUTO, handle_threads);
        ASSERT_TRUE(m);
        const int T = 8, per_thread = 2;
        std::vector<std::vector<float>> serial(T * per_thread);
        for (int s = 0; s < T * per_thread; s++) serial[s] = generate(m.get(), 1000 + s);
        std::vector<std::vector<float>> parallel(T * per_thread);
        std::vector<int> failures(T, 0);
        std::vector<std::thread> pool;
        dpc_model_info info = info_of(m.get());
        for (int t = 0; t < T; t++)
            pool.emplace_back([&, t] {
                for (int r = 0; r < per_thread; r++) {
                    int s = t + T * r; // interleave seeds between threads
                    std::vector<float> out((size_t)info.n_points * info.dims);
                    if (dpc_generate(m.get(), 1000 + s, out.data()) != DPC_OK) failures[t]++;
                    parallel[s] = std::move(out);
                }
            });
        for (auto &th : pool) th.join();
        for (int t = 0; t < T; t++) EXPECT_EQ(failures[t], 0) << "thread " << t;
        for (int s = 0; s < T * per_thread; s++)
            EXPECT_EQ(serial[s], parallel[s]) << "seed " << 1000 + s << ", handle threads " << handle_threads;
    }
}

TEST_P(PerModel, BatchEqualsPerSeedGenerate) {
    ModelPtr m = load(path(), DPC_ISA_AUTO, 2);
    ASSERT_TRUE(m);
    dpc_model_info info = info_of(m.get());
    std::vector<size_t> counts = {0};
    if (other_count(info)) counts.push_back(600);
    for (size_t n : counts) {
        size_t m_pts = n ? n : info.n_points;
        for (uint64_t seed : {10ull, ~0ull - 1}) { // the second wraps: seeds 2^64-2, 2^64-1, 0, 1
            const size_t count = 4;
            ASSERT_EQ(dpc_output_size(m.get(), count, m_pts), count * m_pts * info.dims);
            std::vector<float> batch(count * m_pts * info.dims, -1.0f);
            ASSERT_EQ(dpc_generate_batch(m.get(), seed, count, n, batch.data()), DPC_OK) << dpc_last_error();
            for (size_t c = 0; c < count; c++) {
                std::vector<float> one = generate(m.get(), seed + c, n); // uint64 wraps
                std::vector<float> part(batch.begin() + c * one.size(), batch.begin() + (c + 1) * one.size());
                EXPECT_EQ(part, one) << "set " << c << " of the batch from seed " << seed << ", n " << n;
            }
        }
    }
}

TEST_P(PerModel, OtherPointCounts) {
    ModelPtr m = load(path());
    ASSERT_TRUE(m);
    dpc_model_info info = info_of(m.get());
    EXPECT_EQ(generate(m.get(), 4, 0), generate(m.get(), 4, info.n_points)) << "0 means the trained count";
    if (info.grid_dims) GTEST_SKIP() << "gridded models generate only their grid's count (tested in test_api)";
    for (size_t n : {777u, 1500u, 3000u}) {
        if (info.dims >= 8 && n > 1000) continue; // O(m^2) full-space subspace: keep it fast
        std::vector<float> y = generate(m.get(), 4, n);
        ASSERT_EQ(y.size(), n * info.dims);
        expect_unit_cube(y);
        EXPECT_EQ(y, generate(m.get(), 4, n)) << n << " points: not deterministic";
        EXPECT_GT(mean_move(info, input_points(info, 4, n), y), 1e-3) << n << " points did not move";
    }
}

TEST_P(PerModel, OnePointIsNotMoved) {
    // With m = 1 the only pair is j = i (d = 0, below the cut-off): the output is the input.
    ModelPtr m = load(path());
    ASSERT_TRUE(m);
    dpc_model_info info = info_of(m.get());
    if (info.grid_dims) GTEST_SKIP() << "a gridded model has exactly its grid's count";
    for (uint64_t seed : {0ull, 8ull}) EXPECT_EQ(generate(m.get(), seed, 1), input_points(info, seed, 1));
    for (size_t n : {2u, 3u, 17u}) expect_unit_cube(generate(m.get(), 8, n));
}

TEST_P(PerModel, EveryIsaGivesTheScalarBits) {
    // dpc.h: every ISA path evaluates the canonical order of docs/model-format.md §3, so the
    // outputs are the same bits, for any thread count.
    std::vector<dpc_isa> isas = vector_isas();
    if (isas.empty()) GTEST_SKIP() << "this CPU has no vector ISA path libdpc supports (AVX2+FMA)";
    ModelPtr scalar = load(path(), DPC_ISA_SCALAR);
    ASSERT_TRUE(scalar);
    EXPECT_EQ(info_of(scalar.get()).isa, DPC_ISA_SCALAR);
    dpc_model_info info = info_of(scalar.get());
    std::vector<size_t> counts = {0};
    if (other_count(info)) counts.push_back(other_count(info));
    for (dpc_isa isa : isas)
        for (uint32_t threads : {1u, 3u}) {
            ModelPtr vec = load(path(), isa, threads);
            ASSERT_TRUE(vec);
            EXPECT_EQ(info_of(vec.get()).isa, isa);
            for (size_t n : counts)
                for (uint64_t seed : {0ull, 1ull, 77ull})
                    EXPECT_EQ(generate(scalar.get(), seed, n), generate(vec.get(), seed, n))
                        << isa_name(isa) << " vs scalar, " << threads << " threads, seed " << seed << ", n " << n;
        }
}

INSTANTIATE_TEST_SUITE_P(TestModels, PerModel, ::testing::ValuesIn(model_names()), param_name);

TEST(Isa, UnsupportedIsaIsReported) {
    // dpc.h: "Asking for a path the CPU lacks gives DPC_ERROR_UNSUPPORTED".
    struct Path {
        dpc_isa isa;
        bool cpu_has;
    };
    int refused = 0;
    for (Path p : {Path{DPC_ISA_AVX2, cpu_has_avx2_fma()}, Path{DPC_ISA_AVX512, cpu_has_avx512()}}) {
        dpc_load_options o;
        dpc_load_options_init(&o);
        o.isa = p.isa;
        dpc_model *m = nullptr;
        dpc_status st = dpc_model_load_file(model_path("model_2d").c_str(), &o, &m);
        ModelPtr hold(m);
        if (p.cpu_has) {
            EXPECT_EQ(st, DPC_OK) << isa_name(p.isa) << ": the CPU has it: " << dpc_last_error();
            if (m) {
                EXPECT_EQ(info_of(m).isa, p.isa);
            }
        } else {
            EXPECT_EQ(st, DPC_ERROR_UNSUPPORTED) << isa_name(p.isa) << " requested on a CPU without it";
            EXPECT_EQ(m, nullptr);
            refused++;
        }
    }
    std::printf("[ info ] %d of 2 vector ISAs missing on this CPU (checked they are refused)\n", refused);
}

// ---- gridded dimensions ----------------------------------------------------------------------

TEST(Grid, GriddedDimsAreCellCentresAndNeverMove) {
    ModelPtr m = load(model_path("model_grid_3to1"));
    ASSERT_TRUE(m);
    for (uint64_t seed : {0ull, 1ull, 31337ull}) {
        std::vector<float> y = generate(m.get(), seed);
        ASSERT_EQ(y.size(), 1024u * 3);
        for (size_t i = 0; i < 1024; i++) {
            // §5: the first grid axis varies fastest; centres (cell + 0.5) / 32 are exact floats.
            ASSERT_EQ(y[i * 3 + 0], ((float)(i % 32) + 0.5f) / 32.0f) << "point " << i;
            ASSERT_EQ(y[i * 3 + 1], ((float)(i / 32) + 0.5f) / 32.0f) << "point " << i;
        }
    }
}

TEST(Grid, FilterLeavesGivenGriddedValuesAlone) {
    ModelPtr m = load(model_path("model_grid_3to1"));
    ASSERT_TRUE(m);
    std::vector<float> x(1024 * 3);
    ASSERT_EQ(dpc_uniform(5, 1024, 3, x.data()), DPC_OK); // gridded dims NOT on cell centres
    std::vector<float> y = x;
    ASSERT_EQ(dpc_filter(m.get(), 1024, y.data()), DPC_OK) << dpc_last_error();
    size_t moved = 0;
    for (size_t i = 0; i < 1024; i++) {
        ASSERT_EQ(y[i * 3 + 0], x[i * 3 + 0]);
        ASSERT_EQ(y[i * 3 + 1], x[i * 3 + 1]);
        moved += y[i * 3 + 2] != x[i * 3 + 2];
    }
    EXPECT_GT(moved, 900u) << "the value dimension should move";
}

// ---- equivalent encodings (tests/data/variants) ---------------------------------------------

TEST(Variants, EquivalentFilesGiveTheSameBits) {
    std::ifstream manifest(data_path("variants/manifest.tsv"));
    ASSERT_TRUE(manifest) << "variants/manifest.tsv missing";
    std::string line;
    int checked = 0;
    while (std::getline(manifest, line)) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream ss(line);
        std::string file, base, why;
        std::getline(ss, file, '\t');
        std::getline(ss, base, '\t');
        std::getline(ss, why);
        SCOPED_TRACE(file + " (" + why + ")");
        ModelPtr v = load(data_path("variants/" + file));
        ModelPtr b = load(data_path(base));
        ASSERT_TRUE(v && b);
        dpc_model_info vi = info_of(v.get()), bi = info_of(b.get());
        EXPECT_EQ(vi.dims, bi.dims);
        EXPECT_EQ(vi.n_points, bi.n_points);
        EXPECT_EQ(vi.layers, bi.layers);
        EXPECT_EQ(vi.grid_dims, bi.grid_dims);
        for (uint64_t seed : {0ull, 12ull}) EXPECT_EQ(generate(v.get(), seed), generate(b.get(), seed));
        checked++;
    }
    EXPECT_GE(checked, 8);
}

// ---- absolute correctness: the float64 reference's output (tests/data/golden) -----------------

TEST(Golden, EveryIsaMatchesTheFloat64Reference) {
    // golden/MODEL__seedS__nN.f32 holds tests/python/reference_cascade.py's output for
    // dpc_generate_n(MODEL, S, N), rounded to float32 (tests/data/make_golden.py).
    std::vector<dpc_isa> isas = {DPC_ISA_SCALAR};
    for (dpc_isa v : vector_isas()) isas.push_back(v);
    std::set<std::string> models_seen;
    int files = 0;
    for (const auto &entry : std::filesystem::directory_iterator(data_path("golden"))) {
        std::string fname = entry.path().filename().string();
        if (entry.path().extension() != ".f32") continue;
        size_t a = fname.find("__seed"), b = fname.find("__n");
        ASSERT_TRUE(a != std::string::npos && b != std::string::npos && b > a) << fname;
        std::string model = fname.substr(0, a);
        uint64_t seed = std::stoull(fname.substr(a + 6, b - a - 6));
        size_t n = std::stoull(fname.substr(b + 3));
        std::vector<uint8_t> raw = read_file(entry.path().string());
        std::vector<float> expect(raw.size() / 4);
        std::memcpy(expect.data(), raw.data(), expect.size() * 4); // little-endian hosts
        for (dpc_isa isa : isas) {
            ModelPtr m = load(model_path(model), isa);
            ASSERT_TRUE(m);
            ASSERT_EQ(expect.size(), n * info_of(m.get()).dims) << fname;
            double d = max_torus_diff(generate(m.get(), seed, n), expect);
            EXPECT_LE(d, 1e-5) << fname << ", " << isa_name(isa);
            std::printf("[ info ] %s %s: max |diff| %.3g\n", fname.c_str(), isa_name(isa).c_str(), d);
        }
        models_seen.insert(model);
        files++;
    }
    EXPECT_EQ(models_seen.size(), model_names().size()) << "golden files should cover every test model";
    EXPECT_GE(files, 5);
}

// ---- progressive models (docs/model-format.md §6) ---------------------------------------------

namespace {
std::vector<float> head(const std::vector<float> &x, size_t points) {
    return std::vector<float>(x.begin(), x.begin() + (ptrdiff_t)(points * 2));
}
} // namespace

TEST(Progressive, LevelSizesArePrefixesOfLargerSets) {
    ModelPtr m = load(model_path("model_2d_progressive"));
    ASSERT_TRUE(m);
    EXPECT_STREQ(dpc_model_metadata(m.get(), "dpc.order"), "progressive");
    for (uint64_t seed : {0ull, 9ull, ~0ull}) {
        const std::vector<float> big = generate(m.get(), seed, 300); // levels 16, 32, ..., 256, +44
        for (size_t n : {16u, 32u, 64u, 128u, 256u})
            EXPECT_EQ(head(big, n), generate(m.get(), seed, n)) << "n " << n << ", seed " << seed;
        // 100 is no level size of 300: its levels are 16 .. 64 and 36 more
        const std::vector<float> odd = generate(m.get(), seed, 100);
        EXPECT_EQ(head(odd, 64), head(big, 64));
        EXPECT_NE(odd, head(big, 100));
        // the first level is the cascade on the seed's input points, as for a set model
        std::vector<float> x = input_points(info_of(m.get()), seed, 16);
        ASSERT_EQ(dpc_filter(m.get(), 16, x.data()), DPC_OK) << dpc_last_error();
        ASSERT_EQ(dpc_order_levels(x.data(), 16, 2, 16), DPC_OK) << dpc_last_error(); // in its order
        EXPECT_EQ(x, head(big, 16));
    }
}

namespace {
// A 2-D model's sets of `points` points (20,000: large enough for the engine's threads inside a
// set) on every ISA path with 1 and 3 threads, and set 1 of a batch of `batch_points`, are the
// scalar single-thread bits.
void expect_same_bits_everywhere(const std::string &name, size_t points = 20000, size_t batch_points = 500) {
    ModelPtr ref = load(model_path(name), DPC_ISA_SCALAR, 1);
    ASSERT_TRUE(ref);
    const std::vector<float> want = generate(ref.get(), 4, points);
    std::vector<dpc_isa> isas = {DPC_ISA_SCALAR};
    for (dpc_isa v : vector_isas()) isas.push_back(v);
    for (dpc_isa isa : isas)
        for (uint32_t threads : {1u, 3u}) {
            ModelPtr m = load(model_path(name), isa, threads);
            ASSERT_TRUE(m);
            EXPECT_EQ(generate(m.get(), 4, points), want) << isa_name(isa) << ", " << threads << " threads";
            const ptrdiff_t per = (ptrdiff_t)batch_points * 2;
            std::vector<float> batch(3 * (size_t)per);
            ASSERT_EQ(dpc_generate_batch(m.get(), 7, 3, batch_points, batch.data()), DPC_OK) << dpc_last_error();
            EXPECT_EQ(std::vector<float>(batch.begin() + per, batch.begin() + 2 * per),
                      generate(ref.get(), 8, batch_points));
        }
}
} // namespace

TEST(Progressive, ThreadsIsasAndBatchesGiveTheSameBits) { expect_same_bits_everywhere("model_2d_progressive"); }

// dpc.balance on a progressive model (§5.1, §6): each level's own points balance its prefix, so
// the level sizes stay prefixes and each has (almost) no power at 0 < |q| <= k.
TEST(Progressive, BalancedLevelsKeepThePrefixesAndCancelTheTorusScale) {
    ModelPtr m = load(model_path("model_2d_progressive_balanced"));
    ASSERT_TRUE(m);
    uint32_t k = 0;
    ASSERT_EQ(dpc_model_get_balance(m.get(), &k), DPC_OK);
    EXPECT_EQ(k, 8u);
    ModelPtr plain = load(model_path("model_2d_progressive"));
    const std::vector<float> big = generate(m.get(), 3, 300);
    EXPECT_NE(big, generate(plain.get(), 3, 300));
    for (size_t n : {16u, 32u, 64u, 128u, 256u}) {
        const std::vector<float> x = generate(m.get(), 3, n);
        EXPECT_EQ(head(big, n), x) << "n " << n;
        const double e = 6.283185307179586;
        for (size_t axis = 0; axis < 2; axis++) { // q = (1, 0) and (0, 1): balanced at every level size
            double re = 0.0, im = 0.0;
            for (size_t i = 0; i < n; i++) {
                re += std::cos(e * (double)x[2 * i + axis]);
                im += std::sin(e * (double)x[2 * i + axis]);
            }
            EXPECT_LT((re * re + im * im) / (double)n, 1e-5) << "n " << n << ", axis " << axis;
        }
    }
}

TEST(Progressive, BalancedThreadsIsasAndBatchesGiveTheSameBits) {
    expect_same_bits_everywhere("model_2d_progressive_balanced");
}

TEST(Progressive, RunsOnTheCpuAndVulkanSaysWhy) {
    dpc_load_options o;
    dpc_load_options_init(&o);
    o.backend = DPC_BACKEND_VULKAN;
    dpc_model *m = nullptr;
    EXPECT_EQ(dpc_model_load_file(model_path("model_2d_progressive").c_str(), &o, &m), DPC_ERROR_UNSUPPORTED);
    EXPECT_EQ(m, nullptr);
    EXPECT_NE(std::string(dpc_last_error()).find("progressive"), std::string::npos) << dpc_last_error();
    o.backend = DPC_BACKEND_AUTO;
    ASSERT_EQ(dpc_model_load_file(model_path("model_2d_progressive").c_str(), &o, &m), DPC_OK) << dpc_last_error();
    dpc_backend b = DPC_BACKEND_VULKAN;
    EXPECT_EQ(dpc_model_get_backend(m, &b), DPC_OK);
    EXPECT_EQ(b, DPC_BACKEND_CPU);
    dpc_model_free(m);
}

// ---- the order within the levels (docs/model-format.md §6) --------------------------------------

namespace {
// the smallest toroidal distance among the first n points, times sqrt(n)
double min_gap(const std::vector<float> &x, size_t n) {
    double best = 1.0;
    for (size_t i = 0; i < n; i++)
        for (size_t j = i + 1; j < n; j++) {
            double d2 = 0.0;
            for (size_t c = 0; c < 2; c++) {
                double d = std::fabs((double)x[2 * i + c] - (double)x[2 * j + c]);
                d = std::min(d, 1.0 - d);
                d2 += d * d;
            }
            best = std::min(best, std::sqrt(d2));
        }
    return best * std::sqrt((double)n);
}
} // namespace

namespace {
// each level of a set of m points (base 16) sorted as (x, y) pairs: its set of points
std::vector<std::vector<std::pair<float, float>>> level_sets(const std::vector<float> &x, size_t m) {
    std::vector<std::vector<std::pair<float, float>>> out;
    for (size_t n = 0, a = std::min<size_t>(m, 16); n < m; n += a, a = std::min(n, m - n)) {
        std::vector<std::pair<float, float>> level;
        for (size_t i = n; i < n + a; i++) level.emplace_back(x[2 * i], x[2 * i + 1]);
        std::sort(level.begin(), level.end());
        out.push_back(level);
    }
    return out;
}
} // namespace

// The generator's levels come out in their order: ordering them again changes nothing.
TEST(OrderLevels, TheGeneratorLeavesEveryLevelInItsOrder) {
    for (const char *name : {"model_2d_progressive", "model_2d_progressive_balanced", "model_2d_progressive_relaxed"}) {
        ModelPtr m = load(model_path(name));
        ASSERT_TRUE(m);
        for (size_t n : {12u, 100u, 300u}) {
            std::vector<float> x = generate(m.get(), 4, n);
            const std::vector<float> want = x;
            ASSERT_EQ(dpc_order_levels(x.data(), n, 2, 16), DPC_OK) << dpc_last_error();
            EXPECT_EQ(x, want) << name << ", " << n << " points";
        }
    }
}

// Each level keeps its set of points, in a new order (the prefixes' quality is measured on the
// bundled models in Python: tests/python/test_progressive.py), and the first level of a set of
// fewer than base points is one level.
TEST(OrderLevels, EachLevelKeepsItsPoints) {
    for (uint64_t seed = 0; seed < 4; seed++)
        for (size_t n : {256u, 200u, 12u}) {
            std::vector<float> x(n * 2);
            ASSERT_EQ(dpc_uniform(seed, n, 2, x.data()), DPC_OK);
            const std::vector<float> y = x;
            ASSERT_EQ(dpc_order_levels(x.data(), n, 2, 16), DPC_OK) << dpc_last_error();
            EXPECT_EQ(level_sets(x, n), level_sets(y, n));
            EXPECT_NE(x, y);
        }
}

TEST(OrderLevels, BadArgumentsLeaveThePointsAsTheyWere) {
    std::vector<float> x(100 * 3);
    ASSERT_EQ(dpc_uniform(1, 100, 3, x.data()), DPC_OK);
    const std::vector<float> before = x;
    EXPECT_EQ(dpc_order_levels(nullptr, 100, 3, 16), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_order_levels(x.data(), 0, 3, 16), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_order_levels(x.data(), 100, 0, 16), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_order_levels(x.data(), 100, DPC_MAX_DIMS + 1, 16), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_order_levels(x.data(), 100, 3, 0), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_order_levels(x.data(), (size_t)DPC_MAX_POINTS + 1, 3, 16), DPC_ERROR_LIMIT);
    x[77] = 1.0f;
    EXPECT_EQ(dpc_order_levels(x.data(), 100, 3, 16), DPC_ERROR_INVALID_ARGUMENT);
    x[77] = before[77];
    EXPECT_EQ(x, before);
    EXPECT_EQ(dpc_order_levels(x.data(), 100, 3, 16), DPC_OK); // 3-D: the cells split x and y
    EXPECT_NE(x, before);
}

// ---- the prefix relaxation (docs/model-format.md §6.1) ----------------------------------------

// dpc.relax = 400: the levels of model_2d_progressive, then dpc_relax_prefixes on all points, then
// each level's order: each level holds the points of the relaxation of the levels.
TEST(Relax, TheModelIsItsLevelsThenTheRelaxation) {
    ModelPtr m = load(model_path("model_2d_progressive_relaxed"));
    ModelPtr levels = load(model_path("model_2d_progressive"));
    ASSERT_TRUE(m && levels);
    EXPECT_STREQ(dpc_model_metadata(m.get(), "dpc.relax"), "400");
    for (uint64_t seed : {0ull, 9ull, ~0ull})
        for (size_t n : {10u, 64u, 300u}) {
            std::vector<float> x = generate(levels.get(), seed, n);
            ASSERT_EQ(dpc_relax_prefixes(x.data(), n, 16, 400, 1), n >= 16 ? DPC_OK : DPC_ERROR_INVALID_ARGUMENT);
            if (n >= 16) { // the levels' order comes last (§6): the relaxation saw them in their input order
                ASSERT_EQ(dpc_order_levels(x.data(), n, 2, 16), DPC_OK) << dpc_last_error();
                EXPECT_EQ(level_sets(generate(m.get(), seed, n), n), level_sets(x, n))
                    << "seed " << seed << ", n " << n;
            }
        }
    // every point moves: the first n points of a set are no longer the set of n (§6.1)
    const std::vector<float> big = generate(m.get(), 3, 256);
    EXPECT_NE(head(big, 64), generate(m.get(), 3, 64));
}

// Every prefix 16 * 2^j and the whole set keep their points apart (min distance times sqrt(n)),
// far more than model_2d_progressive's held levels (model_2d's cascade is no progressive design).
TEST(Relax, EveryPrefixSpreadsOut) {
    ModelPtr m = load(model_path("model_2d_progressive_relaxed"));
    ModelPtr levels = load(model_path("model_2d_progressive"));
    double relaxed_sum = 0.0, levels_sum = 0.0;
    for (uint64_t seed = 0; seed < 4; seed++) {
        const std::vector<float> x = generate(m.get(), seed, 200), y = generate(levels.get(), seed, 200);
        for (size_t n : {16u, 32u, 64u, 128u, 200u}) {
            EXPECT_GT(min_gap(x, n), 0.4) << "seed " << seed << ", n " << n; // the levels: 0.03-0.73
            relaxed_sum += min_gap(x, n);
            levels_sum += min_gap(y, n);
        }
    }
    EXPECT_GT(relaxed_sum, 2.0 * levels_sum); // 11.2 against 4.5 when written
}

// 600 points: below the relaxation's threading threshold (SameBitsForEveryThreadCount covers it).
TEST(Relax, SameBitsOnEveryPathThreadCountAndBatch) {
    expect_same_bits_everywhere("model_2d_progressive_relaxed", 600, 600);
}

// From 2,048 points the steps are shared by threads, in fixed parts: the same bits for any count.
TEST(Relax, SameBitsForEveryThreadCount) {
    std::vector<float> want(2500 * 2);
    ASSERT_EQ(dpc_uniform(5, 2500, 2, want.data()), DPC_OK);
    const std::vector<float> start = want;
    ASSERT_EQ(dpc_relax_prefixes(want.data(), 2500, 16, 30, 1), DPC_OK) << dpc_last_error();
    EXPECT_NE(want, start);
    for (uint32_t threads : {0u, 2u, 3u, 8u, 64u}) {
        std::vector<float> x = start;
        ASSERT_EQ(dpc_relax_prefixes(x.data(), 2500, 16, 30, threads), DPC_OK) << dpc_last_error();
        EXPECT_EQ(x, want) << threads << " threads";
    }
}

TEST(Relax, BadArgumentsLeaveThePointsAsTheyWere) {
    std::vector<float> x(100 * 2);
    ASSERT_EQ(dpc_uniform(1, 100, 2, x.data()), DPC_OK);
    const std::vector<float> before = x;
    EXPECT_EQ(dpc_relax_prefixes(nullptr, 100, 16, 10, 1), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_relax_prefixes(x.data(), 100, 1, 10, 1), DPC_ERROR_INVALID_ARGUMENT); // base < 2
    EXPECT_EQ(dpc_relax_prefixes(x.data(), 15, 16, 10, 1), DPC_ERROR_INVALID_ARGUMENT); // fewer than base
    EXPECT_EQ(dpc_relax_prefixes(x.data(), 100, 16, 100001, 1), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(dpc_last_error()).find("100000"), std::string::npos) << dpc_last_error();
    EXPECT_EQ(dpc_relax_prefixes(x.data(), (size_t)DPC_MAX_POINTS + 1, 16, 10, 1), DPC_ERROR_LIMIT);
    x[77] = 1.0f;
    EXPECT_EQ(dpc_relax_prefixes(x.data(), 100, 16, 10, 1), DPC_ERROR_INVALID_ARGUMENT);
    x[77] = before[77];
    EXPECT_EQ(x, before);
    EXPECT_EQ(dpc_relax_prefixes(x.data(), 100, 16, 0, 1), DPC_OK); // no steps: nothing moves
    EXPECT_EQ(x, before);
    EXPECT_EQ(dpc_relax_prefixes(x.data(), 100, 16, 10, 1), DPC_OK);
    EXPECT_NE(x, before);
    for (float v : x) EXPECT_TRUE(v >= 0.0f && v < 1.0f);
}

namespace {
struct Polls {
    uint64_t total = 0, after_end = 0;
};
int stop_after_the_layers(void *user, uint64_t done, uint64_t total) {
    Polls *p = (Polls *)user;
    p->total = total;
    if (done < total) return 0;
    return ++p->after_end >= 3; // the relaxation polls once every 10 steps after the last layer
}
} // namespace

TEST(Relax, TheProgressCallbackCanStopIt) {
    ModelPtr m = load(model_path("model_2d_progressive_relaxed"));
    std::vector<float> out(2000 * 2);
    Polls polls;
    dpc_generate_options o;
    dpc_generate_options_init(&o);
    o.progress = stop_after_the_layers;
    o.user = &polls;
    EXPECT_EQ(dpc_generate_ex(m.get(), 1, 1, 2000, &o, out.data()), DPC_ERROR_CANCELLED) << dpc_last_error();
    EXPECT_EQ(polls.after_end, 3u);
}

// ---- the output balance (docs/model-format.md §5.1) -------------------------------------------

namespace {
// max over 0 < |q|^2 <= k2 of |sum_j exp(-2 pi i q.x_j)|^2 / m, in long double
double low_power(const std::vector<float> &x, int k2) {
    const size_t m = x.size() / 2;
    double worst = 0.0;
    for (int a = 0; a * a <= k2; a++)
        for (int b = -8; b <= 8; b++) {
            if (a * a + b * b == 0 || a * a + b * b > k2 || (a == 0 && b < 0)) continue;
            long double re = 0, im = 0;
            for (size_t j = 0; j < m; j++) {
                const long double ph =
                    2 * 3.14159265358979323846L * (a * (long double)x[2 * j] + b * (long double)x[2 * j + 1]);
                re += std::cos(ph);
                im -= std::sin(ph);
            }
            worst = std::max(worst, (double)((re * re + im * im) / m));
        }
    return worst;
}
} // namespace

TEST(Balance, GenerateIsTheCascadeThenTheBalance) {
    ModelPtr m = load(model_path("model_2d_balanced"));
    ModelPtr plain = load(model_path("model_2d"));
    ASSERT_TRUE(m && plain);
    uint32_t k = 0;
    ASSERT_EQ(dpc_model_get_balance(m.get(), &k), DPC_OK);
    EXPECT_EQ(k, 3u);
    ASSERT_EQ(dpc_model_get_balance(plain.get(), &k), DPC_OK);
    EXPECT_EQ(k, 0u);
    for (uint64_t seed : {0ull, 5ull, ~0ull}) {
        std::vector<float> want = generate(plain.get(), seed, 1024);
        const double before = low_power(want, 9);
        ASSERT_EQ(dpc_balance(want.data(), 1024, 2, 3), DPC_OK) << dpc_last_error();
        const std::vector<float> got = generate(m.get(), seed, 1024);
        EXPECT_EQ(got, want) << "seed " << seed;
        // model_2d is no blue noise (about 1 there, as white noise): three steps still take 1e-6 of it
        EXPECT_GT(before, 0.1);
        EXPECT_LT(low_power(got, 9), 1e-6 * before) << "seed " << seed;
        // dpc_filter is the cascade alone
        std::vector<float> x = input_points(info_of(m.get()), seed, 1024);
        ASSERT_EQ(dpc_filter(m.get(), 1024, x.data()), DPC_OK) << dpc_last_error();
        EXPECT_EQ(x, generate(plain.get(), seed, 1024));
    }
}

TEST(Balance, ThreadsIsasAndBatchesGiveTheSameBits) { expect_same_bits_everywhere("model_2d_balanced"); }

TEST(Balance, RadiusShrinksWithTheSetAndPointsStayInTheTorus) {
    // K = min(radius, largest j with (4 j)^dims <= m): 15 points get none, 64 points |q| <= 2
    std::vector<float> x(15 * 2), y;
    dpc_uniform(1, 15, 2, x.data());
    y = x;
    ASSERT_EQ(dpc_balance(y.data(), 15, 2, 3), DPC_OK);
    EXPECT_EQ(x, y);
    x.resize(64 * 2);
    dpc_uniform(2, 64, 2, x.data());
    const double white = low_power(x, 4);
    ASSERT_EQ(dpc_balance(x.data(), 64, 2, 3), DPC_OK);
    EXPECT_LT(low_power(x, 4), 1e-3 * white); // 64 white-noise points: the steps' first-order model is rough
    EXPECT_GT(low_power(x, 9), 1e-2);         // |q| = sqrt(5), 3: beyond K = 2
    // points at the seam stay in [0, 1)
    std::vector<float> seam(1024 * 2);
    dpc_stratified(3, 1024, 2, seam.data());
    for (size_t i = 0; i < 40; i++) seam[2 * i] = i % 2 ? 0.0f : 0.99999994f;
    ASSERT_EQ(dpc_balance(seam.data(), 1024, 2, 3), DPC_OK);
    for (float v : seam) EXPECT_TRUE(v >= 0.0f && v < 1.0f) << v;
    // 3-D and 1-D too
    std::vector<float> z(4096 * 3);
    dpc_stratified(4, 4096, 3, z.data());
    ASSERT_EQ(dpc_balance(z.data(), 4096, 3, 2), DPC_OK);
    std::vector<float> w(200);
    dpc_stratified(5, 200, 1, w.data());
    ASSERT_EQ(dpc_balance(w.data(), 200, 1, 3), DPC_OK);
}

TEST(Balance, BadArgumentsAreRefusedAndLeaveThePointsAlone) {
    std::vector<float> x(256 * 2);
    dpc_uniform(1, 256, 2, x.data());
    const std::vector<float> keep = x;
    EXPECT_EQ(dpc_balance(nullptr, 256, 2, 3), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_balance(x.data(), 0, 2, 3), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_balance(x.data(), 256, 0, 3), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_balance(x.data(), 2, 65, 3), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_balance(x.data(), 256, 2, 33), DPC_ERROR_INVALID_ARGUMENT);
    x[77] = 1.0f;
    EXPECT_EQ(dpc_balance(x.data(), 256, 2, 3), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(dpc_last_error()).find("[0, 1)"), std::string::npos) << dpc_last_error();
    x[77] = std::nanf("");
    EXPECT_EQ(dpc_balance(x.data(), 256, 2, 3), DPC_ERROR_INVALID_ARGUMENT);
    x[77] = keep[77];
    EXPECT_EQ(x, keep);
    // radius 13 in 3-D holds more than 4,096 frequencies: (4 * 13)^3 = 140,608 points reach it
    std::vector<float> big(140608 * 3, 0.5f);
    EXPECT_EQ(dpc_balance(big.data(), 140608, 3, 13), DPC_ERROR_LIMIT);
    EXPECT_NE(std::string(dpc_last_error()).find("4096"), std::string::npos) << dpc_last_error();
    EXPECT_EQ(big, std::vector<float>(140608 * 3, 0.5f));
    uint32_t k = 0;
    EXPECT_EQ(dpc_model_get_balance(nullptr, &k), DPC_ERROR_INVALID_ARGUMENT);
}
