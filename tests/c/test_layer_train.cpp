// The float64 training kernels of one filter layer (dpc_layer_forward / dpc_layer_backward) from
// C: argument checking and limits (NULLs the Python bindings cannot pass), a two-point layer
// worked out by hand (across the torus seam too), in-place calls, and bit-identical results for
// any thread count on the chunk-parallel, set-parallel, all-pairs and many-subspace paths, for
// every ISA path (DPC_ISA); each vector path against the scalar one to 1e-12 relative on grid,
// all-pairs (3-D .. 10-D), subspace, fixed-dimension and generic-size layers.
// Public header dpc/dpc.h only. Gradients against finite differences: tests/python/test_layer_grad.py.
#include "test_util.h"

#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

namespace {

// A layer description that owns its arrays (desc() points into them, so copies stay valid).
struct Layer {
    uint32_t dims, bins;
    std::vector<uint64_t> masks;
    std::vector<double> radius;
    double eps;
    uint64_t fixed;
    Layer(uint32_t n, std::vector<uint64_t> m, std::vector<double> r, uint32_t b, double e = 1e-4, uint64_t f = 0)
        : dims(n), bins(b), masks(std::move(m)), radius(std::move(r)), eps(e), fixed(f) {}
    dpc_layer_desc desc() const {
        dpc_layer_desc d{};
        d.dims = dims;
        d.n_subspaces = static_cast<uint32_t>(masks.size());
        d.bins = bins;
        d.subspaces = masks.data();
        d.radius = radius.data();
        d.eps = eps;
        d.fixed = fixed;
        return d;
    }
};

std::vector<double> uniform(size_t count, uint64_t seed, double lo = 0.0, double hi = 1.0) {
    std::mt19937_64 gen(seed);
    std::uniform_real_distribution<double> u(lo, hi);
    std::vector<double> v(count);
    for (double &x : v) x = u(gen);
    return v;
}

// DPC_ISA for the scope (the training kernels read it on every call); restored to "" (auto).
struct IsaScope {
    explicit IsaScope(dpc_isa isa) { setenv("DPC_ISA", dpct::isa_name(isa).c_str(), 1); }
    ~IsaScope() { setenv("DPC_ISA", "", 1); }
};

std::vector<dpc_isa> all_isas() {
    std::vector<dpc_isa> v = {DPC_ISA_SCALAR};
    for (dpc_isa isa : dpct::vector_isas()) v.push_back(isa);
    return v;
}

void expect_failure(dpc_status got, dpc_status want, const char *needle) {
    EXPECT_EQ(got, want) << dpc_last_error();
    EXPECT_NE(std::strstr(dpc_last_error(), needle), nullptr) << "message: " << dpc_last_error();
}

} // namespace

