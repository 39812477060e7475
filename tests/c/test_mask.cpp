// dpc_mask_design (docs/masks.md, "Annealed masks"): options and errors, rank-exact layout,
// the same bits on every machine, progress and cancellation, concurrent designs. Quality against
// void-and-cluster and STBN is measured by the Python tests and models/mask_report.py.
#include <dpc/dpc.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

namespace {

dpc_mask_options options(uint32_t size, uint32_t frames = 1, uint32_t channels = 1, uint32_t steps = 600) {
    dpc_mask_options o;
    dpc_mask_options_init(&o);
    o.size = size, o.frames = frames, o.channels = channels, o.steps_per_pixel = steps;
    return o;
}

std::vector<uint32_t> design(const dpc_mask_options &o, uint64_t seed, dpc_mask_stats *stats = nullptr) {
    size_t count = 0;
    EXPECT_EQ(dpc_mask_count(&o, &count), DPC_OK) << dpc_last_error();
    std::vector<uint32_t> out(count);
    EXPECT_EQ(dpc_mask_design(&o, seed, out.data(), stats), DPC_OK) << dpc_last_error();
    return out;
}

uint64_t fnv1a(const std::vector<uint32_t> &v) {
    uint64_t h = 1469598103934665603ull;
    for (uint32_t x : v)
        for (int b = 0; b < 4; b++) h = (h ^ ((x >> (8 * b)) & 0xFF)) * 1099511628211ull;
    return h;
}

} // namespace

TEST(MaskOptions, Defaults) {
    dpc_mask_options o;
    dpc_mask_options_init(&o);
    EXPECT_EQ(o.struct_size, sizeof o);
    EXPECT_EQ(o.size, 64u);
    EXPECT_EQ(o.frames, 1u);
    EXPECT_EQ(o.channels, 1u);
    EXPECT_EQ(o.steps_per_pixel, 600u);
    EXPECT_EQ(o.progress, nullptr);
    size_t count = 0;
    ASSERT_EQ(dpc_mask_count(&o, &count), DPC_OK);
    EXPECT_EQ(count, 64u * 64u);
    o = options(32, 16);
    ASSERT_EQ(dpc_mask_count(&o, &count), DPC_OK);
    EXPECT_EQ(count, 16u * 32u * 32u);
    o = options(32, 1, 2);
    ASSERT_EQ(dpc_mask_count(&o, &count), DPC_OK);
    EXPECT_EQ(count, 2u * 32u * 32u);
}

