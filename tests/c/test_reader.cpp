// The model reader under hostile input: every truncation of every valid test file, the
// hand-made malformed files of tests/data/malformed (with the status each must give), and
// random bit flips (fixed seed) that must never crash.
#include "test_util.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>

using namespace dpct;
namespace fs = std::filesystem;

namespace {

// Load from an exactly-sized heap copy, so that a read past the end is caught by ASan.
dpc_status load_exact(const uint8_t *data, size_t size, dpc_model **out) {
    std::unique_ptr<uint8_t[]> copy(new uint8_t[size ? size : 1]);
    if (size) std::memcpy(copy.get(), data, size);
    return dpc_model_load_memory(size ? copy.get() : nullptr, size, nullptr, out);
}

struct MalformedCase {
    std::string file, why;
    std::set<dpc_status> expected;
};

std::vector<MalformedCase> read_manifest() {
    std::vector<MalformedCase> cases;
    std::ifstream f(data_path("malformed/manifest.tsv"));
    std::string line;
    while (std::getline(f, line)) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream ss(line);
        MalformedCase c;
        std::string expected, name;
        std::getline(ss, c.file, '\t');
        std::getline(ss, expected, '\t');
        std::getline(ss, c.why);
        std::istringstream es(expected);
        while (std::getline(es, name, '|')) {
            dpc_status st;
            if (status_from_name(name, &st)) c.expected.insert(st);
            else ADD_FAILURE() << "manifest: unknown status '" << name << "' for " << c.file;
        }
        cases.push_back(c);
    }
    return cases;
}

std::string names(const std::set<dpc_status> &s) {
    std::string out;
    for (dpc_status st : s) out += (out.empty() ? "" : " or ") + std::string(dpc_status_string(st));
    return out;
}

// Exercise a model that loaded: info, metadata, a small generate (must not crash or hang).
void exercise(dpc_model *m) {
    dpc_model_info info{};
    ASSERT_EQ(dpc_model_get_info(m, &info), DPC_OK);
    ASSERT_GE(info.dims, 1u);
    ASSERT_LE(info.dims, (uint32_t)DPC_MAX_DIMS);
    for (size_t i = 0; i < dpc_model_metadata_count(m); i++) {
        const char *k, *v;
        ASSERT_EQ(dpc_model_metadata_at(m, i, &k, &v), DPC_OK);
        ASSERT_TRUE(k && v);
    }
    size_t n = info.grid_dims ? info.n_points : std::min<size_t>(info.n_points, 256);
    if (n > 4096) return; // a mutated grid could be large; keep the test fast
    std::vector<float> out(n * info.dims);
    if (dpc_generate_n(m, 9, info.grid_dims ? 0 : n, out.data()) == DPC_OK) {
        for (float v : out) ASSERT_TRUE(v >= 0.0f && v < 1.0f);
    }
}

} // namespace

// ---- truncations -----------------------------------------------------------------------------

class Truncation : public ::testing::TestWithParam<std::string> {};

TEST_P(Truncation, EveryProperPrefixIsRejected) {
    // make_models.py writes the required metadata entries last, so no proper prefix of these files
    // is a complete model: each one must give an error with a message, and never crash.
    std::vector<uint8_t> bytes = read_file(model_path(GetParam()));
    ASSERT_GT(bytes.size(), 100u);
    dpc_model *m = nullptr;
    ASSERT_EQ(load_exact(bytes.data(), bytes.size(), &m), DPC_OK) << dpc_last_error();
    dpc_model_free(m);
    size_t accepted = 0;
    for (size_t len = 0; len < bytes.size(); len++) {
        m = reinterpret_cast<dpc_model *>(0x1);
        dpc_status st = load_exact(bytes.data(), len, &m);
        if (st == DPC_OK) {
            accepted++;
            ADD_FAILURE() << "prefix of " << len << " of " << bytes.size() << " bytes was accepted";
            dpc_model_free(m);
            continue;
        }
        EXPECT_EQ(m, nullptr) << "prefix " << len;
        EXPECT_TRUE(st == DPC_ERROR_FORMAT) << "prefix " << len << ": " << dpc_status_string(st);
        EXPECT_GT(std::strlen(dpc_last_error()), 0u) << "prefix " << len << ": no message";
    }
    EXPECT_EQ(accepted, 0u);
    RecordProperty("prefixes", std::to_string(bytes.size()));
}