TEST(LayerTrain, RejectsBadArguments) {
    Layer L(2, {3}, {3.0}, 8);
    std::vector<double> w(8, 0.0), x = uniform(20, 1), y(20), g(20, 0.0), gx(20), gk(8);
    const dpc_layer_desc good = L.desc();
    auto fwd = [&](const dpc_layer_desc *d, size_t count, size_t m) {
        return dpc_layer_forward(d, w.data(), count, m, x.data(), y.data(), 1);
    };
    auto bwd = [&](const dpc_layer_desc *d, size_t count, size_t m) {
        return dpc_layer_backward(d, w.data(), count, m, x.data(), g.data(), gx.data(), gk.data(), 1);
    };
    expect_failure(fwd(nullptr, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "layer is NULL");
    expect_failure(dpc_layer_forward(&good, nullptr, 1, 10, x.data(), y.data(), 1), DPC_ERROR_INVALID_ARGUMENT, "NULL");
    expect_failure(dpc_layer_forward(&good, w.data(), 1, 10, nullptr, y.data(), 1), DPC_ERROR_INVALID_ARGUMENT, "NULL");
    expect_failure(dpc_layer_forward(&good, w.data(), 1, 10, x.data(), nullptr, 1), DPC_ERROR_INVALID_ARGUMENT,
                   "y is NULL");
    expect_failure(dpc_layer_backward(&good, w.data(), 1, 10, x.data(), nullptr, gx.data(), gk.data(), 1),
                   DPC_ERROR_INVALID_ARGUMENT, "NULL");
    expect_failure(dpc_layer_backward(&good, w.data(), 1, 10, x.data(), g.data(), nullptr, gk.data(), 1),
                   DPC_ERROR_INVALID_ARGUMENT, "NULL");
    expect_failure(dpc_layer_backward(&good, w.data(), 1, 10, x.data(), g.data(), gx.data(), nullptr, 1),
                   DPC_ERROR_INVALID_ARGUMENT, "NULL");

    dpc_layer_desc d = good;
    d.dims = 0;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "dims");
    d = good, d.dims = 65;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "dims");
    d = good, d.n_subspaces = 0;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "subspaces");
    d = good, d.n_subspaces = 65;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "subspaces");
    d = good, d.bins = 1;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "bins");
    d = good, d.bins = 65537;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "bins");
    d = good, d.subspaces = nullptr;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "NULL");
    d = good, d.radius = nullptr;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "NULL");
    const uint64_t bad_mask = 4, zero_mask = 0;
    d = good, d.subspaces = &bad_mask;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "dimensions < 2");
    d = good, d.subspaces = &zero_mask;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "nonzero");
    const uint64_t twice[2] = {1, 1};
    const double radii[2] = {3.0, 3.0};
    std::vector<double> w2(16, 0.0);
    d = good, d.n_subspaces = 2, d.subspaces = twice, d.radius = radii;
    expect_failure(dpc_layer_forward(&d, w2.data(), 1, 10, x.data(), y.data(), 1), DPC_ERROR_INVALID_ARGUMENT, "equal");
    for (double rho : {0.0, -1.0, 2e6, HUGE_VAL, std::nan("")}) {
        d = good, d.radius = &rho;
        expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "radius");
    }
    for (double eps : {-1e-9, HUGE_VAL, std::nan("")}) {
        d = good, d.eps = eps;
        expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "eps");
    }
    d = good, d.fixed = 4;
    expect_failure(fwd(&d, 1, 10), DPC_ERROR_INVALID_ARGUMENT, "fixed");
    expect_failure(fwd(&good, 0, 10), DPC_ERROR_INVALID_ARGUMENT, "positive");
    expect_failure(fwd(&good, 1, 0), DPC_ERROR_INVALID_ARGUMENT, "positive");
    // Limits are checked before any point is read (the buffers here are tiny).
    expect_failure(fwd(&good, 1, (size_t)DPC_MAX_POINTS + 1), DPC_ERROR_LIMIT, "at most");
    d = good, d.dims = 5, d.subspaces = &good.subspaces[0];
    expect_failure(fwd(&d, 1, DPC_MAX_POINTS), DPC_ERROR_LIMIT, "2^28");
    expect_failure(fwd(&good, SIZE_MAX / 4, 10), DPC_ERROR_LIMIT, "overflows");

    std::vector<double> bad = x;
    bad[13] = 1.0;
    expect_failure(dpc_layer_forward(&good, w.data(), 1, 10, bad.data(), y.data(), 1), DPC_ERROR_INVALID_ARGUMENT,
                   "point 6, dimension 1 is 1");
    bad[13] = std::nan("");
    expect_failure(dpc_layer_forward(&good, w.data(), 1, 10, bad.data(), y.data(), 1), DPC_ERROR_INVALID_ARGUMENT,
                   "[0, 1)");
    std::vector<double> wbad = w;
    wbad[5] = HUGE_VAL;
    expect_failure(dpc_layer_forward(&good, wbad.data(), 1, 10, x.data(), y.data(), 1), DPC_ERROR_INVALID_ARGUMENT,
                   "bin 5");
    std::vector<double> gbad = g;
    gbad[3] = std::nan("");
    expect_failure(dpc_layer_backward(&good, w.data(), 1, 10, x.data(), gbad.data(), gx.data(), gk.data(), 1),
                   DPC_ERROR_INVALID_ARGUMENT, "grad_y");
    EXPECT_EQ(bwd(&good, 1, 10), DPC_OK);
    EXPECT_STREQ(dpc_last_error(), "");
}

