// API lifecycle, argument checking, error reporting, metadata and the input generator of libdpc
// (public header dpc/dpc.h only).
#include "test_util.h"

#include <algorithm>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <thread>

using namespace dpct;

namespace {

// After a failing call: a non-empty message is available on this thread.
void expect_message() {
    const char *msg = dpc_last_error();
    ASSERT_NE(msg, nullptr);
    EXPECT_GT(std::strlen(msg), 0u) << "dpc_last_error() is empty after a failure";
}

} // namespace

TEST(Version, RuntimeMatchesHeader) {
    EXPECT_EQ(dpc_version_number(), (unsigned)DPC_VERSION_NUMBER);
    std::string expect = std::to_string(DPC_VERSION_MAJOR) + "." + std::to_string(DPC_VERSION_MINOR) + "." +
                         std::to_string(DPC_VERSION_PATCH);
    ASSERT_NE(dpc_version_string(), nullptr);
    EXPECT_EQ(expect, dpc_version_string());
    EXPECT_EQ(DPC_FORMAT_VERSION, 1);
}

// CMake's project version is read from dpc.h (CMakeLists.txt): the build that made this library
// must agree with the library (tests/python/test_version.py checks pyproject and Python).
TEST(Version, MatchesTheCMakeProject) { EXPECT_STREQ(DPC_TEST_PROJECT_VERSION, dpc_version_string()); }

TEST(Status, PinnedValuesAndNames) {
    // The numeric values are part of the ABI (dpc.h: "Values are pinned").
    EXPECT_EQ((int)DPC_OK, 0);
    EXPECT_EQ((int)DPC_ERROR_INVALID_ARGUMENT, 1);
    EXPECT_EQ((int)DPC_ERROR_IO, 2);
    EXPECT_EQ((int)DPC_ERROR_FORMAT, 3);
    EXPECT_EQ((int)DPC_ERROR_UNSUPPORTED, 4);
    EXPECT_EQ((int)DPC_ERROR_OUT_OF_MEMORY, 5);
    EXPECT_EQ((int)DPC_ERROR_LIMIT, 6);
    EXPECT_EQ((int)DPC_ERROR_INTERNAL, 7);
    for (const StatusName &s : status_names()) EXPECT_STREQ(dpc_status_string(s.status), s.name);
    const char *unknown = dpc_status_string((dpc_status)1234);
    ASSERT_NE(unknown, nullptr);
    EXPECT_GT(std::strlen(unknown), 0u);
}

TEST(Options, InitSetsDocumentedDefaults) {
    dpc_load_options o;
    std::memset(&o, 0xAB, sizeof o);
    dpc_load_options_init(&o);
    EXPECT_EQ(o.struct_size, (uint32_t)sizeof(dpc_load_options));
    EXPECT_EQ(o.isa, DPC_ISA_AUTO);
    EXPECT_EQ(o.threads, 1u);
    EXPECT_EQ(o.backend, DPC_BACKEND_AUTO);
    EXPECT_EQ(o.input, DPC_INPUT_AUTO);
}

TEST(Lifecycle, FreeNullIsNoOp) { dpc_model_free(nullptr); }