TEST(MaskOptions, BadOptionsGetAStatusAndAMessage) {
    uint32_t out[64];
    size_t count = 7;
    EXPECT_EQ(dpc_mask_count(nullptr, &count), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(count, 0u);
    dpc_mask_options good = options(8);
    EXPECT_EQ(dpc_mask_count(&good, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_mask_design(nullptr, 0, out, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_mask_design(&good, 0, nullptr, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(dpc_last_error()).find("out_ranks"), std::string::npos);
    struct Case {
        dpc_mask_options o;
        const char *says;
    };
    dpc_mask_options stale = good;
    stale.struct_size = 4;
    const Case cases[] = {{stale, "struct_size"},          {options(7), "size"},
                          {options(1025), "size"},         {options(16, 0), "frames"},
                          {options(16, 1025), "frames"},   {options(16, 1, 0), "channels"},
                          {options(16, 1, 3), "channels"}, {options(16, 2, 2), "not both"}};
    for (const Case &c : cases) {
        EXPECT_EQ(dpc_mask_count(&c.o, &count), DPC_ERROR_INVALID_ARGUMENT) << c.says;
        EXPECT_NE(std::string(dpc_last_error()).find(c.says), std::string::npos) << dpc_last_error();
        EXPECT_EQ(dpc_mask_design(&c.o, 0, out, nullptr), DPC_ERROR_INVALID_ARGUMENT) << c.says;
    }
    // 512 x 512 x 64 frames needs 12.6 GiB of spectra: refused before anything is allocated
    const dpc_mask_options big = options(512, 64);
    EXPECT_EQ(dpc_mask_count(&big, &count), DPC_ERROR_LIMIT);
    EXPECT_NE(std::string(dpc_last_error()).find("GiB"), std::string::npos) << dpc_last_error();
    EXPECT_EQ(dpc_mask_design(&big, 0, out, nullptr), DPC_ERROR_LIMIT);
    EXPECT_EQ(dpc_mask_design(&good, 0, out, nullptr), DPC_OK);
    EXPECT_STREQ(dpc_last_error(), "");
}

TEST(MaskDesign, EveryFrameAndChannelHoldsEveryRankOnce) {
    for (const dpc_mask_options &o : {options(16), options(16, 4), options(16, 1, 2), options(12, 3)}) {
        dpc_mask_stats stats{};
        const std::vector<uint32_t> r = design(o, 3, &stats);
        const size_t s = size_t(o.size) * o.size;
        for (uint32_t f = 0; f < o.frames; f++)
            for (uint32_t c = 0; c < o.channels; c++) {
                std::vector<uint32_t> plane;
                for (size_t p = 0; p < s; p++) plane.push_back(r[(f * s + p) * o.channels + c]);
                std::sort(plane.begin(), plane.end());
                for (size_t k = 0; k < s; k++) ASSERT_EQ(plane[k], k) << o.size << " " << o.frames << " " << o.channels;
            }
        EXPECT_GT(stats.accepted, 1000u);
        EXPECT_LT(stats.energy_end, stats.energy_start);
    }
}

TEST(MaskDesign, TheSameBitsOnEveryMachine) {
    // Made on an AMD EPYC (AVX2); tests/python/test_mask_design.py pins the same designs. Plain
    // double arithmetic in a fixed order with libdpc's own exp, sin and cos: any machine and
    // compiler must agree.
    EXPECT_EQ(fnv1a(design(options(16), 7)), 0x569f6c2bb3db1e03ull);
    EXPECT_EQ(fnv1a(design(options(16, 4), 7)), 0x48da11cd78315073ull);
    EXPECT_EQ(fnv1a(design(options(16, 1, 2), 7)), 0xdfb987c37164d843ull);
    EXPECT_EQ(design(options(16), 7), design(options(16), 7));
    EXPECT_NE(design(options(16), 7), design(options(16), 8));
    const std::vector<uint32_t> v = design(options(16, 1, 2), 7);
    bool channels_differ = false;
    for (size_t p = 0; p < 256; p++) channels_differ |= v[2 * p] != v[2 * p + 1];
    EXPECT_TRUE(channels_differ);
}

TEST(MaskDesign, StepsZeroIsTheVoidAndClusterStart) {
    dpc_mask_stats start{}, full{};
    dpc_mask_options zero = options(16, 1, 1, 0);
    zero.progress = [](void *, uint64_t done, uint64_t total) -> int {
        EXPECT_EQ(done, 0u); // polls of the start only: no proposals to report
        EXPECT_EQ(total, 1u);
        return 0;
    };
    const std::vector<uint32_t> a = design(zero, 2, &start);
    design(options(16), 2, &full);
    EXPECT_EQ(start.accepted, 0u);
    EXPECT_EQ(start.energy_start, start.energy_end);
    EXPECT_EQ(start.energy_start, full.energy_start); // the annealer starts from it
    EXPECT_EQ(a, design(options(16, 1, 1, 0), 2));
}

namespace {
struct Progress {
    uint64_t calls = 0, last_done = 0, total = 0;
    uint64_t stop_after = UINT64_MAX;
};
int on_progress(void *user, uint64_t done, uint64_t total) {
    Progress *p = static_cast<Progress *>(user);
    EXPECT_GE(done, p->last_done);
    p->calls++, p->last_done = done, p->total = total;
    return p->calls > p->stop_after ? 1 : 0;
}
} // namespace

TEST(MaskDesign, ProgressReportsEveryProposalAndCancels) {
    dpc_mask_options o = options(16, 4);
    Progress p;
    o.progress = on_progress;
    o.user = &p;
    const std::vector<uint32_t> with = design(o, 1);
    EXPECT_EQ(p.total, 600ull * 256 * 4);
    EXPECT_EQ(p.last_done, p.total);
    EXPECT_GE(p.calls, p.total / 65536);
    EXPECT_EQ(with, design(options(16, 4), 1)); // the callback changes nothing
    Progress stop;
    stop.stop_after = 2;
    o.user = &stop;
    std::vector<uint32_t> out(4 * 256);
    EXPECT_EQ(dpc_mask_design(&o, 1, out.data(), nullptr), DPC_ERROR_CANCELLED);
    EXPECT_NE(std::string(dpc_last_error()).find("cancel"), std::string::npos);
    EXPECT_EQ(stop.calls, 3u);
}

TEST(MaskThreads, ConcurrentDesignsMatchSerialOnes) {
    const std::vector<uint32_t> a = design(options(16), 11), b = design(options(16, 1, 2), 12);
    std::vector<uint32_t> ta, tb;
    std::thread t1([&] { ta = design(options(16), 11); });
    std::thread t2([&] { tb = design(options(16, 1, 2), 12); });
    t1.join(), t2.join();
    EXPECT_EQ(ta, a);
    EXPECT_EQ(tb, b);
}

// The void-and-cluster start (O(N^4), minutes at 512 x 512) polls the callback too: a cancel is
// seen within milliseconds, before any proposal.
TEST(MaskDesign, CancelDuringTheVoidAndClusterStartIsPrompt) {
    struct Stop {
        std::chrono::steady_clock::time_point start, stopped;
        bool stop = false, proposals = false;
        int calls_after_stop = 0;
    } st;
    dpc_mask_options o = options(256, 1, 1, 0);
    o.user = &st;
    o.progress = [](void *user, uint64_t done, uint64_t total) -> int {
        Stop *s = static_cast<Stop *>(user);
        s->proposals |= done != 0 || total != 1;
        if (s->stop) s->calls_after_stop++; // a callback that asked to stop is not called again
        if (!s->stop && std::chrono::steady_clock::now() - s->start > std::chrono::milliseconds(200)) {
            s->stop = true;
            s->stopped = std::chrono::steady_clock::now();
        }
        return s->stop ? 1 : 0;
    };
    std::vector<uint32_t> out(256 * 256);
    st.start = std::chrono::steady_clock::now();
    EXPECT_EQ(dpc_mask_design(&o, 3, out.data(), nullptr), DPC_ERROR_CANCELLED);
    ASSERT_TRUE(st.stop);
    EXPECT_FALSE(st.proposals);
    EXPECT_EQ(st.calls_after_stop, 0);
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - st.stopped).count(), 0.5);
    EXPECT_NE(std::string(dpc_last_error()).find("cancel"), std::string::npos) << dpc_last_error();
}