// Two points in 1-D, m = 2: h = 1/2, r = min(0.8 h, 1/2) = 0.4, b = 3, kernel (0, 0.1, 0).
// At distance 0.25: u = 0.25 * 2 / 0.4 = 1.25, q = 1, f = 0.25, g = 0.075, g' = -0.1 * 2 / 0.4.
// The pair attracts: each point moves h g = 0.0375 towards the other. With G = (1, 0):
// v = (h, 0), dy0/dx0 = 1 - h g' = 1.25, dy0/dx1 = h g' = -0.25, and with n = +-1 the direction
// from x0 to x1 on the torus, dL/dw = n h (0, 1 - f, f).
TEST(LayerTrain, TwoPointsByHand) {
    const Layer L(1, {1}, {0.8}, 3, 0.0);
    const dpc_layer_desc d = L.desc();
    const double w[3] = {0.0, 0.1, 0.0};
    struct Case {
        double x0, x1, y0, y1, dir;
    };
    for (const Case &c : {Case{0.1, 0.35, 0.1375, 0.3125, 1.0},     // x1 to the right
                          Case{0.35, 0.1, 0.3125, 0.1375, -1.0},    // to the left
                          Case{0.95, 0.2, 0.9875, 0.1625, 1.0},     // to the right across the seam
                          Case{0.2, 0.95, 0.1625, 0.9875, -1.0},    // to the left across the seam
                          Case{0.98, 0.23, 0.0175, 0.1925, 1.0}}) { // and y0 wraps past 1
        const double x[2] = {c.x0, c.x1}, G[2] = {1.0, 0.0};
        double y[2], gx[2], gk[3];
        ASSERT_EQ(dpc_layer_forward(&d, w, 1, 2, x, y, 1), DPC_OK) << dpc_last_error();
        EXPECT_NEAR(y[0], c.y0, 1e-15) << c.x0 << " " << c.x1;
        EXPECT_NEAR(y[1], c.y1, 1e-15) << c.x0 << " " << c.x1;
        ASSERT_EQ(dpc_layer_backward(&d, w, 1, 2, x, G, gx, gk, 1), DPC_OK) << dpc_last_error();
        EXPECT_NEAR(gx[0], 1.25, 1e-14);
        EXPECT_NEAR(gx[1], -0.25, 1e-14);
        EXPECT_EQ(gk[0], 0.0);
        EXPECT_NEAR(gk[1], c.dir * 0.375, 1e-14);
        EXPECT_NEAR(gk[2], c.dir * 0.125, 1e-14);
    }
}

TEST(LayerTrain, InPlaceAndZeroKernels) {
    const Layer L(3, {7, 4}, {2.0, 3.0}, 16);
    const dpc_layer_desc d = L.desc();
    const size_t m = 500, total = m * 3;
    std::vector<double> w = uniform(32, 3, -0.05, 0.05), x = uniform(total, 4), g = uniform(total, 5, -1, 1);
    std::vector<double> y(total), gx(total), gk(32), gk2(32);
    ASSERT_EQ(dpc_layer_forward(&d, w.data(), 1, m, x.data(), y.data(), 1), DPC_OK);
    ASSERT_EQ(dpc_layer_backward(&d, w.data(), 1, m, x.data(), g.data(), gx.data(), gk.data(), 1), DPC_OK);
    std::vector<double> inplace = x;
    ASSERT_EQ(dpc_layer_forward(&d, w.data(), 1, m, inplace.data(), inplace.data(), 1), DPC_OK);
    EXPECT_EQ(0, std::memcmp(inplace.data(), y.data(), total * sizeof(double)));
    std::vector<double> ginplace = g;
    ASSERT_EQ(dpc_layer_backward(&d, w.data(), 1, m, x.data(), ginplace.data(), ginplace.data(), gk2.data(), 1),
              DPC_OK);
    EXPECT_EQ(0, std::memcmp(ginplace.data(), gx.data(), total * sizeof(double)));
    EXPECT_EQ(0, std::memcmp(gk2.data(), gk.data(), 32 * sizeof(double)));

    std::vector<double> zero(32, 0.0);
    ASSERT_EQ(dpc_layer_forward(&d, zero.data(), 1, m, x.data(), y.data(), 1), DPC_OK);
    EXPECT_EQ(0, std::memcmp(x.data(), y.data(), total * sizeof(double)));
    ASSERT_EQ(dpc_layer_backward(&d, zero.data(), 1, m, x.data(), g.data(), gx.data(), gk.data(), 1), DPC_OK);
    EXPECT_EQ(0, std::memcmp(g.data(), gx.data(), total * sizeof(double)));
}