TEST(Lifecycle, LoadFileNullArguments) {
    dpc_model *m = reinterpret_cast<dpc_model *>(0x1);
    EXPECT_EQ(dpc_model_load_file(nullptr, nullptr, &m), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(m, nullptr) << "*out_model must be NULL after a failure";
    expect_message();
    EXPECT_EQ(dpc_model_load_file(model_path("model_2d").c_str(), nullptr, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    expect_message();
}

TEST(Lifecycle, LoadMemoryNullArguments) {
    dpc_model *m = reinterpret_cast<dpc_model *>(0x1);
    EXPECT_EQ(dpc_model_load_memory(nullptr, 16, nullptr, &m), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(m, nullptr);
    expect_message();
    std::vector<uint8_t> bytes = read_file(model_path("model_2d"));
    ASSERT_FALSE(bytes.empty());
    EXPECT_EQ(dpc_model_load_memory(bytes.data(), bytes.size(), nullptr, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    expect_message();
}

TEST(Lifecycle, MissingFileIsIoError) {
    dpc_model *m = reinterpret_cast<dpc_model *>(0x1);
    std::string path = data_path("no_such_file.onnx");
    EXPECT_EQ(dpc_model_load_file(path.c_str(), nullptr, &m), DPC_ERROR_IO);
    EXPECT_EQ(m, nullptr);
    expect_message();
}

TEST(Lifecycle, DirectoryIsIoError) {
    dpc_model *m = reinterpret_cast<dpc_model *>(0x1);
    EXPECT_EQ(dpc_model_load_file(DPC_TEST_DATA_DIR, nullptr, &m), DPC_ERROR_IO);
    EXPECT_EQ(m, nullptr);
    expect_message();
}

TEST(Lifecycle, BadOptionsAreRejected) {
    dpc_load_options o;
    dpc_model *m = nullptr;
    std::string path = model_path("model_2d");
    dpc_load_options_init(&o);
    o.isa = (dpc_isa)77;
    EXPECT_EQ(dpc_model_load_file(path.c_str(), &o, &m), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(m, nullptr);
    expect_message();
    dpc_load_options_init(&o);
    o.struct_size = 0; // not initialised with dpc_load_options_init
    EXPECT_NE(dpc_model_load_file(path.c_str(), &o, &m), DPC_OK);
    EXPECT_EQ(m, nullptr);
    expect_message();
}

TEST(Lifecycle, LoadFileAndMemoryAgree) {
    std::vector<uint8_t> bytes = read_file(model_path("model_3d_mixed"));
    ASSERT_FALSE(bytes.empty());
    dpc_model *mm = nullptr;
    ASSERT_EQ(dpc_model_load_memory(bytes.data(), bytes.size(), nullptr, &mm), DPC_OK) << dpc_last_error();
    ModelPtr from_mem(mm);
    std::fill(bytes.begin(), bytes.end(), 0); // "not retained after the call returns"
    ModelPtr from_file = load(model_path("model_3d_mixed"));
    ASSERT_TRUE(from_file);
    EXPECT_EQ(generate(from_mem.get(), 5), generate(from_file.get(), 5));
}

TEST(Errors, LastErrorIsPerThread) {
    dpc_model *m = nullptr;
    ASSERT_EQ(dpc_model_load_file(nullptr, nullptr, &m), DPC_ERROR_INVALID_ARGUMENT);
    std::string here = dpc_last_error();
    EXPECT_FALSE(here.empty());
    std::string other = "unset";
    std::thread t([&] { other = dpc_last_error(); });
    t.join();
    EXPECT_EQ(other, "") << "a thread that has not failed must see no message";
}

TEST(Errors, MessageNamesTheProblem) {
    dpc_model *m = nullptr;
    std::string path = data_path("no_such_file.onnx");
    ASSERT_EQ(dpc_model_load_file(path.c_str(), nullptr, &m), DPC_ERROR_IO);
    EXPECT_NE(std::string(dpc_last_error()).find("no_such_file.onnx"), std::string::npos)
        << "message: " << dpc_last_error();
    // From memory, so that no file name (which contains "v2") is part of the message.
    std::vector<uint8_t> opset = read_file(data_path("malformed/opset_dpc_v2.onnx"));
    ASSERT_FALSE(opset.empty());
    ASSERT_EQ(dpc_model_load_memory(opset.data(), opset.size(), nullptr, &m), DPC_ERROR_UNSUPPORTED);
    std::string msg = dpc_last_error();
    // docs/model-format.md §7: "a message naming both versions"
    EXPECT_NE(msg.find('1'), std::string::npos) << msg;
    EXPECT_NE(msg.find('2'), std::string::npos) << msg;
}

// ---- model information -----------------------------------------------------------------------

TEST(Info, TwoDimensionalModel) {
    ModelPtr m = load(model_path("model_2d"));
    ASSERT_TRUE(m);
    dpc_model_info info = info_of(m.get());
    EXPECT_EQ(info.dims, 2u);
    EXPECT_EQ(info.n_points, 1024u);
    EXPECT_EQ(info.layers, 4u);
    EXPECT_EQ(info.grid_dims, 0u);
    EXPECT_NE(info.isa, DPC_ISA_AUTO) << "info.isa is never AUTO";
    EXPECT_EQ(info.threads, 1u);
    EXPECT_EQ(dpc_output_size(m.get(), 3, 100), 3u * 100u * 2u);
    EXPECT_EQ(dpc_output_size(m.get(), SIZE_MAX / 2, 1000), 0u) << "overflow must give 0";
}

TEST(Info, GriddedModel) {
    ModelPtr m = load(model_path("model_grid_3to1"));
    ASSERT_TRUE(m);
    dpc_model_info info = info_of(m.get());
    EXPECT_EQ(info.dims, 3u);
    EXPECT_EQ(info.n_points, 1024u);
    EXPECT_EQ(info.layers, 3u);
    ASSERT_EQ(info.grid_dims, 2u);
    EXPECT_EQ(info.grid_axis[0], 0u);
    EXPECT_EQ(info.grid_axis[1], 1u);
    EXPECT_EQ(info.grid_shape[0], 32u);
    EXPECT_EQ(info.grid_shape[1], 32u);
}

TEST(Info, OtherModels) {
    struct Expect {
        const char *name;
        uint32_t dims, layers;
    };
    for (Expect e : {Expect{"model_3d_proj", 3, 3}, Expect{"model_3d_mixed", 3, 3}, Expect{"model_10d", 10, 3}}) {
        ModelPtr m = load(model_path(e.name));
        ASSERT_TRUE(m);
        dpc_model_info info = info_of(m.get());
        EXPECT_EQ(info.dims, e.dims) << e.name;
        EXPECT_EQ(info.layers, e.layers) << e.name;
        EXPECT_EQ(info.n_points, 1024u) << e.name;
        EXPECT_EQ(info.grid_dims, 0u) << e.name;
    }
}

TEST(Info, ThreadsOption) {
    ModelPtr eight = load(model_path("model_2d"), DPC_ISA_AUTO, 8);
    ASSERT_TRUE(eight);
    EXPECT_EQ(info_of(eight.get()).threads, 8u);
    ModelPtr all = load(model_path("model_2d"), DPC_ISA_AUTO, 0);
    ASSERT_TRUE(all);
    EXPECT_GE(info_of(all.get()).threads, 1u) << "threads = 0 resolves to the CPU count";
}

TEST(Info, NullArguments) {
    dpc_model_info info;
    EXPECT_EQ(dpc_model_get_info(nullptr, &info), DPC_ERROR_INVALID_ARGUMENT);
    expect_message();
    ModelPtr m = load(model_path("model_2d"));
    ASSERT_TRUE(m);
    EXPECT_EQ(dpc_model_get_info(m.get(), nullptr), DPC_ERROR_INVALID_ARGUMENT);
    expect_message();
}

TEST(Metadata, EntriesOfTheTwoDimensionalModel) {
    ModelPtr m = load(model_path("model_2d"));
    ASSERT_TRUE(m);
    EXPECT_STREQ(dpc_model_name(m.get()), "test-2d");
    ASSERT_NE(dpc_model_metadata(m.get(), "dpc.n_points"), nullptr);
    EXPECT_STREQ(dpc_model_metadata(m.get(), "dpc.n_points"), "1024");
    EXPECT_STREQ(dpc_model_metadata(m.get(), "dpc.dims"), "2");
    EXPECT_STREQ(dpc_model_metadata(m.get(), "dpc.format_version"), "1");
    EXPECT_STREQ(dpc_model_metadata(m.get(), "test.kernels"), "tests/data/make_models.py");
    EXPECT_EQ(dpc_model_metadata(m.get(), "no.such.key"), nullptr);

    // Every entry of the file, in any order (make_models.py writes these seven).
    std::map<std::string, std::string> expect = {
        {"dpc.name", "test-2d"},
        {"dpc.description", "Test model: 2-D repulsion/attraction cascade, one subspace."},
        {"dpc.loss", "none (analytic test kernels)"},
        {"test.kernels", "tests/data/make_models.py"},
        {"dpc.format_version", "1"},
        {"dpc.dims", "2"},
        {"dpc.n_points", "1024"},
    };
    ASSERT_EQ(dpc_model_metadata_count(m.get()), expect.size());
    std::map<std::string, std::string> got;
    for (size_t i = 0; i < dpc_model_metadata_count(m.get()); i++) {
        const char *k = nullptr, *v = nullptr;
        ASSERT_EQ(dpc_model_metadata_at(m.get(), i, &k, &v), DPC_OK) << dpc_last_error();
        ASSERT_NE(k, nullptr);
        ASSERT_NE(v, nullptr);
        got[k] = v;
    }
    EXPECT_EQ(got, expect);
    const char *k = nullptr, *v = nullptr;
    EXPECT_EQ(dpc_model_metadata_at(m.get(), expect.size(), &k, &v), DPC_ERROR_INVALID_ARGUMENT);
    expect_message();
    EXPECT_EQ(dpc_model_metadata_at(m.get(), 0, nullptr, &v), DPC_ERROR_INVALID_ARGUMENT);
}

TEST(Metadata, UnknownKeysAreKept) {
    ModelPtr m = load(data_path("variants/extras_and_defaults.onnx"));
    ASSERT_TRUE(m);
    EXPECT_STREQ(dpc_model_metadata(m.get(), "vendor.note"), "unknown keys are kept");
    EXPECT_STREQ(dpc_model_name(m.get()), "test-10d");
}

TEST(Metadata, NameIsEmptyWithoutDpcName) {
    // malformed/ has no such file, so build one: model_2d with its dpc.name key renamed. The key
    // bytes "dpc.name" appear once in the file (inside the metadata entry); replace them with
    // "dpc.nbme", same length, so no length field changes.
    std::vector<uint8_t> bytes = read_file(model_path("model_2d"));
    ASSERT_FALSE(bytes.empty());
    const std::string key = "dpc.name";
    auto it = std::search(bytes.begin(), bytes.end(), key.begin(), key.end());
    ASSERT_NE(it, bytes.end());
    ASSERT_EQ(std::search(it + 1, bytes.end(), key.begin(), key.end()), bytes.end());
    it[5] = 'b';
    dpc_model *raw = nullptr;
    ASSERT_EQ(dpc_model_load_memory(bytes.data(), bytes.size(), nullptr, &raw), DPC_OK) << dpc_last_error();
    ModelPtr m(raw);
    ASSERT_NE(dpc_model_name(m.get()), nullptr);
    EXPECT_STREQ(dpc_model_name(m.get()), "");
    EXPECT_STREQ(dpc_model_metadata(m.get(), "dpc.nbme"), "test-2d");
}

// ---- argument checks of the generating calls -------------------------------------------------

TEST(Generate, NullArguments) {
    ModelPtr m = load(model_path("model_2d"));
    ASSERT_TRUE(m);
    std::vector<float> out(1024 * 2 * 2);
    EXPECT_EQ(dpc_generate(nullptr, 0, out.data()), DPC_ERROR_INVALID_ARGUMENT);
    expect_message();
    EXPECT_EQ(dpc_generate(m.get(), 0, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    expect_message();
    EXPECT_EQ(dpc_generate_n(m.get(), 0, 10, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_generate_batch(nullptr, 0, 2, 0, out.data()), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_generate_batch(m.get(), 0, 2, 0, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_filter(nullptr, 10, out.data()), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_filter(m.get(), 10, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_uniform(0, 10, 2, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    expect_message();
}

TEST(Generate, ZeroCountsAreInvalid) {
    ModelPtr m = load(model_path("model_2d"));
    ASSERT_TRUE(m);
    std::vector<float> out(64, 0.5f);
    EXPECT_EQ(dpc_generate_batch(m.get(), 0, 0, 16, out.data()), DPC_ERROR_INVALID_ARGUMENT);
    expect_message();
    EXPECT_EQ(dpc_filter(m.get(), 0, out.data()), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_uniform(0, 0, 2, out.data()), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_uniform(0, 4, 0, out.data()), DPC_ERROR_INVALID_ARGUMENT);
}

TEST(Generate, TooManyPointsIsLimit) {
    ModelPtr m = load(model_path("model_2d"));
    ASSERT_TRUE(m);
    // The request must be refused before anything is written: the buffer is tiny.
    std::vector<float> out(4, 0.25f);
    EXPECT_EQ(dpc_generate_n(m.get(), 0, (size_t)DPC_MAX_POINTS + 1, out.data()), DPC_ERROR_LIMIT);
    expect_message();
    EXPECT_EQ(dpc_generate_batch(m.get(), 0, 1, (size_t)DPC_MAX_POINTS + 1, out.data()), DPC_ERROR_LIMIT);
    // count * n_points * dims overflows size_t: a limit or an out-of-range count
    dpc_status st = dpc_generate_batch(m.get(), 0, SIZE_MAX / 4, 1000, out.data());
    EXPECT_TRUE(st == DPC_ERROR_LIMIT || st == DPC_ERROR_INVALID_ARGUMENT) << dpc_status_string(st);
    for (float v : out) EXPECT_EQ(v, 0.25f);
}

TEST(Generate, GriddedModelRejectsOtherCounts) {
    ModelPtr m = load(model_path("model_grid_3to1"));
    ASSERT_TRUE(m);
    std::vector<float> out(2048 * 3, 0.25f);
    for (size_t n : {1000, 1023, 1025, 2048}) {
        dpc_status st = dpc_generate_n(m.get(), 1, n, out.data());
        EXPECT_NE(st, DPC_OK) << n << " points from a 32x32 grid";
        expect_message();
    }
    EXPECT_NE(dpc_generate_batch(m.get(), 1, 2, 512, out.data()), DPC_OK);
    EXPECT_EQ(dpc_generate_n(m.get(), 1, 1024, out.data()), DPC_OK) << dpc_last_error();
}

TEST(Filter, NonFinitePointsAreRejected) {
    ModelPtr m = load(model_path("model_2d"));
    ASSERT_TRUE(m);
    for (float bad : {NAN, INFINITY, -INFINITY}) {
        std::vector<float> pts(64 * 2);
        ASSERT_EQ(dpc_uniform(3, 64, 2, pts.data()), DPC_OK);
        pts[17] = bad;
        EXPECT_EQ(dpc_filter(m.get(), 64, pts.data()), DPC_ERROR_INVALID_ARGUMENT);
        expect_message();
    }
}

// ---- the input generator (docs/model-format.md §5) ------------------------------------------

TEST(Uniform, KnownSplitMix64Values) {
    // Seed 0: mix(0) = 0, so the stream is the classic SplitMix64 stream from state 0, whose
    // first outputs are the published 0xe220a8397b1dcdaf, 0x6e789e6aa1b965f4, 0x06c45d188009454f.
    EXPECT_EQ(stream_value(0, 0), 0xe220a8397b1dcdafull);
    EXPECT_EQ(stream_value(0, 1), 0x6e789e6aa1b965f4ull);
    EXPECT_EQ(stream_value(0, 2), 0x06c45d188009454full);
    float out[3];
    ASSERT_EQ(dpc_uniform(0, 3, 1, out), DPC_OK);
    EXPECT_EQ(out[0], (float)0xe220a8 / 16777216.0f);
    EXPECT_EQ(out[1], (float)0x6e789e / 16777216.0f);
    EXPECT_EQ(out[2], (float)0x06c45d / 16777216.0f);
}

TEST(Uniform, MatchesTheDocumentedFormula) {
    for (uint64_t seed : {1ull, 2ull, 0xDEADBEEFull, 0x8000000000000000ull, ~0ull}) {
        for (size_t dims : {1u, 2u, 3u, 10u}) {
            const size_t n = 257;
            std::vector<float> out(n * dims, -1.0f);
            ASSERT_EQ(dpc_uniform(seed, n, dims, out.data()), DPC_OK) << dpc_last_error();
            for (size_t c = 0; c < n * dims; c++) {
                ASSERT_EQ(out[c], uniform_value(seed, c)) << "seed " << seed << " value " << c;
                ASSERT_GE(out[c], 0.0f);
                ASSERT_LT(out[c], 1.0f);
            }
        }
    }
}

TEST(Uniform, HandComputedValues) {
    // (seed, index) -> top 24 bits, computed from the formula of §5 outside the test
    // (python: mix(mix(seed) + (c + 1) * 0x9E3779B97F4A7C15) >> 40).
    struct Known {
        uint64_t seed, index;
        uint32_t top24;
    };
    for (Known k : {Known{1, 0, 12578688}, Known{1, 1, 6247724}, Known{1, 7, 3119647}, Known{0xDEADBEEF, 0, 2595342},
                    Known{0xDEADBEEF, 1, 15670181}, Known{0xDEADBEEF, 7, 8394523}, Known{~0ull, 0, 10844024},
                    Known{~0ull, 1, 11830564}, Known{~0ull, 7, 12987990}}) {
        EXPECT_EQ(stream_value(k.seed, k.index) >> 40, k.top24);
        float out[8];
        ASSERT_EQ(dpc_uniform(k.seed, 8, 1, out), DPC_OK);
        EXPECT_EQ(out[k.index], (float)k.top24 / 16777216.0f) << "seed " << k.seed << " index " << k.index;
    }
}

TEST(Uniform, RowMajorLayoutDoesNotDependOnShape) {
    // value c is the c-th of the stream whatever (n_points, dims) is
    std::vector<float> a(60), b(60);
    ASSERT_EQ(dpc_uniform(42, 20, 3, a.data()), DPC_OK);
    ASSERT_EQ(dpc_uniform(42, 6, 10, b.data()), DPC_OK);
    EXPECT_EQ(a, b);
}
