// The subspace plan (libdpc/src/model/plan.h) and the thread helper (common/threads.h), below the
// public API. The plan replaced three hand-kept copies (the CPU engine's float32 parameters and
// grid choice, the Vulkan host code's, the float64 training kernels'): each copy, as it was
// written before, is kept here as the reference, and the plan must reproduce its numbers
// exactly over a sweep of point counts, subspace sizes, radii and cutoffs.
#include <atomic>
#include <cmath>
#include <cstring>
#include <random>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

extern "C" {
#include "common/threads.h"
#include "model/plan.h"
}

namespace {

// ---- the copies the plan replaced (as they were) ----------------------------------------------

// cpu_cascade.c plan_grid (float r of the engine; ws->cell_cap = 2m + 64).
int old_cpu_grid(unsigned k, float radius, size_t m, uint32_t *Go, uint32_t *Ro) {
    if (k > 4 || m < 64) return 0;
    const double r = radius;
    const double reach = k <= 2 ? 2.0 : 1.0;
    const double margin = 1e-3;
    double G = floor(reach / (r * (1.0 + margin)));
    const double cap = floor(pow(2.0 * (double)m, 1.0 / k) + 1e-9);
    if (G > cap) G = cap;
    if (G > 16384) G = 16384;
    if (G < 3) return 0;
    const double R = ceil(r * G + margin);
    if (2 * R + 1 > G) return 0;
    if (pow((2 * R + 1) / G, k) > 0.5) return 0;
    double rows = 2 * pow(2 * R + 1, k - 1);
    if (rows > 512 || pow(G, k) > (double)(2 * m + 64)) return 0;
    *Go = (uint32_t)G;
    *Ro = (uint32_t)R;
    return 1;
}

// vk_engine.c plan_subspace (float r; no range or cell guard).
int old_vk_grid(unsigned k, float r, size_t m, uint32_t *G_out, uint32_t *R_out) {
    if (k > 4 || m < 64) return 0;
    const double reach = k <= 2 ? 2.0 : 1.0, margin = 1e-3;
    double G = floor(reach / ((double)r * (1.0 + margin)));
    const double cap = floor(pow(2.0 * (double)m, 1.0 / k) + 1e-9);
    if (G > cap) G = cap;
    if (G > 16384) G = 16384;
    if (G < 3) return 0;
    const double R = ceil((double)r * G + margin);
    if (2 * R + 1 > G) return 0;
    if (pow((2 * R + 1) / G, k) > 0.5) return 0;
    *G_out = (uint32_t)G;
    *R_out = (uint32_t)R;
    return 1;
}

// cpu_layer_train.c plan_grid (double r; range guard, no cell guard).
int old_train_grid(unsigned k, double r, size_t m, uint32_t *Go, uint32_t *Ro) {
    if (k > 4 || m < 64) return 0;
    const double reach = k <= 2 ? 2.0 : 1.0;
    const double margin = 1e-3;
    double G = floor(reach / (r * (1.0 + margin)));
    const double cap = floor(pow(2.0 * (double)m, 1.0 / k) + 1e-9);
    if (G > cap) G = cap;
    if (G > 16384) G = 16384;
    if (G < 3) return 0;
    const double R = ceil(r * G + margin);
    if (2 * R + 1 > G) return 0;
    if (pow((2 * R + 1) / G, k) > 0.5) return 0;
    if (2 * pow(2 * R + 1, k - 1) > 512) return 0;
    *Go = (uint32_t)G;
    *Ro = (uint32_t)R;
    return 1;
}

uint32_t bits(float v) {
    uint32_t u;
    std::memcpy(&u, &v, sizeof u);
    return u;
}
uint64_t bits(double v) {
    uint64_t u;
    std::memcpy(&u, &v, sizeof u);
    return u;
}

std::vector<size_t> point_counts() {
    std::vector<size_t> ms;
    for (size_t m = 1; m < 3000; m++) ms.push_back(m);
    for (size_t g = 3; g < 2000; g++) /* near perfect powers, where the cell cap is decided */
        for (unsigned k = 1; k <= 4; k++) {
            const double p = std::pow((double)g, (double)k) / 2.0;
            if (p > (double)DPC_MAX_POINTS) continue;
            for (long d = -1; d <= 1; d++) ms.push_back((size_t)std::max(1.0, std::floor(p) + (double)d));
        }
    std::mt19937_64 gen(7);
    std::uniform_int_distribution<size_t> u(64, DPC_MAX_POINTS);
    for (int i = 0; i < 3000; i++) ms.push_back(u(gen));
    return ms;
}

} // namespace