// Bits for threads 1, 3 and 0 (one per CPU) on each scheduling path, for every ISA path.
TEST(LayerTrain, ThreadCountDoesNotChangeBits) {
    struct Case {
        Layer layer;
        size_t count, m;
        bool vector_only = false; /* too slow for the scalar path, whose scheduling is covered above */
    };
    std::vector<uint64_t> many;
    std::vector<double> many_r;
    for (uint64_t mask = 1; mask <= 64; mask++) many.push_back(mask), many_r.push_back(1.0 + 0.03 * (double)mask);
    std::vector<Case> cases = {
        {Layer(2, {3}, {3.0}, 32), 1, 12000},                        // one big set: chunks over threads
        {Layer(3, {3, 5, 6, 4}, {2.0, 2.0, 2.0, 4.0}, 32), 2, 9000}, // fewer sets than threads
        {Layer(3, {7, 4}, {2.0, 3.0}, 16, 1e-4, 1), 4, 700},         // sets over threads, a fixed dim
        {Layer(5, {31, 1}, {1.5, 3.0}, 8), 3, 400},                  // 5-D: all pairs, generic K
        {Layer(7, many, many_r, 4), 2, 300},                         // 64 subspaces
        {Layer(4, {15}, {2.0}, 32), 1, 9000, true},                  // 4-D all pairs, chunks over threads
        {Layer(10, {1023}, {1.0}, 32), 3, 1001},                     // 10-D all pairs, m not a multiple of 8
    };
    for (dpc_isa isa : all_isas())
        for (const Case &c : cases) {
            if (c.vector_only && isa == DPC_ISA_SCALAR) continue;
            SCOPED_TRACE(dpct::isa_name(isa));
            const IsaScope scope(isa);
            const dpc_layer_desc d = c.layer.desc();
            const size_t n = d.dims, total = c.count * c.m * n, sb = (size_t)d.n_subspaces * d.bins;
            std::vector<double> w = uniform(sb, 7, -0.05, 0.05), x = uniform(total, 8), g = uniform(total, 9, -1, 1);
            std::vector<double> y1(total), gx1(total), gk1(sb);
            ASSERT_EQ(dpc_layer_forward(&d, w.data(), c.count, c.m, x.data(), y1.data(), 1), DPC_OK);
            ASSERT_EQ(dpc_layer_backward(&d, w.data(), c.count, c.m, x.data(), g.data(), gx1.data(), gk1.data(), 1),
                      DPC_OK);
            EXPECT_NE(0, std::memcmp(x.data(), y1.data(), total * sizeof(double))) << "the layer moved nothing";
            for (uint32_t threads : {3u, 0u}) {
                std::vector<double> y(total), gx(total), gk(sb);
                ASSERT_EQ(dpc_layer_forward(&d, w.data(), c.count, c.m, x.data(), y.data(), threads), DPC_OK);
                ASSERT_EQ(
                    dpc_layer_backward(&d, w.data(), c.count, c.m, x.data(), g.data(), gx.data(), gk.data(), threads),
                    DPC_OK);
                EXPECT_EQ(0, std::memcmp(y.data(), y1.data(), total * sizeof(double)))
                    << "dims " << n << " threads " << threads;
                EXPECT_EQ(0, std::memcmp(gx.data(), gx1.data(), total * sizeof(double))) << "dims " << n;
                EXPECT_EQ(0, std::memcmp(gk.data(), gk1.data(), sb * sizeof(double))) << "dims " << n;
            }
        }
}

