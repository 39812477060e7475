// Robustness of the loading and generation API: only regular files are opened (a
// FIFO, a directory or a device gives a status, never a hang), dpc_model_load_named, the work
// bound max_neighbours, dpc_generate_size (counts checked before a host allocates), and
// dpc_generate_ex (progress and cancellation, the same bits as dpc_generate_batch).
#include "test_util.h"

#include <atomic>
#include <chrono>
#include <cstring>
#include <thread>

#include <fcntl.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

using namespace dpct;

namespace {

std::string temp_dir() {
    char tmpl[] = "/tmp/dpc_test_robust.XXXXXX";
    const char *d = mkdtemp(tmpl);
    EXPECT_NE(d, nullptr);
    return d ? d : "/tmp";
}

// Load with a deadline: a load that blocks fails the test instead of hanging it.
dpc_status load_within(const std::string &path, double seconds, std::string *message) {
    std::atomic<bool> done{false};
    dpc_status st = DPC_ERROR_INTERNAL;
    std::string msg;
    std::thread t([&] {
        dpc_model *m = nullptr;
        st = dpc_model_load_file(path.c_str(), nullptr, &m);
        msg = dpc_last_error();
        dpc_model_free(m);
        done = true;
    });
    const auto start = std::chrono::steady_clock::now();
    while (!done && std::chrono::steady_clock::now() - start < std::chrono::duration<double>(seconds))
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    if (!done) {
        // Unblock the reader by opening the FIFO for writing, then fail.
        int fd = open(path.c_str(), O_WRONLY | O_NONBLOCK);
        t.join();
        if (fd >= 0) close(fd);
        ADD_FAILURE() << "loading " << path << " blocked for " << seconds << " s";
        return DPC_ERROR_INTERNAL;
    }
    t.join();
    *message = msg;
    return st;
}

} // namespace

TEST(OnlyRegularFiles, FifoDirectoryAndDeviceGiveAStatusAtOnce) {
    const std::string dir = temp_dir();
    const std::string fifo = dir + "/model.onnx";
    ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
    std::string msg;
    EXPECT_EQ(load_within(fifo, 2.0, &msg), DPC_ERROR_IO);
    EXPECT_NE(msg.find("a FIFO"), std::string::npos) << msg;
    EXPECT_EQ(load_within(dir, 2.0, &msg), DPC_ERROR_IO);
    EXPECT_NE(msg.find("a directory"), std::string::npos) << msg;
    EXPECT_EQ(load_within("/dev/zero", 2.0, &msg), DPC_ERROR_IO);
    EXPECT_NE(msg.find("a character device"), std::string::npos) << msg;
    EXPECT_EQ(load_within(dir + "/missing.onnx", 2.0, &msg), DPC_ERROR_IO);
    EXPECT_NE(msg.find("No such file"), std::string::npos) << msg;
    unlink(fifo.c_str());
    rmdir(dir.c_str());
}

TEST(OnlyRegularFiles, ARegularFileStillLoads) {
    std::string msg;
    EXPECT_EQ(load_within(model_path("model_2d"), 10.0, &msg), DPC_OK) << msg;
}