INSTANTIATE_TEST_SUITE_P(TestModels, Truncation, ::testing::ValuesIn(model_names()),
                         [](const ::testing::TestParamInfo<std::string> &p) { return p.param; });

// ---- hand-made malformed files ---------------------------------------------------------------

TEST(Malformed, ManifestListsEveryFile) {
    std::vector<MalformedCase> cases = read_manifest();
    ASSERT_GE(cases.size(), 50u) << "malformed/manifest.tsv missing or short";
    std::set<std::string> listed;
    for (const MalformedCase &c : cases) {
        EXPECT_TRUE(listed.insert(c.file).second) << c.file << " listed twice";
        EXPECT_FALSE(c.expected.empty()) << c.file;
        EXPECT_EQ(c.expected.count(DPC_OK), 0u) << c.file;
    }
    for (const auto &e : fs::directory_iterator(data_path("malformed")))
        if (e.path().extension() == ".onnx") {
            EXPECT_TRUE(listed.count(e.path().filename().string())) << e.path() << " is not in the manifest";
        }
}

TEST(Malformed, EveryFileGivesItsStatus) {
    std::vector<MalformedCase> cases = read_manifest();
    ASSERT_FALSE(cases.empty());
    for (const MalformedCase &c : cases) {
        SCOPED_TRACE(c.file + ": " + c.why);
        std::string path = data_path("malformed/" + c.file);
        dpc_model *m = reinterpret_cast<dpc_model *>(0x1);
        dpc_status st = dpc_model_load_file(path.c_str(), nullptr, &m);
        std::string msg = dpc_last_error();
        if (st == DPC_OK) dpc_model_free(m);
        EXPECT_TRUE(c.expected.count(st))
            << "got " << dpc_status_string(st) << " (" << msg << "), expected " << names(c.expected);
        if (st != DPC_OK) {
            EXPECT_EQ(m, nullptr);
            EXPECT_FALSE(msg.empty());
        }
        // The same bytes from memory give the same status.
        std::vector<uint8_t> bytes = read_file(path);
        m = nullptr;
        dpc_status st2 = load_exact(bytes.data(), bytes.size(), &m);
        if (st2 == DPC_OK) dpc_model_free(m);
        EXPECT_EQ(st2, st) << "load_memory and load_file disagree";
    }
}

// ---- random mutations ------------------------------------------------------------------------

TEST(Mutation, RandomBitFlipsNeverCrash) {
    // Fixed seed: the same mutants on every run. A mutant may load (a flipped kernel bit is a
    // valid model) or not; either way the library must return, and a loaded model must work.
    std::mt19937_64 rng(20191117);
    size_t loaded = 0, rejected = 0;
    std::vector<std::string> files;
    for (const std::string &n : model_names()) files.push_back(model_path(n));
    for (const std::string &f : files) {
        const std::vector<uint8_t> good = read_file(f);
        ASSERT_FALSE(good.empty()) << f;
        for (int iter = 0; iter < 250; iter++) {
            std::vector<uint8_t> b = good;
            int kind = (int)(rng() % 4);
            if (kind <= 1) { // flip 1..4 bits
                int flips = 1 + (int)(rng() % 4);
                for (int k = 0; k < flips; k++) b[rng() % b.size()] ^= (uint8_t)(1u << (rng() % 8));
            } else if (kind == 2) { // overwrite a byte (lengths, tags, digits become anything)
                b[rng() % b.size()] = (uint8_t)rng();
            } else { // delete or duplicate a short run of bytes
                size_t at = rng() % b.size(), len = 1 + rng() % 8;
                len = std::min(len, b.size() - at);
                if (rng() % 2) b.erase(b.begin() + at, b.begin() + at + len);
                else b.insert(b.begin() + at, good.begin() + at, good.begin() + at + len);
            }
            dpc_model *m = nullptr;
            dpc_status st = load_exact(b.data(), b.size(), &m);
            if (st == DPC_OK) {
                loaded++;
                exercise(m);
                dpc_model_free(m);
            } else {
                rejected++;
                EXPECT_EQ(m, nullptr);
                EXPECT_GT(std::strlen(dpc_last_error()), 0u);
                EXPECT_NE(st, DPC_ERROR_INTERNAL) << dpc_last_error();
            }
        }
    }
    std::printf("[ info ] mutants: %zu loaded, %zu rejected\n", loaded, rejected);
    EXPECT_GT(rejected, 0u);
    EXPECT_GT(loaded, 0u) << "flips inside kernel values should give loadable models";
}