namespace {

// Largest |a - b| over max |b|, where the values are displacements a = y - x on the torus (or
// gradient terms): the scale is that of what the pairs contributed.
double rel_err(const std::vector<double> &a, const std::vector<double> &b, const std::vector<double> &base,
               bool torus) {
    double err = 0.0, scale = 0.0;
    for (size_t i = 0; i < a.size(); i++) {
        double da = a[i] - base[i], db = b[i] - base[i];
        if (torus) da -= std::rint(da), db -= std::rint(db);
        err = std::max(err, std::fabs(da - db));
        scale = std::max(scale, std::fabs(db));
    }
    return scale > 0.0 ? err / scale : err;
}

} // namespace

// Each vector path against the scalar path: forward displacements, grad_x pair terms and the
// kernel gradient to 1e-12 relative, on grid and all-pairs layers of 1 .. 10 dimensions, several
// subspaces, fixed dimensions, a generic subspace size (7), tails (m not a multiple of 8),
// duplicate points with eps = 0, and points on the torus seam.
TEST(LayerTrain, VectorPathsMatchScalar) {
    const std::vector<dpc_isa> isas = dpct::vector_isas();
    if (isas.empty()) GTEST_SKIP() << "no vector ISA on this CPU";
    struct Case {
        const char *name;
        Layer layer;
        size_t count, m;
    };
    const std::vector<Case> cases = {
        {"2d_grid", Layer(2, {3}, {4.0}, 32), 2, 1024},
        {"1d_grid", Layer(1, {1}, {3.0}, 16), 2, 999},
        {"3d_grid", Layer(3, {7}, {2.5}, 32), 2, 1024},
        {"3d_subspaces", Layer(3, {3, 5, 6, 4}, {2.0, 2.5, 3.0, 4.0}, 24), 2, 777},
        {"4d_all_pairs", Layer(4, {15}, {2.0}, 32), 2, 1024},
        {"5d_all_pairs", Layer(5, {31}, {2.0}, 32), 2, 701},
        {"7d_generic", Layer(7, {127, 3}, {1.5, 3.0}, 20), 2, 513},
        {"10d_all_pairs", Layer(10, {1023}, {1.0}, 32), 2, 1024},
        {"10d_large_radius", Layer(10, {1023, 0x3e0}, {3.0, 2.0}, 32), 1, 333},
        {"fixed_dims", Layer(4, {15, 12}, {2.0, 3.0}, 16, 1e-4, 3), 2, 600},
        {"eps0_duplicates", Layer(3, {7}, {3.0}, 8, 0.0), 2, 400},
    };
    for (const Case &c : cases) {
        SCOPED_TRACE(c.name);
        const dpc_layer_desc d = c.layer.desc();
        const size_t n = d.dims, total = c.count * c.m * n, sb = (size_t)d.n_subspaces * d.bins;
        std::vector<double> w = uniform(sb, 17, -0.05, 0.05), x = uniform(total, 18), g = uniform(total, 19, -1, 1);
        for (size_t i = 0; i < 6 && i < c.m; i++) // the seam: near 0 and near 1 in every dimension
            for (size_t k = 0; k < n; k++) x[i * n + k] = i % 2 ? 1.0 - 1e-9 * (double)(i + 1) : 1e-9 * (double)i;
        for (size_t i = c.m / 2; i < c.m / 2 + 3; i++) // duplicates: d = 0 is never a pair
            for (size_t k = 0; k < n; k++) x[i * n + k] = x[(c.m / 3) * n + k];
        std::vector<double> y0(total), gx0(total), gk0(sb);
        {
            const IsaScope scope(DPC_ISA_SCALAR);
            ASSERT_EQ(dpc_layer_forward(&d, w.data(), c.count, c.m, x.data(), y0.data(), 1), DPC_OK)
                << dpc_last_error();
            ASSERT_EQ(dpc_layer_backward(&d, w.data(), c.count, c.m, x.data(), g.data(), gx0.data(), gk0.data(), 1),
                      DPC_OK);
        }
        ASSERT_GT(rel_err(x, y0, x, true), 0.0);
        double moved = 0.0;
        for (size_t i = 0; i < total; i++) moved = std::max(moved, std::fabs(std::remainder(y0[i] - x[i], 1.0)));
        EXPECT_GT(moved, 1e-6) << "the layer barely moved the points: a vacuous comparison";
        const std::vector<double> zero(sb, 0.0);
        for (dpc_isa isa : isas) {
            SCOPED_TRACE(dpct::isa_name(isa));
            const IsaScope scope(isa);
            std::vector<double> y(total), gx(total), gk(sb);
            ASSERT_EQ(dpc_layer_forward(&d, w.data(), c.count, c.m, x.data(), y.data(), 2), DPC_OK) << dpc_last_error();
            ASSERT_EQ(dpc_layer_backward(&d, w.data(), c.count, c.m, x.data(), g.data(), gx.data(), gk.data(), 2),
                      DPC_OK);
            // Displacements y - x, relative to the largest one.
            std::vector<double> disp(total), disp0(total);
            double scale = 0.0, err = 0.0;
            for (size_t i = 0; i < total; i++) {
                disp[i] = std::remainder(y[i] - x[i], 1.0);
                disp0[i] = std::remainder(y0[i] - x[i], 1.0);
                scale = std::max(scale, std::fabs(disp0[i]));
                err = std::max(err, std::fabs(disp[i] - disp0[i]));
            }
            EXPECT_LE(err, 1e-12 * scale) << "forward";
            EXPECT_LE(rel_err(gx, gx0, g, false), 1e-12) << "grad_x";
            EXPECT_LE(rel_err(gk, gk0, zero, false), 1e-12) << "grad_kernels";
            for (size_t i = 0; i < total; i++) { // fixed dimensions never move, on any path
                if (d.fixed >> (i % n) & 1) {
                    ASSERT_EQ(y[i], x[i]);
                }
            }
        }
    }
}