TEST(Plan, ReproducesTheCopiesItReplaced) {
    const float rhos[] = {0.25f, 0.5f, 1.0f, 1.5f, 2.0f, 2.5f, 3.0f, 4.0f, 6.0f, 8.0f, 20.0f, 1e6f};
    const float epss[] = {0.0f, 1e-4f, 0.2f};
    const uint64_t masks[] = {0x1, 0x3, 0x5, 0x7, 0xF, 0x1F, 0x3FF};
    const uint32_t bins_list[] = {2, 16, 32};
    size_t grids = 0, pairs = 0;
    for (size_t m : point_counts()) {
        for (uint64_t mask : masks) {
            const unsigned k = (unsigned)__builtin_popcountll(mask);
            for (float rho : rhos) {
                const float eps = epss[m % 3];
                const uint32_t b = bins_list[m % 3];
                // the CPU engine and the Vulkan host code (float32, cpu_cascade.c run_layer)
                const float h = (float)pow((double)m, -1.0 / k);
                float r = rho * h;
                const float radius = r < 0.5f ? r : 0.5f;
                const float cutoff = eps * h;
                const float scale = (float)(b - 1) / radius;
                dpc_sub_plan f;
                dpc_plan_subspace(mask, 0, rho, eps, b, m, DPC_PLAN_F32, &f);
                ASSERT_EQ(f.k, k);
                ASSERT_EQ(bits((float)f.h), bits(h));
                ASSERT_EQ(bits((float)f.r), bits(radius)) << m << " " << k << " " << rho;
                ASSERT_EQ(bits((float)f.e), bits(cutoff));
                ASSERT_EQ(bits((float)f.scale), bits(scale));
                ASSERT_EQ((double)(float)f.r, f.r) << "a float32 plan holds float32 values";
                ASSERT_EQ(f.umax, (double)(b - 1));
                ASSERT_EQ(f.qmax, (int32_t)b - 2);
                uint32_t G = 0, R = 0, G2 = 0, R2 = 0;
                const int cpu = old_cpu_grid(k, radius, m, &G, &R);
                ASSERT_EQ(f.grid, cpu) << m << " " << k << " " << rho;
                ASSERT_EQ(old_vk_grid(k, radius, m, &G2, &R2), cpu);
                if (cpu) {
                    ASSERT_EQ(f.G, G);
                    ASSERT_EQ(f.R, R);
                    ASSERT_EQ(G2, G);
                    ASSERT_EQ(R2, R);
                }
                // the training kernels (float64, cpu_layer_train.c plan_init)
                const double rd = (double)rho;
                const double hd = pow((double)m, -1.0 / k);
                const double rr = rd * hd < 0.5 ? rd * hd : 0.5;
                dpc_sub_plan d;
                dpc_plan_subspace(mask, 0, rd, (double)eps, b, m, DPC_PLAN_F64, &d);
                ASSERT_EQ(bits(d.h), bits(hd));
                ASSERT_EQ(bits(d.r), bits(rr));
                ASSERT_EQ(bits(d.e), bits((double)eps * hd));
                ASSERT_EQ(bits(d.scale), bits((double)(b - 1) / rr));
                const int train = old_train_grid(k, rr, m, &G, &R);
                ASSERT_EQ(d.grid, train) << m << " " << k << " " << rho;
                if (train) {
                    ASSERT_EQ(d.G, G);
                    ASSERT_EQ(d.R, R);
                }
                (f.grid ? grids : pairs)++;
            }
        }
    }
    EXPECT_GT(grids, 10000u);
    EXPECT_GT(pairs, 10000u);
}