TEST(LoadNamed, SearchesDpcModelPathThenTheInstalledFolder) {
    const char *old = std::getenv("DPC_MODEL_PATH");
    const std::string saved = old ? old : "";
    const std::string data = data_path("");
    setenv("DPC_MODEL_PATH", ("/nonexistent:" + data).c_str(), 1);
    dpc_model *m = nullptr;
    ASSERT_EQ(dpc_model_load_named("model_2d", nullptr, &m), DPC_OK) << dpc_last_error();
    dpc_model_info info;
    ASSERT_EQ(dpc_model_get_info(m, &info), DPC_OK);
    EXPECT_EQ(info.dims, 2u);
    dpc_model_free(m);

    m = reinterpret_cast<dpc_model *>(1);
    EXPECT_EQ(dpc_model_load_named("no-such-model", nullptr, &m), DPC_ERROR_IO);
    EXPECT_EQ(m, nullptr);
    EXPECT_NE(std::string(dpc_last_error()).find("no-such-model.onnx"), std::string::npos) << dpc_last_error();
    // names never reach outside the folders
    for (const char *bad : {"", "../model_2d", "a/b", ".hidden", "model 2d", "x\\y"}) {
        EXPECT_EQ(dpc_model_load_named(bad, nullptr, &m), DPC_ERROR_INVALID_ARGUMENT) << bad;
        EXPECT_EQ(m, nullptr);
    }
    EXPECT_EQ(dpc_model_load_named(std::string(256, 'a').c_str(), nullptr, &m), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_model_load_named(nullptr, nullptr, &m), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_model_load_named("model_2d", nullptr, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    if (old) setenv("DPC_MODEL_PATH", saved.c_str(), 1);
    else unsetenv("DPC_MODEL_PATH");
    EXPECT_NE(dpc_model_dir(), nullptr);
}

// The one model search (dpc_model_find; dpc.load and the Mitsuba plugin use it): regular files
// only, so a FIFO, a folder or a dangling name on DPC_MODEL_PATH is skipped, never opened.
TEST(ModelFind, SkipsEverythingButRegularFilesWithoutOpeningThem) {
    const char *old = std::getenv("DPC_MODEL_PATH");
    const std::string saved = old ? old : "";
    const std::string dir = temp_dir(), data = data_path("");
    const std::string fifo = dir + "/model_2d.onnx", folder = dir + "/model_3d_proj.onnx";
    ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
    ASSERT_EQ(mkdir(folder.c_str(), 0700), 0);
    ASSERT_EQ(symlink((dir + "/nowhere.onnx").c_str(), (dir + "/model_10d.onnx").c_str()), 0);
    setenv("DPC_MODEL_PATH", (dir + ":" + data).c_str(), 1);
    char path[DPC_PATH_MAX];
    const auto start = std::chrono::steady_clock::now();
    for (const char *name : {"model_2d", "model_3d_proj", "model_10d"}) {
        ASSERT_EQ(dpc_model_find(name, path, sizeof path), DPC_OK) << name << ": " << dpc_last_error();
        EXPECT_EQ(std::string(path), data + "/" + name + ".onnx");
    }
    dpc_model *m = nullptr;
    ASSERT_EQ(dpc_model_load_named("model_2d", nullptr, &m), DPC_OK) << dpc_last_error(); // past the FIFO
    dpc_model_free(m);
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);

    setenv("DPC_MODEL_PATH", dir.c_str(), 1); // the FIFO alone: not found, and no hang
    std::string msg;
    EXPECT_EQ(load_within(fifo, 2.0, &msg), DPC_ERROR_IO);
    EXPECT_EQ(dpc_model_find("model_2d", path, sizeof path), DPC_ERROR_IO); // no bundled model has that name
    EXPECT_STREQ(path, "");
    EXPECT_NE(std::string(dpc_last_error()).find("no regular file model_2d.onnx"), std::string::npos)
        << dpc_last_error();
    { // the message lists the models the search could find: the FIFO, the folder and the dangling link are none
        const std::string msg = dpc_last_error(), marker = "; models there: ";
        const size_t at = msg.find(marker);
        ASSERT_NE(at, std::string::npos) << msg;
        const std::string listed = msg.substr(at + marker.size());
        for (const char *skipped : {"model_2d", "model_3d_proj", "model_10d"})
            EXPECT_EQ(listed.find(skipped), std::string::npos) << skipped << " in " << msg;
    }
    EXPECT_EQ(dpc_model_find("no-such-model", path, sizeof path), DPC_ERROR_IO);
    EXPECT_STREQ(path, "");
    setenv("DPC_MODEL_PATH", (dir + ":" + data).c_str(), 1); // the test models listed, sorted, each once
    EXPECT_EQ(dpc_model_find("no-such-model", path, sizeof path), DPC_ERROR_IO);
    {
        const std::string msg = dpc_last_error();
        const size_t a = msg.find("model_10d, "), b = msg.find("model_2d, "), c = msg.find("model_3d_proj");
        EXPECT_TRUE(a != std::string::npos && b != std::string::npos && c != std::string::npos && a < b && b < c)
            << msg;
        EXPECT_EQ(msg.find("model_2d, ", b + 1), std::string::npos) << msg; // once, though two folders were read
    }

    setenv("DPC_MODEL_PATH", data.c_str(), 1);
    char small[8] = "x";
    EXPECT_EQ(dpc_model_find("model_2d", small, sizeof small), DPC_ERROR_LIMIT);
    EXPECT_STREQ(small, "");
    EXPECT_NE(std::string(dpc_last_error()).find("DPC_PATH_MAX"), std::string::npos) << dpc_last_error();
    const size_t need = data.size() + std::strlen("/model_2d.onnx") + 1;
    std::vector<char> exact(need);
    EXPECT_EQ(dpc_model_find("model_2d", exact.data(), need), DPC_OK) << dpc_last_error();
    EXPECT_EQ(dpc_model_find("model_2d", exact.data(), need - 1), DPC_ERROR_LIMIT);
    for (const char *bad : {"", "../model_2d", "a/b", ".hidden", "model 2d", "model_2d.onnx/x"})
        EXPECT_EQ(dpc_model_find(bad, path, sizeof path), DPC_ERROR_INVALID_ARGUMENT) << bad;
    EXPECT_EQ(dpc_model_find(nullptr, path, sizeof path), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_model_find("model_2d", nullptr, 10), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_model_find("model_2d", path, 0), DPC_ERROR_INVALID_ARGUMENT);

    if (old) setenv("DPC_MODEL_PATH", saved.c_str(), 1);
    else unsetenv("DPC_MODEL_PATH");
    unlink(fifo.c_str());
    unlink((dir + "/model_10d.onnx").c_str());
    rmdir(folder.c_str());
    rmdir(dir.c_str());
}

TEST(WorkBound, MaxNeighboursIsCheckedAtEveryRequestedCount) {
    // model_2d's largest radius is 4 spacings in 2-D: pi * 16 = 50.3 neighbours per point.
    ModelPtr plain = load(model_path("model_2d"));
    double nb = 0;
    ASSERT_EQ(dpc_model_neighbours(plain.get(), &nb), DPC_OK);
    EXPECT_NEAR(nb, 3.14159265358979 * 16.0, 1e-9);

    dpc_load_options o;
    dpc_load_options_init(&o);
    EXPECT_EQ(o.max_neighbours, DPC_DEFAULT_MAX_NEIGHBOURS);
    o.max_neighbours = 40.0;
    dpc_model *m = nullptr;
    ASSERT_EQ(dpc_model_load_file(model_path("model_2d").c_str(), &o, &m), DPC_OK) << dpc_last_error();
    ModelPtr bounded(m);
    dpc_model_info info;
    ASSERT_EQ(dpc_model_get_info(m, &info), DPC_OK);
    std::vector<float> out(dpc_output_size(m, 2, 0));
    EXPECT_EQ(dpc_generate(m, 1, out.data()), DPC_ERROR_LIMIT);
    EXPECT_NE(std::string(dpc_last_error()).find("max_neighbours"), std::string::npos) << dpc_last_error();
    EXPECT_EQ(dpc_generate_batch(m, 1, 2, 0, out.data()), DPC_ERROR_LIMIT);
    EXPECT_EQ(dpc_filter(m, info.n_points, out.data()), DPC_ERROR_LIMIT);
    size_t floats = 7;
    EXPECT_EQ(dpc_generate_size(m, 1, 0, &floats), DPC_ERROR_LIMIT);
    EXPECT_EQ(floats, 0u);
    // 30 points: at most 29 neighbours, within the bound; the same bits as the unbounded handle
    std::vector<float> a(30 * 2), b(30 * 2);
    ASSERT_EQ(dpc_generate_n(m, 5, 30, a.data()), DPC_OK) << dpc_last_error();
    ASSERT_EQ(dpc_generate_n(plain.get(), 5, 30, b.data()), DPC_OK);
    EXPECT_EQ(a, b);

    o.max_neighbours = INFINITY;
    ASSERT_EQ(dpc_model_load_file(model_path("model_2d").c_str(), &o, &m), DPC_OK);
    EXPECT_EQ(dpc_generate(m, 1, out.data()), DPC_OK);
    dpc_model_free(m);
    for (double bad : {0.0, -1.0, (double)NAN}) {
        o.max_neighbours = bad;
        EXPECT_EQ(dpc_model_load_file(model_path("model_2d").c_str(), &o, &m), DPC_ERROR_INVALID_ARGUMENT) << bad;
        EXPECT_EQ(m, nullptr);
    }
    // a caller compiled before the field: the default bound
    dpc_load_options_init(&o);
    o.struct_size = offsetof(dpc_load_options, max_neighbours);
    o.max_neighbours = 1.0; /* not part of the old struct: ignored */
    ASSERT_EQ(dpc_model_load_file(model_path("model_2d").c_str(), &o, &m), DPC_OK) << dpc_last_error();
    EXPECT_EQ(dpc_generate(m, 1, out.data()), DPC_OK);
    dpc_model_free(m);
}

TEST(GenerateSize, ChecksLikeGenerateBatch) {
    ModelPtr m = load(model_path("model_3d_proj"));
    dpc_model_info info;
    ASSERT_EQ(dpc_model_get_info(m.get(), &info), DPC_OK);
    size_t floats = 0;
    ASSERT_EQ(dpc_generate_size(m.get(), 3, 0, &floats), DPC_OK);
    EXPECT_EQ(floats, 3u * info.n_points * info.dims);
    EXPECT_EQ(floats, dpc_output_size(m.get(), 3, 0));
    ASSERT_EQ(dpc_generate_size(m.get(), 2, 100, &floats), DPC_OK);
    EXPECT_EQ(floats, 2u * 100 * 3);
    EXPECT_EQ(dpc_generate_size(m.get(), 0, 100, &floats), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_generate_size(m.get(), 1, (size_t)DPC_MAX_POINTS + 1, &floats), DPC_ERROR_LIMIT);
    EXPECT_EQ(dpc_generate_size(m.get(), SIZE_MAX / 4, 1000, &floats), DPC_ERROR_LIMIT);
    EXPECT_NE(std::string(dpc_last_error()).find("overflows"), std::string::npos);
    EXPECT_EQ(dpc_generate_size(nullptr, 1, 1, &floats), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_generate_size(m.get(), 1, 1, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    ModelPtr grid = load(model_path("model_grid_3to1"));
    EXPECT_EQ(dpc_generate_size(grid.get(), 1, 7, &floats), DPC_ERROR_INVALID_ARGUMENT);
}

namespace {
struct Calls {
    std::vector<std::pair<uint64_t, uint64_t>> seen;
    uint64_t stop_after = UINT64_MAX; // cancel once done >= this
    std::atomic<int> inside{0};
    bool overlapped = false;
};

int record(void *user, uint64_t done, uint64_t total) {
    Calls *c = static_cast<Calls *>(user);
    if (c->inside.fetch_add(1) != 0) c->overlapped = true;
    c->seen.emplace_back(done, total);
    std::this_thread::sleep_for(std::chrono::microseconds(50));
    c->inside.fetch_sub(1);
    return done >= c->stop_after ? 1 : 0;
}
} // namespace

TEST(GenerateEx, SameBitsAsBatchAndProgressReachesTotal) {
    for (uint32_t threads : {1u, 3u}) {
        ModelPtr m = load(model_path("model_2d"), DPC_ISA_AUTO, threads);
        dpc_model_info info;
        ASSERT_EQ(dpc_model_get_info(m.get(), &info), DPC_OK);
        const size_t count = 5, n = 300;
        std::vector<float> a(count * n * 2), b(count * n * 2);
        ASSERT_EQ(dpc_generate_batch(m.get(), 77, count, n, a.data()), DPC_OK);
        Calls calls;
        dpc_generate_options o;
        dpc_generate_options_init(&o);
        o.progress = record;
        o.user = &calls;
        ASSERT_EQ(dpc_generate_ex(m.get(), 77, count, n, &o, b.data()), DPC_OK) << dpc_last_error();
        EXPECT_EQ(a, b) << threads;
        ASSERT_FALSE(calls.seen.empty());
        EXPECT_FALSE(calls.overlapped);
        const uint64_t total = count * info.layers;
        for (size_t i = 0; i < calls.seen.size(); i++) {
            EXPECT_EQ(calls.seen[i].second, total);
            if (i) {
                EXPECT_GE(calls.seen[i].first, calls.seen[i - 1].first); // polls repeat `done`
            }
        }
        EXPECT_EQ(calls.seen.back().first, total);
        EXPECT_EQ(calls.seen.front().first, 0u); // called before the first set
        // NULL options and no callback: plain dpc_generate_batch
        ASSERT_EQ(dpc_generate_ex(m.get(), 77, count, n, nullptr, b.data()), DPC_OK);
        EXPECT_EQ(a, b);
    }
}

TEST(GenerateEx, CancelStopsWithCancelled) {
    for (uint32_t threads : {1u, 2u}) {
        ModelPtr m = load(model_path("model_2d"), DPC_ISA_AUTO, threads);
        const size_t count = 40, n = 200;
        std::vector<float> out(count * n * 2);
        Calls calls;
        calls.stop_after = 1; // the first report of finished work asks to stop
        dpc_generate_options o;
        dpc_generate_options_init(&o);
        o.progress = record;
        o.user = &calls;
        EXPECT_EQ(dpc_generate_ex(m.get(), 1, count, n, &o, out.data()), DPC_ERROR_CANCELLED);
        EXPECT_NE(std::string(dpc_last_error()).find("cancelled"), std::string::npos) << dpc_last_error();
        ASSERT_FALSE(calls.seen.empty());
        size_t first_stop = 0;
        while (first_stop < calls.seen.size() && calls.seen[first_stop].first < 1) first_stop++;
        EXPECT_EQ(first_stop + 1, calls.seen.size()) << "no call after the callback said stop";
        EXPECT_LT(calls.seen.back().first, calls.seen.back().second) << "stopped before the end";
        EXPECT_STREQ(dpc_status_string(DPC_ERROR_CANCELLED), "DPC_ERROR_CANCELLED");
    }
    ModelPtr m = load(model_path("model_2d"));
    dpc_generate_options o;
    dpc_generate_options_init(&o);
    o.struct_size = 4;
    std::vector<float> out(1024 * 2);
    EXPECT_EQ(dpc_generate_ex(m.get(), 1, 1, 0, &o, out.data()), DPC_ERROR_INVALID_ARGUMENT);
}