// The all-pairs filter of the vector paths works on float32 copies of the coordinates: pairs at
// d = r (1 - 1e-12), at d = 1e-9 with eps = 0 (distinct in double, equal in float) and across the
// seam from a coordinate that rounds to 1.0f must all still interact, as on the scalar path.
TEST(LayerTrain, VectorFilterKeepsEdgePairs) {
    const std::vector<dpc_isa> isas = dpct::vector_isas();
    if (isas.empty()) GTEST_SKIP() << "no vector ISA on this CPU";
    for (uint32_t k : {4u, 10u}) {
        SCOPED_TRACE(k);
        const double rho = k == 4 ? 2.0 : 0.8;
        const Layer L(k, {(1ull << k) - 1}, {rho}, 16, 0.0);
        const dpc_layer_desc d = L.desc();
        const size_t m = 256, total = m * k;
        const double r = std::min(rho * std::pow((double)m, -1.0 / k), 0.5);
        std::vector<double> w = uniform(16, 31, 0.5, 1.0), x = uniform(total, 32, 0.0, 1.0),
                            g = uniform(total, 33, -1, 1);
        std::mt19937_64 gen(34);
        std::normal_distribution<double> normal;
        // Pairs (2i, 2i+1) for i < 20: partner at r (1 - 1e-12), at 1e-9, or across the seam.
        for (size_t i = 0; i < 20; i++) {
            double *a = &x[2 * i * k], *b = &x[(2 * i + 1) * k];
            std::vector<double> dir(k);
            double norm = 0.0;
            for (double &v : dir) v = normal(gen), norm += v * v;
            const double len = i % 3 == 1 ? 1e-9 : r * (1.0 - 1e-12);
            if (i % 3 == 2) a[0] = 1.0 - 1e-9; // rounds to 1.0f
            for (size_t q = 0; q < k; q++) {
                double v = a[q] + dir[q] / std::sqrt(norm) * len;
                b[q] = v - std::floor(v);
            }
        }
        std::vector<double> y0(total), gx0(total), gk0(16);
        {
            const IsaScope scope(DPC_ISA_SCALAR);
            ASSERT_EQ(dpc_layer_forward(&d, w.data(), 1, m, x.data(), y0.data(), 1), DPC_OK) << dpc_last_error();
            ASSERT_EQ(dpc_layer_backward(&d, w.data(), 1, m, x.data(), g.data(), gx0.data(), gk0.data(), 1), DPC_OK);
        }
        for (dpc_isa isa : isas) {
            SCOPED_TRACE(dpct::isa_name(isa));
            const IsaScope scope(isa);
            std::vector<double> y(total), gx(total), gk(16);
            ASSERT_EQ(dpc_layer_forward(&d, w.data(), 1, m, x.data(), y.data(), 1), DPC_OK);
            ASSERT_EQ(dpc_layer_backward(&d, w.data(), 1, m, x.data(), g.data(), gx.data(), gk.data(), 1), DPC_OK);
            EXPECT_LE(rel_err(y, y0, x, true), 1e-12) << "forward";
            EXPECT_LE(rel_err(gx, gx0, g, false), 1e-12) << "grad_x";
            EXPECT_LE(rel_err(gk, gk0, std::vector<double>(16, 0.0), false), 1e-12) << "grad_kernels";
        }
    }
}