TEST(Plan, MovesAndCounts) {
    dpc_sub_plan p;
    dpc_plan_subspace(0b101, 0b101, 2.0, 0.0, 8, 100, DPC_PLAN_F32, &p);
    EXPECT_EQ(p.k, 2u);
    EXPECT_EQ(p.dim[0], 0u);
    EXPECT_EQ(p.dim[1], 2u);
    EXPECT_FALSE(p.moves); /* every dimension fixed: every backend skips it */
    dpc_plan_subspace(0b101, 0b001, 2.0, 0.0, 8, 100, DPC_PLAN_F64, &p);
    EXPECT_TRUE(p.moves);
    const uint64_t masks[] = {0b011, 0b110, 0b111, 0b100};
    unsigned count[3];
    dpc_plan_counts(3, 4, masks, 0b010, count);
    EXPECT_EQ(count[0], 2u);
    EXPECT_EQ(count[1], 0u); /* fixed */
    EXPECT_EQ(count[2], 3u);
    dpc_plan_subspace(0b11, 0, 1e6, 0.0, 8, 10, DPC_PLAN_F32, &p);
    EXPECT_EQ(p.r, 0.5); /* r = min(rho h, 1/2) */
    EXPECT_FALSE(p.grid);
}

TEST(Threads, EverySlotAndEveryIndexOnce) {
    EXPECT_GE(dpc_threads_resolve(0), 1u);
    EXPECT_LE(dpc_threads_resolve(0), DPC_MAX_THREADS);
    EXPECT_EQ(dpc_threads_resolve(1), 1u);
    EXPECT_EQ(dpc_threads_resolve(7), 7u);
    EXPECT_EQ(dpc_threads_resolve(1000), DPC_MAX_THREADS);
    for (unsigned T : {0u, 1u, 2u, 3u, 8u, 64u, 100u}) {
        std::vector<std::atomic<int>> slots(DPC_MAX_THREADS);
        dpc_run_workers(
            T, [](void *ctx, unsigned slot) { (*static_cast<std::vector<std::atomic<int>> *>(ctx))[slot]++; }, &slots);
        const unsigned want = T == 0 ? 1 : T > DPC_MAX_THREADS ? DPC_MAX_THREADS : T;
        for (unsigned s = 0; s < DPC_MAX_THREADS; s++) EXPECT_EQ(slots[s].load(), s < want ? 1 : 0) << T << " " << s;
        for (size_t n : {0ul, 1ul, 5ul, 63ul, 1000ul}) {
            std::vector<std::atomic<int>> seen(n);
            dpc_parallel_ranges(
                T, n,
                [](void *ctx, unsigned, size_t lo, size_t hi) {
                    for (size_t i = lo; i < hi; i++) (*static_cast<std::vector<std::atomic<int>> *>(ctx))[i]++;
                },
                &seen);
            for (size_t i = 0; i < n; i++) EXPECT_EQ(seen[i].load(), 1) << T << " " << n << " " << i;
        }
    }
}

// The worker pool (common/threads.c) behind both calls: callers on several threads at once (all
// but one get threads of their own), a worker that forks again (nested), and many calls in a
// row: every slot and index exactly once, every time.
namespace {
using Counts = std::vector<std::atomic<int>>;
bool ranges_once(unsigned T, size_t n) {
    Counts seen(n);
    dpc_parallel_ranges(
        T, n,
        [](void *ctx, unsigned, size_t lo, size_t hi) {
            for (size_t i = lo; i < hi; i++) (*static_cast<Counts *>(ctx))[i]++;
        },
        &seen);
    for (size_t i = 0; i < n; i++)
        if (seen[i].load() != 1) return false;
    return true;
}
} // namespace

TEST(Threads, PoolServesConcurrentAndNestedCallers) {
    std::atomic<int> bad{0};
    std::vector<std::thread> callers;
    for (int c = 0; c < 4; c++)
        callers.emplace_back([&bad, c] {
            for (int round = 0; round < 200; round++)
                if (!ranges_once(2 + (unsigned)(c + round) % 3, 1000 + (size_t)round)) bad++;
        });
    for (auto &t : callers) t.join();
    EXPECT_EQ(bad.load(), 0);
    // nested: each of 3 slots forks 2 more
    std::atomic<int> inner_bad{0};
    dpc_run_workers(
        3,
        [](void *ctx, unsigned) {
            if (!ranges_once(2, 777)) (*static_cast<std::atomic<int> *>(ctx))++;
        },
        &inner_bad);
    EXPECT_EQ(inner_bad.load(), 0);
}

TEST(WorkerPool, AForkedChildStartsAFreshPool) { // not under TSan (its name): TSan refuses threads after fork
    ASSERT_TRUE(ranges_once(3, 500));            // the parent's pool is up
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) _exit(ranges_once(3, 500) && ranges_once(2, 64) ? 0 : 1);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
    EXPECT_TRUE(ranges_once(3, 500)); // and the parent's still works
}
