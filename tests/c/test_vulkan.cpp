// The backend choice and the Vulkan backend: options (old struct sizes, bad values), AUTO's
// fallback, a clear status where Vulkan cannot run, parity with the CPU backend on every test
// model (<= 1e-4, same input points for the same seed), the float64 reference, determinism,
// batches (also past one dispatch's set limit), dpc_filter, concurrent calls on one model, and
// Vulkan failures as statuses with the VkResult in the message.
//
// Tests that need a Vulkan device skip (GTEST_SKIP, with the reason) where libdpc was built
// without the backend (DPC_VULKAN=OFF) or no device exists. run_all.sh runs them on lavapipe.
#include "test_util.h"

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <thread>

using namespace dpct;

#ifndef DPC_TEST_HAVE_VULKAN
#error "DPC_TEST_HAVE_VULKAN must be 0 or 1 (set by tests/c/vulkan_tests.cmake)"
#endif

namespace {

constexpr double kParityTol = 1e-4; // Vulkan vs CPU, float32 on both sides

dpc_status load_with(const std::string &path, dpc_backend backend, dpc_model **out,
                     dpc_input input = DPC_INPUT_UNIFORM) {
    dpc_load_options o;
    dpc_load_options_init(&o);
    o.backend = backend;
    o.input = input;
    return dpc_model_load_file(path.c_str(), &o, out);
}

dpc_backend backend_of(const dpc_model *m) {
    dpc_backend b = DPC_BACKEND_AUTO;
    EXPECT_EQ(dpc_model_get_backend(m, &b), DPC_OK) << dpc_last_error();
    return b;
}

// DPC_TEST_REQUIRE_VULKAN=1 (run_all.sh, which installs lavapipe): a missing device fails
// instead of skipping, so a broken driver install cannot turn the suite into skips.
bool device_required() {
    const char *v = std::getenv("DPC_TEST_REQUIRE_VULKAN");
    return v && std::strcmp(v, "1") == 0;
}

// A model on the Vulkan backend, or null with *skip set to why it cannot be had here.
ModelPtr load_vulkan(const std::string &path, std::string *skip) {
    if (!DPC_TEST_HAVE_VULKAN) {
        *skip = "libdpc was built without the Vulkan backend (DPC_VULKAN=OFF)";
        return nullptr;
    }
    dpc_model *m = nullptr;
    dpc_status st = load_with(path, DPC_BACKEND_VULKAN, &m);
    if (st == DPC_ERROR_UNSUPPORTED) {
        *skip = std::string("no usable Vulkan device: ") + dpc_last_error();
        if (device_required()) ADD_FAILURE() << "DPC_TEST_REQUIRE_VULKAN=1 but " << *skip;
        return nullptr;
    }
    EXPECT_EQ(st, DPC_OK) << dpc_status_string(st) << ": " << dpc_last_error();
    if (m) {
        EXPECT_EQ(backend_of(m), DPC_BACKEND_VULKAN);
    }
    return ModelPtr(m);
}

#define LOAD_VULKAN_OR_SKIP(var, path)             \
    std::string skip_##var;                        \
    ModelPtr var = load_vulkan(path, &skip_##var); \
    if (!var && !skip_##var.empty()) {             \
        GTEST_SKIP() << skip_##var;                \
    }                                              \
    ASSERT_TRUE(var)

ModelPtr load_cpu(const std::string &path) {
    dpc_model *m = nullptr;
    dpc_status st = load_with(path, DPC_BACKEND_CPU, &m);
    EXPECT_EQ(st, DPC_OK) << dpc_last_error();
    return ModelPtr(m);
}

// Input points of dpc_generate_n(model, seed, n) as docs/model-format.md §5 defines them.
std::vector<float> input_points(const dpc_model_info &info, uint64_t seed, size_t n) {
    std::vector<float> x(n * info.dims);
    for (size_t c = 0; c < x.size(); c++) x[c] = uniform_value(seed, c);
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

std::vector<float> batch(const dpc_model *m, uint64_t seed, size_t count, size_t n) {
    dpc_model_info info = info_of(m);
    std::vector<float> out(count * (n ? n : info.n_points) * info.dims, -1.0f);
    dpc_status st = dpc_generate_batch(m, seed, count, n, out.data());
    EXPECT_EQ(st, DPC_OK) << dpc_last_error();
    return out;
}

class VulkanPerModel : public ::testing::TestWithParam<std::string> {
  protected:
    std::string path() const { return model_path(GetParam()); }
};

std::string param_name(const ::testing::TestParamInfo<std::string> &p) { return p.param; }

} // namespace

// ---- the backend choice (every build) --------------------------------------------------------

TEST(BackendChoice, InitDefaultsToAuto) {
    dpc_load_options o;
    std::memset(&o, 0xAB, sizeof o);
    dpc_load_options_init(&o);
    EXPECT_EQ(o.struct_size, (uint32_t)sizeof(dpc_load_options));
    EXPECT_EQ(o.backend, DPC_BACKEND_AUTO);
}

TEST(BackendChoice, CpuIsAlwaysThere) {
    ModelPtr m = load_cpu(model_path("model_2d"));
    ASSERT_TRUE(m);
    EXPECT_EQ(backend_of(m.get()), DPC_BACKEND_CPU);
    EXPECT_STREQ(dpc_model_device(m.get()), "cpu");
    // The CPU backend is the one the other C tests check bit for bit.
    ModelPtr plain = load(model_path("model_2d"), DPC_ISA_AUTO, 1);
    ASSERT_TRUE(plain);
    if (backend_of(plain.get()) == DPC_BACKEND_CPU) {
        EXPECT_EQ(generate(m.get(), 3), generate(plain.get(), 3));
    }
}

TEST(BackendChoice, AutoAlwaysLoadsAndSaysWhatItChose) {
    dpc_model *raw = nullptr;
    ASSERT_EQ(load_with(model_path("model_2d"), DPC_BACKEND_AUTO, &raw), DPC_OK) << dpc_last_error();
    ModelPtr m(raw);
    EXPECT_STREQ(dpc_last_error(), "") << "falling back to the CPU is not an error";
    dpc_backend b = backend_of(m.get());
    if (!DPC_TEST_HAVE_VULKAN) {
        EXPECT_EQ(b, DPC_BACKEND_CPU) << "a build without Vulkan runs on the CPU";
    }
    ASSERT_TRUE(b == DPC_BACKEND_CPU || b == DPC_BACKEND_VULKAN) << (int)b;
    if (b == DPC_BACKEND_CPU) EXPECT_STREQ(dpc_model_device(m.get()), "cpu");
    else EXPECT_GT(std::strlen(dpc_model_device(m.get())), 0u);
    std::printf("[ info ] backend auto chose %s (%s)\n", b == DPC_BACKEND_CPU ? "cpu" : "vulkan",
                dpc_model_device(m.get()));
    std::vector<float> x = generate(m.get(), 0);
    EXPECT_EQ(x.size(), 1024u * 2u);
}

TEST(BackendChoice, BadBackendValueIsInvalidArgument) {
    dpc_load_options o;
    dpc_load_options_init(&o);
    o.backend = (dpc_backend)9;
    dpc_model *m = reinterpret_cast<dpc_model *>(0x1);
    EXPECT_EQ(dpc_model_load_file(model_path("model_2d").c_str(), &o, &m), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(m, nullptr);
    EXPECT_NE(std::string(dpc_last_error()).find("backend"), std::string::npos) << dpc_last_error();
}

TEST(BackendChoice, StructWithoutBackendFieldStillLoadsAsAuto) {
    // A caller compiled against the header before `backend` existed passes the smaller size; the
    // bytes where `backend` now lives are not read (here they hold garbage).
    dpc_load_options o;
    dpc_load_options_init(&o);
    o.struct_size = (uint32_t)offsetof(dpc_load_options, backend);
    o.backend = (dpc_backend)77;
    o.isa = DPC_ISA_SCALAR;
    dpc_model *raw = nullptr;
    ASSERT_EQ(dpc_model_load_file(model_path("model_2d").c_str(), &o, &raw), DPC_OK) << dpc_last_error();
    ModelPtr m(raw);
    EXPECT_EQ(info_of(m.get()).isa, DPC_ISA_SCALAR) << "the fields before backend are read";
    dpc_model *auto_raw = nullptr;
    ASSERT_EQ(load_with(model_path("model_2d"), DPC_BACKEND_AUTO, &auto_raw), DPC_OK);
    ModelPtr a(auto_raw);
    EXPECT_EQ(backend_of(m.get()), backend_of(a.get()));
    for (uint32_t bad : {0u, 4u, 8u, (uint32_t)sizeof(dpc_load_options) + 4}) {
        o.struct_size = bad;
        dpc_model *x = nullptr;
        EXPECT_EQ(dpc_model_load_file(model_path("model_2d").c_str(), &o, &x), DPC_ERROR_INVALID_ARGUMENT) << bad;
        EXPECT_EQ(x, nullptr);
    }
}

TEST(BackendChoice, QueriesCheckTheirArguments) {
    dpc_backend b;
    EXPECT_EQ(dpc_model_get_backend(nullptr, &b), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_GT(std::strlen(dpc_last_error()), 0u);
    ModelPtr m = load_cpu(model_path("model_2d"));
    ASSERT_TRUE(m);
    EXPECT_EQ(dpc_model_get_backend(m.get(), nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_STREQ(dpc_model_device(nullptr), "");
}

TEST(BackendChoice, ExplicitVulkanEitherRunsOrSaysWhyNot) {
    dpc_model *raw = reinterpret_cast<dpc_model *>(0x1);
    dpc_status st = load_with(model_path("model_2d"), DPC_BACKEND_VULKAN, &raw);
    ModelPtr m(st == DPC_OK ? raw : nullptr);
    if (!DPC_TEST_HAVE_VULKAN) {
        EXPECT_EQ(st, DPC_ERROR_UNSUPPORTED);
        EXPECT_EQ(raw, nullptr);
        EXPECT_NE(std::string(dpc_last_error()).find("DPC_VULKAN"), std::string::npos) << dpc_last_error();
        return;
    }
    if (st == DPC_OK) {
        EXPECT_EQ(backend_of(m.get()), DPC_BACKEND_VULKAN);
        EXPECT_GT(std::strlen(dpc_model_device(m.get())), 0u);
        EXPECT_STRNE(dpc_model_device(m.get()), "cpu");
        std::printf("[ info ] Vulkan device: %s\n", dpc_model_device(m.get()));
    } else {
        EXPECT_EQ(st, DPC_ERROR_UNSUPPORTED) << dpc_last_error();
        EXPECT_EQ(raw, nullptr);
        EXPECT_NE(std::string(dpc_last_error()).find("Vulkan"), std::string::npos) << dpc_last_error();
    }
}

// ---- a machine without Vulkan: run by ctest with the environment set (vulkan_tests.cmake) ----

TEST(NoVulkanLoader, ExplicitVulkanIsUnsupportedAndAutoRunsOnTheCpu) {
    const char *loader = std::getenv("DPC_VULKAN_LOADER");
    if (!DPC_TEST_HAVE_VULKAN) GTEST_SKIP() << "libdpc was built without the Vulkan backend (DPC_VULKAN=OFF)";
    if (!loader || !*loader || std::filesystem::exists(loader))
        GTEST_SKIP() << "needs DPC_VULKAN_LOADER naming a missing library (ctest entry vulkan.no_loader sets it)";
    dpc_model *raw = reinterpret_cast<dpc_model *>(0x1);
    EXPECT_EQ(load_with(model_path("model_2d"), DPC_BACKEND_VULKAN, &raw), DPC_ERROR_UNSUPPORTED);
    EXPECT_EQ(raw, nullptr);
    std::string msg = dpc_last_error();
    EXPECT_NE(msg.find("cannot load the Vulkan loader"), std::string::npos) << msg;
    EXPECT_NE(msg.find(loader), std::string::npos) << msg;
    ASSERT_EQ(load_with(model_path("model_3d_mixed"), DPC_BACKEND_AUTO, &raw), DPC_OK) << dpc_last_error();
    ModelPtr a(raw);
    EXPECT_EQ(backend_of(a.get()), DPC_BACKEND_CPU);
    ModelPtr c = load_cpu(model_path("model_3d_mixed"));
    ASSERT_TRUE(c);
    EXPECT_EQ(generate(a.get(), 9), generate(c.get(), 9));
}

TEST(NoVulkanDriver, VkResultIsInTheMessage) {
    // With no driver to load, the loader's vkCreateInstance fails (VK_ERROR_INCOMPATIBLE_DRIVER)
    // or finds no device: a status and a message, never an abort or a print. libdpc makes one
    // Vulkan instance per process and reads the driver choice then, so the environment must be
    // set before the process starts (ctest entry vulkan.no_driver).
    if (!DPC_TEST_HAVE_VULKAN) GTEST_SKIP() << "libdpc was built without the Vulkan backend (DPC_VULKAN=OFF)";
    const char *icd = std::getenv("VK_DRIVER_FILES");
    if (!icd || !*icd || std::filesystem::exists(icd))
        GTEST_SKIP() << "needs VK_DRIVER_FILES naming a missing file (ctest entry vulkan.no_driver sets it)";
    dpc_model *raw = reinterpret_cast<dpc_model *>(0x1);
    dpc_status st = load_with(model_path("model_2d"), DPC_BACKEND_VULKAN, &raw);
    std::string msg = dpc_last_error();
    if (msg.find("cannot load the Vulkan loader") != std::string::npos)
        GTEST_SKIP() << "no Vulkan loader on this machine: " << msg;
    EXPECT_EQ(st, DPC_ERROR_UNSUPPORTED) << msg;
    EXPECT_EQ(raw, nullptr);
    EXPECT_TRUE(msg.find("VK_ERROR_INCOMPATIBLE_DRIVER (VkResult -9)") != std::string::npos ||
                msg.find("no Vulkan device") != std::string::npos)
        << msg;
    std::printf("[ info ] without a driver: %s: %s\n", dpc_status_string(st), msg.c_str());
    // A second load gets the same status and message (vk_engine.c tries again; nothing is cached).
    EXPECT_EQ(load_with(model_path("model_2d"), DPC_BACKEND_VULKAN, &raw), DPC_ERROR_UNSUPPORTED);
    EXPECT_EQ(dpc_last_error(), msg);
}

// ---- the Vulkan backend (skips without a device) ---------------------------------------------

TEST_P(VulkanPerModel, MatchesTheCpuBackend) {
    LOAD_VULKAN_OR_SKIP(vk, path());
    ModelPtr cpu = load_cpu(path());
    ASSERT_TRUE(cpu);
    dpc_model_info info = info_of(cpu.get());
    // The trained count, and one other where the model allows it (radii scale with m).
    std::vector<size_t> counts = {info.n_points};
    if (!info.grid_dims) counts.push_back(info.dims >= 8 ? 600 : 1500);
    double worst = 0;
    for (size_t n : counts)
        for (uint64_t seed : {0ull, 1ull, 123456789ull}) {
            std::vector<float> a = generate(cpu.get(), seed, n), b = generate(vk.get(), seed, n);
            double d = max_torus_diff(a, b);
            EXPECT_LE(d, kParityTol) << GetParam() << ", seed " << seed << ", n " << n;
            for (float v : b) ASSERT_TRUE(v >= 0.0f && v < 1.0f) << v;
            std::printf("[ parity ] %s n=%zu seed=%llu: max |vulkan - cpu| = %.3g\n", GetParam().c_str(), n,
                        (unsigned long long)seed, d);
            worst = std::max(worst, d);
        }
    RecordProperty("max_abs_diff_vulkan_cpu", std::to_string(worst));
}

TEST_P(VulkanPerModel, FiltersTheDocumentedInputPoints) {
    // generate(seed) on Vulkan is the Vulkan filter of §5's points for seed: the same input
    // points as the CPU backend, made by the same generator.
    LOAD_VULKAN_OR_SKIP(vk, path());
    dpc_model_info info = info_of(vk.get());
    for (uint64_t seed : {0ull, 42ull}) {
        std::vector<float> x = input_points(info, seed, info.n_points);
        std::vector<float> given = x;
        ASSERT_EQ(dpc_filter(vk.get(), info.n_points, x.data()), DPC_OK) << dpc_last_error();
        EXPECT_EQ(x, generate(vk.get(), seed)) << "seed " << seed;
        double moved = max_torus_diff(x, given);
        EXPECT_GT(moved, 1e-3) << "the cascade did not move the points";
        for (uint32_t g = 0; g < info.grid_dims; g++)
            for (size_t i = 0; i < info.n_points; i++) {
                size_t k = i * info.dims + info.grid_axis[g];
                ASSERT_EQ(x[k], given[k]) << "gridded dimension moved at point " << i;
            }
    }
}

TEST_P(VulkanPerModel, SameSeedSameBits) {
    LOAD_VULKAN_OR_SKIP(a, path());
    std::string skip;
    ModelPtr b = load_vulkan(path(), &skip);
    ASSERT_TRUE(b);
    for (uint64_t seed : {0ull, ~0ull}) {
        std::vector<float> x = generate(a.get(), seed);
        EXPECT_EQ(x, generate(a.get(), seed)) << "second call differs";
        EXPECT_EQ(x, generate(b.get(), seed)) << "second handle differs";
    }
}

TEST_P(VulkanPerModel, BatchIsPerSeedGenerate) {
    LOAD_VULKAN_OR_SKIP(vk, path());
    dpc_model_info info = info_of(vk.get());
    std::vector<size_t> counts = {0};
    if (!info.grid_dims) counts.push_back(300);
    for (size_t n : counts) {
        const size_t m = n ? n : info.n_points, stride = m * info.dims;
        std::vector<float> all = batch(vk.get(), 7, 4, n);
        for (size_t c = 0; c < 4; c++) {
            std::vector<float> one(all.begin() + c * stride, all.begin() + (c + 1) * stride);
            EXPECT_EQ(one, generate(vk.get(), 7 + c, n)) << "set " << c << ", n " << m;
        }
    }
}

INSTANTIATE_TEST_SUITE_P(TestModels, VulkanPerModel, ::testing::ValuesIn(model_names()), param_name);

TEST(Vulkan, MatchesTheFloat64Reference) {
    int files = 0;
    for (const auto &entry : std::filesystem::directory_iterator(data_path("golden"))) {
        if (entry.path().extension() != ".f32") continue;
        std::string fname = entry.path().filename().string();
        size_t a = fname.find("__seed"), b = fname.find("__n");
        ASSERT_TRUE(a != std::string::npos && b != std::string::npos && b > a) << fname;
        std::string model = fname.substr(0, a);
        uint64_t seed = std::stoull(fname.substr(a + 6, b - a - 6));
        size_t n = std::stoull(fname.substr(b + 3));
        LOAD_VULKAN_OR_SKIP(vk, model_path(model));
        std::vector<uint8_t> raw = read_file(entry.path().string());
        std::vector<float> expect(raw.size() / 4);
        std::memcpy(expect.data(), raw.data(), expect.size() * 4);
        ASSERT_EQ(expect.size(), n * info_of(vk.get()).dims) << fname;
        double d = max_torus_diff(generate(vk.get(), seed, n), expect);
        EXPECT_LE(d, kParityTol) << fname;
        std::printf("[ info ] %s vulkan vs float64 reference: max |diff| %.3g\n", fname.c_str(), d);
        files++;
    }
    EXPECT_GE(files, 5);
}

TEST(Vulkan, OtherCountsIncludingTinyOnes) {
    // m < 64 takes the all-pairs pass for every subspace, m = 1 has no pair at all.
    LOAD_VULKAN_OR_SKIP(vk, model_path("model_3d_mixed"));
    ModelPtr cpu = load_cpu(model_path("model_3d_mixed"));
    ASSERT_TRUE(cpu);
    dpc_model_info info = info_of(cpu.get());
    for (size_t n : {1u, 2u, 17u, 63u, 64u, 65u, 4099u}) {
        double d = max_torus_diff(generate(cpu.get(), 5, n), generate(vk.get(), 5, n));
        EXPECT_LE(d, kParityTol) << n << " points";
    }
    EXPECT_EQ(generate(vk.get(), 5, 1), input_points(info, 5, 1)) << "one point has no neighbour";
}

TEST(Vulkan, CrowdedCellsAreSortedToo) {
    // 900 of 1,024 points in one cell of the grid (the device sorts a cell's points by index
    // with a heapsort when it holds more than 16): parity with the CPU and identical bits on a
    // second run.
    LOAD_VULKAN_OR_SKIP(vk, model_path("model_2d"));
    ModelPtr cpu = load_cpu(model_path("model_2d"));
    ASSERT_TRUE(cpu);
    std::vector<float> x(1024 * 2);
    for (size_t c = 0; c < x.size(); c++) x[c] = uniform_value(77, c);
    for (size_t i = 0; i < 900; i++)
        for (size_t k = 0; k < 2; k++) x[i * 2 + k] = 0.4f + 0.004f * x[i * 2 + k];
    std::vector<float> a = x, b = x, c = x;
    ASSERT_EQ(dpc_filter(cpu.get(), 1024, a.data()), DPC_OK) << dpc_last_error();
    ASSERT_EQ(dpc_filter(vk.get(), 1024, b.data()), DPC_OK) << dpc_last_error();
    ASSERT_EQ(dpc_filter(vk.get(), 1024, c.data()), DPC_OK) << dpc_last_error();
    EXPECT_EQ(b, c) << "crowded cells: the Vulkan result depends on timing";
    EXPECT_LE(max_torus_diff(a, b), kParityTol);
    EXPECT_GT(max_torus_diff(a, x), 1e-4) << "the points did not move";
    std::printf("[ info ] crowded cells: max |vulkan - cpu| = %.3g\n", max_torus_diff(a, b));
}

TEST(Vulkan, BatchLargerThanOneDispatch) {
    // More sets than one dispatch may hold (65,535 workgroups along y): the run is split, and
    // each set is still exactly its own seed's result.
    LOAD_VULKAN_OR_SKIP(vk, model_path("model_2d"));
    const size_t count = 65537, n = 3, stride = n * 2;
    std::vector<float> all = batch(vk.get(), 100, count, n);
    for (size_t c : {size_t(0), size_t(1), size_t(65534), size_t(65535), size_t(65536)}) {
        std::vector<float> one(all.begin() + c * stride, all.begin() + (c + 1) * stride);
        EXPECT_EQ(one, generate(vk.get(), 100 + c, n)) << "set " << c;
    }
    for (float v : all) ASSERT_TRUE(v >= 0.0f && v < 1.0f);
}

TEST(Vulkan, FilterChecksItsInputLikeTheCpu) {
    LOAD_VULKAN_OR_SKIP(vk, model_path("model_2d"));
    std::vector<float> x(20, 0.5f);
    x[7] = 1.0f;
    EXPECT_EQ(dpc_filter(vk.get(), 10, x.data()), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_GT(std::strlen(dpc_last_error()), 0u);
    std::vector<float> out(2 * 1024);
    EXPECT_EQ(dpc_generate_batch(vk.get(), 0, 0, 0, out.data()), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_generate_n(vk.get(), 0, (size_t)DPC_MAX_POINTS + 1, out.data()), DPC_ERROR_LIMIT);
}

TEST(Vulkan, ConcurrentCallsOnOneModel) {
    // dpc.h: calls on one Vulkan-backed model are serialised by the model's mutex. Threads mix
    // single sets, batches and point counts (so work buffers grow while others wait).
    LOAD_VULKAN_OR_SKIP(vk, model_path("model_3d_proj"));
    const int T = 6;
    std::vector<std::vector<float>> serial(T), parallel(T);
    auto job = [&](int t, std::vector<float> *out) {
        const size_t n = t % 3 == 0 ? 0 : 200 + 100 * t;
        if (t % 2 == 0) *out = generate(vk.get(), 500 + t, n);
        else *out = batch(vk.get(), 500 + t, 3, n);
    };
    for (int t = 0; t < T; t++) job(t, &serial[t]);
    for (int round = 0; round < 2; round++) {
        std::vector<std::thread> pool;
        for (int t = 0; t < T; t++) pool.emplace_back(job, t, &parallel[t]);
        for (auto &th : pool) th.join();
        for (int t = 0; t < T; t++) EXPECT_EQ(serial[t], parallel[t]) << "thread " << t << ", round " << round;
    }
}

TEST(Vulkan, ModelsOnDifferentBackendsLiveSideBySide) {
    LOAD_VULKAN_OR_SKIP(a, model_path("model_10d"));
    std::string skip;
    ModelPtr b = load_vulkan(model_path("model_2d"), &skip);
    ModelPtr c = load_cpu(model_path("model_2d"));
    ASSERT_TRUE(b && c);
    std::vector<float> x, y, z;
    std::thread t1([&] { x = generate(a.get(), 1); });
    std::thread t2([&] { y = generate(b.get(), 1); });
    std::thread t3([&] { z = generate(c.get(), 1); });
    t1.join();
    t2.join();
    t3.join();
    EXPECT_EQ(x.size(), 1024u * 10u);
    EXPECT_LE(max_torus_diff(y, z), kParityTol);
    b.reset(); // freeing one model leaves the others working
    EXPECT_EQ(generate(a.get(), 1), x);
}

TEST(Vulkan, ManyModelsOneAfterAnother) {
    // A renderer loads and frees models all its life. NVIDIA's driver (on an H200) refused
    // vkCreateInstance after about 25 instances had come and gone in one process, so libdpc keeps
    // one instance for the process (vk_engine.c); each model still has its own device.
    LOAD_VULKAN_OR_SKIP(first, model_path("model_2d"));
    const std::vector<float> expect = generate(first.get(), 3, 64);
    first.reset();
    for (int i = 0; i < 40; i++) {
        std::string skip;
        ModelPtr m = load_vulkan(model_path("model_2d"), &skip);
        ASSERT_TRUE(m) << "load " << i + 2 << " of 41: " << skip;
        ASSERT_EQ(generate(m.get(), 3, 64), expect) << "load " << i + 2;
    }
}

TEST(Vulkan, StratifiedInputIsTheCpuBackendsToo) {
    // The input points are made on the host by the same code for both backends.
    LOAD_VULKAN_OR_SKIP(probe, model_path("model_2d"));
    dpc_model *v = nullptr, *c = nullptr;
    ASSERT_EQ(load_with(model_path("model_2d"), DPC_BACKEND_VULKAN, &v, DPC_INPUT_STRATIFIED), DPC_OK)
        << dpc_last_error();
    ModelPtr vk(v);
    ASSERT_EQ(load_with(model_path("model_2d"), DPC_BACKEND_CPU, &c, DPC_INPUT_STRATIFIED), DPC_OK) << dpc_last_error();
    ModelPtr cpu(c);
    for (size_t n : {1024u, 1500u}) {
        std::vector<float> x(n * 2);
        ASSERT_EQ(dpc_stratified(8, n, 2, x.data()), DPC_OK);
        ASSERT_EQ(dpc_filter(vk.get(), n, x.data()), DPC_OK) << dpc_last_error();
        EXPECT_EQ(generate(vk.get(), 8, n), x) << "Vulkan generate filters the stratified points, n " << n;
        EXPECT_LE(max_torus_diff(generate(cpu.get(), 8, n), x), kParityTol) << n;
    }
}

TEST(Vulkan, BalancedModelBalancesOnTheHost) {
    // docs/model-format.md §5.1: the Vulkan backend runs the cascade, the host the balance.
    LOAD_VULKAN_OR_SKIP(vk, model_path("model_2d_balanced"));
    ModelPtr cpu = load_cpu(model_path("model_2d_balanced"));
    ASSERT_TRUE(cpu);
    for (size_t n : {1024u, 1500u}) {
        std::vector<float> x(n * 2);
        ASSERT_EQ(dpc_uniform(3, n, 2, x.data()), DPC_OK);
        ASSERT_EQ(dpc_filter(vk.get(), n, x.data()), DPC_OK) << dpc_last_error();
        ASSERT_EQ(dpc_balance(x.data(), n, 2, 3), DPC_OK) << dpc_last_error();
        EXPECT_EQ(generate(vk.get(), 3, n), x) << "Vulkan generate = its filter, then dpc_balance; n " << n;
        EXPECT_LE(max_torus_diff(generate(cpu.get(), 3, n), x), kParityTol) << n;
        std::vector<float> batch(2 * n * 2);
        ASSERT_EQ(dpc_generate_batch(vk.get(), 2, 2, n, batch.data()), DPC_OK) << dpc_last_error();
        EXPECT_EQ(std::vector<float>(batch.begin() + (ptrdiff_t)(n * 2), batch.end()), generate(vk.get(), 3, n));
    }
}