// The vector paths are really taken (their lane sums round differently from the scalar
// path somewhere in a large layer), and a bad DPC_ISA is refused as for the inference engine.
TEST(LayerTrain, IsaSelection) {
    const Layer L(4, {15}, {2.0}, 32);
    const dpc_layer_desc d = L.desc();
    const size_t m = 1024, total = m * 4;
    std::vector<double> w = uniform(32, 21, -0.05, 0.05), x = uniform(total, 22), y0(total);
    {
        const IsaScope scope(DPC_ISA_SCALAR);
        ASSERT_EQ(dpc_layer_forward(&d, w.data(), 1, m, x.data(), y0.data(), 1), DPC_OK);
    }
    for (dpc_isa isa : dpct::vector_isas()) {
        const IsaScope scope(isa);
        std::vector<double> y(total);
        ASSERT_EQ(dpc_layer_forward(&d, w.data(), 1, m, x.data(), y.data(), 1), DPC_OK);
        EXPECT_NE(0, std::memcmp(y.data(), y0.data(), total * sizeof(double))) << dpct::isa_name(isa);
    }
    setenv("DPC_ISA", "sse9", 1);
    std::vector<double> y(total), gk(32);
    expect_failure(dpc_layer_forward(&d, w.data(), 1, m, x.data(), y.data(), 1), DPC_ERROR_INVALID_ARGUMENT, "DPC_ISA");
    expect_failure(dpc_layer_backward(&d, w.data(), 1, m, x.data(), x.data(), y.data(), gk.data(), 1),
                   DPC_ERROR_INVALID_ARGUMENT, "DPC_ISA");
    setenv("DPC_ISA", "", 1);
    if (!dpct::cpu_has_avx512()) {
        setenv("DPC_ISA", "avx512", 1);
        expect_failure(dpc_layer_forward(&d, w.data(), 1, m, x.data(), y.data(), 1), DPC_ERROR_UNSUPPORTED, "AVX-512");
        setenv("DPC_ISA", "", 1);
    }
}

// The ISA as an argument (dpc_layer_options.isa): the same bits as DPC_ISA naming that path,
// whatever DPC_ISA says meanwhile; AUTO follows DPC_ISA; a path the CPU lacks, an unknown
// value and a wrong struct_size are refused; dpc_layer_forward is _ex with {threads, AUTO}.
TEST(LayerTrain, IsaAsArgument) {
    const Layer L(3, {7, 3}, {2.0, 3.0}, 16, 1e-4, 4);
    const dpc_layer_desc d = L.desc();
    const size_t m = 900, count = 2, total = count * m * 3;
    const std::vector<double> w = uniform(32, 31, -0.05, 0.05), x = uniform(total, 32), g = uniform(total, 33, -1, 1);
    dpc_layer_options defaults;
    dpc_layer_options_init(&defaults);
    EXPECT_EQ(defaults.struct_size, sizeof(dpc_layer_options));
    EXPECT_EQ(defaults.threads, 1u);
    EXPECT_EQ(defaults.isa, DPC_ISA_AUTO);
    dpc_load_options load;
    dpc_load_options_init(&load);
    EXPECT_EQ(defaults.threads, load.threads) << "one default for threads";
    for (dpc_isa isa : all_isas()) {
        std::vector<double> y_env(total), gx_env(total), gk_env(16 * 2);
        {
            const IsaScope scope(isa);
            ASSERT_EQ(dpc_layer_forward(&d, w.data(), count, m, x.data(), y_env.data(), 2), DPC_OK);
            ASSERT_EQ(dpc_layer_backward(&d, w.data(), count, m, x.data(), g.data(), gx_env.data(), gk_env.data(), 2),
                      DPC_OK);
        }
        for (dpc_isa other : all_isas()) { /* the argument wins over DPC_ISA */
            const IsaScope scope(other);
            dpc_layer_options o;
            dpc_layer_options_init(&o);
            o.isa = isa;
            o.threads = 3;
            std::vector<double> y(total), gx(total), gk(16 * 2);
            ASSERT_EQ(dpc_layer_forward_ex(&d, w.data(), count, m, x.data(), y.data(), &o), DPC_OK);
            ASSERT_EQ(dpc_layer_backward_ex(&d, w.data(), count, m, x.data(), g.data(), gx.data(), gk.data(), &o),
                      DPC_OK);
            EXPECT_EQ(0, std::memcmp(y.data(), y_env.data(), total * sizeof(double))) << dpct::isa_name(isa);
            EXPECT_EQ(0, std::memcmp(gx.data(), gx_env.data(), total * sizeof(double))) << dpct::isa_name(isa);
            EXPECT_EQ(0, std::memcmp(gk.data(), gk_env.data(), gk.size() * sizeof(double))) << dpct::isa_name(isa);
        }
    }
    std::vector<double> y(total), y1(total);
    ASSERT_EQ(dpc_layer_forward_ex(&d, w.data(), count, m, x.data(), y.data(), nullptr), DPC_OK); /* defaults */
    ASSERT_EQ(dpc_layer_forward(&d, w.data(), count, m, x.data(), y1.data(), 1), DPC_OK);
    EXPECT_EQ(0, std::memcmp(y.data(), y1.data(), total * sizeof(double)));
    dpc_layer_options o;
    dpc_layer_options_init(&o);
    if (!dpct::cpu_has_avx512()) {
        o.isa = DPC_ISA_AVX512;
        expect_failure(dpc_layer_forward_ex(&d, w.data(), count, m, x.data(), y.data(), &o), DPC_ERROR_UNSUPPORTED,
                       "AVX-512");
    }
    o.isa = static_cast<dpc_isa>(9);
    expect_failure(dpc_layer_forward_ex(&d, w.data(), count, m, x.data(), y.data(), &o), DPC_ERROR_INVALID_ARGUMENT,
                   "options.isa");
    dpc_layer_options_init(&o);
    o.struct_size = 4;
    expect_failure(dpc_layer_forward_ex(&d, w.data(), count, m, x.data(), y.data(), &o), DPC_ERROR_INVALID_ARGUMENT,
                   "struct_size");
    std::vector<double> gx(total), gk(32);
    expect_failure(dpc_layer_backward_ex(&d, w.data(), count, m, x.data(), g.data(), gx.data(), gk.data(), &o),
                   DPC_ERROR_INVALID_ARGUMENT, "struct_size");
}
