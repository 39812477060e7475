// The sampler (dpc_sampler_*): options and errors, range, determinism across objects, threads and
// the model handle's ISA (tables come from the pinned scalar path), the tables being the models'
// sets with stratified projections, and each pixel's values being its table shifted.
// tests/python/test_sampler.py checks every lookup bit for bit against a transcription of the
// definition (docs/rendering.md).
#include "test_util.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <functional>
#include <thread>

using namespace dpct;

namespace {

struct SamplerDeleter {
    void operator()(dpc_sampler *s) const { dpc_sampler_free(s); }
};
using SamplerPtr = std::unique_ptr<dpc_sampler, SamplerDeleter>;

SamplerPtr make(const std::vector<const dpc_model *> &models, uint32_t spp, uint32_t dims, uint64_t seed,
                uint32_t fold_from = 1, uint32_t net_dims = 1) {
    dpc_sampler_options o;
    dpc_sampler_options_init(&o);
    o.models = models.data();
    o.n_models = (uint32_t)models.size();
    o.samples_per_pixel = spp;
    o.dimensions = dims;
    o.seed = seed;
    o.fold_from = fold_from;
    o.net_dims = net_dims;
    dpc_sampler *s = nullptr;
    EXPECT_EQ(dpc_sampler_create(&o, &s), DPC_OK) << dpc_last_error();
    return SamplerPtr(s);
}

std::vector<float> table_of(const dpc_sampler *s, uint32_t t, uint32_t spp) {
    const float *p = nullptr;
    EXPECT_EQ(dpc_sampler_table(s, t, &p), DPC_OK) << dpc_last_error();
    return p ? std::vector<float>(p, p + 2 * spp) : std::vector<float>();
}

} // namespace

TEST(SamplerOptions, InitSetsDocumentedDefaults) {
    dpc_sampler_options o;
    std::memset(&o, 0xAB, sizeof o);
    dpc_sampler_options_init(&o);
    EXPECT_EQ(o.struct_size, sizeof o);
    EXPECT_EQ(o.models, nullptr);
    EXPECT_EQ(o.n_models, 0u);
    EXPECT_EQ(o.samples_per_pixel, 16u);
    EXPECT_EQ(o.dimensions, 16u);
    EXPECT_EQ(o.fold_from, DPC_SAMPLER_NO_FOLD);
    EXPECT_EQ(o.net_dims, DPC_SAMPLER_NET_DIMS_AUTO);
    EXPECT_EQ(o.seed, 0u);
    dpc_sampler_options_init(nullptr); // no-op
}

TEST(SamplerOptions, BadOptionsAreStatusesWithAMessage) {
    ModelPtr m2 = load(model_path("model_2d")), grid = load(model_path("model_grid_3to1"));
    const dpc_model *one[1] = {m2.get()}, *none[1] = {nullptr}, *gridded[1] = {grid.get()};
    dpc_sampler *s = reinterpret_cast<dpc_sampler *>(0x1);
    EXPECT_EQ(dpc_sampler_create(nullptr, &s), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(s, nullptr) << "the out handle is cleared on failure";
    dpc_sampler_options o;
    dpc_sampler_options_init(&o);
    o.models = one;
    o.n_models = 1;
    EXPECT_EQ(dpc_sampler_create(&o, nullptr), DPC_ERROR_INVALID_ARGUMENT);

    struct Case {
        const char *what;
        std::function<void(dpc_sampler_options &)> edit;
        dpc_status want;
        const char *says;
    };
    const Case cases[] = {
        {"struct size", [](dpc_sampler_options &x) { x.struct_size = 8; }, DPC_ERROR_INVALID_ARGUMENT, "struct_size"},
        {"no models", [](dpc_sampler_options &x) { x.n_models = 0; }, DPC_ERROR_INVALID_ARGUMENT, "models"},
        {"null list", [](dpc_sampler_options &x) { x.models = nullptr; }, DPC_ERROR_INVALID_ARGUMENT, "models"},
        {"null model", [&](dpc_sampler_options &x) { x.models = none; }, DPC_ERROR_INVALID_ARGUMENT, "NULL"},
        {"gridded", [&](dpc_sampler_options &x) { x.models = gridded; }, DPC_ERROR_INVALID_ARGUMENT, "gridded"},
        {"spp 0", [](dpc_sampler_options &x) { x.samples_per_pixel = 0; }, DPC_ERROR_INVALID_ARGUMENT,
         "samples_per_pixel"},
        {"spp big", [](dpc_sampler_options &x) { x.samples_per_pixel = DPC_SAMPLER_MAX_SPP + 1; },
         DPC_ERROR_INVALID_ARGUMENT, "samples_per_pixel"},
        {"dims 0", [](dpc_sampler_options &x) { x.dimensions = 0; }, DPC_ERROR_INVALID_ARGUMENT, "dimensions"},
        {"dims big", [](dpc_sampler_options &x) { x.dimensions = DPC_SAMPLER_MAX_DIMENSIONS + 1; },
         DPC_ERROR_INVALID_ARGUMENT, "dimensions"},
        {"tables too big",
         [](dpc_sampler_options &x) {
             x.samples_per_pixel = DPC_SAMPLER_MAX_SPP;
             x.dimensions = 1024;
         },
         DPC_ERROR_LIMIT, "2^24"},
    };
    for (const Case &c : cases) {
        dpc_sampler_options x = o;
        c.edit(x);
        s = reinterpret_cast<dpc_sampler *>(0x1);
        EXPECT_EQ(dpc_sampler_create(&x, &s), c.want) << c.what;
        EXPECT_EQ(s, nullptr) << c.what;
        EXPECT_NE(std::string(dpc_last_error()).find(c.says), std::string::npos) << c.what << ": " << dpc_last_error();
    }
}

TEST(SamplerLookup, NullArgumentsAreInvalidNotCrashes) {
    ModelPtr m = load(model_path("model_2d"));
    SamplerPtr s = make({m.get()}, 4, 2, 0);
    float v[2];
    EXPECT_EQ(dpc_sampler_get_2d(nullptr, 0, 0, 0, 0, v), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(dpc_last_error()).find("NULL"), std::string::npos);
    EXPECT_EQ(dpc_sampler_get_2d(s.get(), 0, 0, 0, 0, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_sampler_get_1d(nullptr, 0, 0, 0, 0, v), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_sampler_get_1d(s.get(), 0, 0, 0, 0, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    const float *t = nullptr;
    EXPECT_EQ(dpc_sampler_table(s.get(), 2, &t), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_sampler_table(nullptr, 0, &t), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_sampler_table(s.get(), 0, nullptr), DPC_ERROR_INVALID_ARGUMENT);
    dpc_sampler_free(nullptr);
    ASSERT_NE(dpc_sampler_mask(), nullptr);
}

TEST(SamplerLookup, ValuesLieInTheUnitIntervalAnywhere) {
    ModelPtr m = load(model_path("model_2d"));
    SamplerPtr s = make({m.get()}, 7, 3, 42);
    const uint32_t xs[] = {0, 1, 31, 32, 1000, 0x7FFFFFFFu, 0xFFFFFFFFu};
    const uint32_t is[] = {0, 3, 6, 7, 100, 0xFFFFFFFFu};
    const uint32_t ds[] = {0, 2, 3, 17, 0xFFFFFFFFu};
    for (uint32_t x : xs)
        for (uint32_t y : xs)
            for (uint32_t i : is)
                for (uint32_t d : ds) {
                    float v[2] = {-1, -1}, w = -1;
                    ASSERT_EQ(dpc_sampler_get_2d(s.get(), x, y, i, d, v), DPC_OK);
                    ASSERT_EQ(dpc_sampler_get_1d(s.get(), x, y, i, d, &w), DPC_OK);
                    for (float a : {v[0], v[1], w}) ASSERT_TRUE(a >= 0.0f && a < 1.0f) << a;
                }
    const float *mask = dpc_sampler_mask();
    for (int k = 0; k < 32 * 32 * 3; k++) ASSERT_TRUE(mask[k] >= 0.0f && mask[k] < 1.0f);
}

TEST(SamplerDeterminism, SameOptionsSameBitsWhateverTheModelsIsaOrThreads) {
    ModelPtr scalar = load(model_path("model_2d"), DPC_ISA_SCALAR, 1);
    ModelPtr best = load(model_path("model_2d"), DPC_ISA_AUTO, 4);
    SamplerPtr a = make({scalar.get()}, 16, 4, 9), b = make({best.get()}, 16, 4, 9),
               c = make({scalar.get()}, 16, 4, 10);
    bool differs = false;
    for (uint32_t t = 0; t < 4; t++) {
        EXPECT_EQ(table_of(a.get(), t, 16), table_of(b.get(), t, 16)) << "table " << t;
        differs |= table_of(a.get(), t, 16) != table_of(c.get(), t, 16);
    }
    EXPECT_TRUE(differs) << "another seed gives other tables";
    for (uint32_t i = 0; i < 40; i++) {
        float va[2], vb[2];
        dpc_sampler_get_2d(a.get(), i * 7, i * 3, i, i % 9, va);
        dpc_sampler_get_2d(b.get(), i * 7, i * 3, i, i % 9, vb);
        EXPECT_EQ(std::memcmp(va, vb, sizeof va), 0);
    }
}

TEST(SamplerDeterminism, TablesAreTheModelsScalarSetsWithStratifiedProjections) {
    ModelPtr m = load(model_path("model_2d"), DPC_ISA_SCALAR);
    const uint32_t n = 24;
    SamplerPtr s = make({m.get()}, n, 3, 5);
    for (uint32_t t = 0; t < 3; t++) {
        std::vector<float> tab = table_of(s.get(), t, n);
        // one value per stratum on each axis: {(r + 1/2) / n}
        for (int c = 0; c < 2; c++) {
            std::vector<float> axis;
            for (uint32_t i = 0; i < n; i++) axis.push_back(tab[2 * i + c]);
            std::sort(axis.begin(), axis.end());
            for (uint32_t r = 0; r < n; r++) EXPECT_EQ(axis[r], ((float)r + 0.5f) / (float)n);
        }
    }
    // The sets themselves: table t is the rank pattern of the scalar path's set (seed of set t).
    // (The seeds are checked end to end by the Python reference; here the rank structure.)
    std::vector<float> tab = table_of(s.get(), 0, n);
    bool all_distinct = true;
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = i + 1; j < n; j++)
            all_distinct &= !(tab[2 * i] == tab[2 * j] && tab[2 * i + 1] == tab[2 * j + 1]);
    EXPECT_TRUE(all_distinct);
}

TEST(SamplerDeterminism, ModelsMayBeFreedAfterCreate) {
    SamplerPtr s;
    std::vector<float> before;
    {
        ModelPtr m = load(model_path("model_2d"));
        s = make({m.get()}, 8, 2, 1);
        before = table_of(s.get(), 1, 8);
    }
    EXPECT_EQ(table_of(s.get(), 1, 8), before);
    float v[2];
    EXPECT_EQ(dpc_sampler_get_2d(s.get(), 3, 4, 5, 1, v), DPC_OK);
}

// The shift of pixel (x, y) in dimension d: value - table point, for the table point that
// sample 0 reads (found as the j that makes every sample a shifted table point).
// Hero-wavelength sampling (pbrt-v4, Mitsuba 3) reads a 1-D value v at v + i/4, i = 0..3: a
// pixel's n values, so shifted, lie 1/(4n) apart all around the circle (the 4n strata of a shifted
// lattice, one each).
static bool fills_hero_strata(const std::vector<float> &one, uint32_t n) {
    std::vector<double> all;
    for (float v : one)
        for (int i = 0; i < 4; i++) all.push_back(std::fmod((double)v + 0.25 * i, 1.0));
    std::sort(all.begin(), all.end());
    for (size_t i = 0; i < all.size(); i++) {
        const double gap = (i + 1 < all.size() ? all[i + 1] : all[0] + 1.0) - all[i];
        if (std::fabs(gap - 0.25 / n) > 2e-6) return false;
    }
    return true;
}

static bool shift_of(const dpc_sampler *s, const std::vector<float> &tab, uint32_t n, uint32_t x, uint32_t y,
                     uint32_t d, double out[2]) {
    float first[2];
    dpc_sampler_get_2d(s, x, y, 0, d, first);
    for (uint32_t j0 = 0; j0 < n; j0++) {
        const double sx = first[0] - tab[2 * j0], sy = first[1] - tab[2 * j0 + 1];
        bool all = true;
        for (uint32_t i = 1; i < n && all; i++) {
            float v[2];
            dpc_sampler_get_2d(s, x, y, i, d, v);
            bool hit = false;
            for (uint32_t j = 0; j < n && !hit; j++)
                hit = torus_diff(v[0], tab[2 * j] + sx) < 1e-6 && torus_diff(v[1], tab[2 * j + 1] + sy) < 1e-6;
            all = hit;
        }
        if (all) {
            out[0] = sx - std::floor(sx);
            out[1] = sy - std::floor(sy);
            return true;
        }
    }
    return false;
}

TEST(SamplerStructure, EachPixelGetsItsTableShiftedAndALattice) {
    ModelPtr m = load(model_path("model_2d"));
    const uint32_t n = 16;
    SamplerPtr s = make({m.get()}, n, 4, 3, DPC_SAMPLER_NO_FOLD, 0);
    for (uint32_t d = 0; d < 6; d++) { // d >= 4 reuses table d mod 4
        std::vector<float> tab = table_of(s.get(), d % 4, n);
        for (uint32_t p = 0; p < 5; p++) {
            const uint32_t x = p * 37 + 1, y = p * 11;
            // value i - table point j = one shift for all i
            double shift[2];
            EXPECT_TRUE(shift_of(s.get(), tab, n, x, y, d, shift))
                << "pixel (" << x << ", " << y << ") dimension " << d;
            std::vector<float> one;
            for (uint32_t i = 0; i < n; i++) {
                float w;
                dpc_sampler_get_1d(s.get(), x, y, i, d, &w);
                one.push_back(w);
            }
            EXPECT_TRUE(fills_hero_strata(one, n)) << "pixel (" << x << ", " << y << ") dimension " << d;
        }
    }
}

// The mask's offset and rotation are the 32 x 32 tile's own: two pixels of one tile keep the
// mask's difference of shifts (for some offset), and the same pixel of the next tile (32 to the
// right or below) has another shift, so tiles do not repeat each other's sets.
TEST(SamplerStructure, EachTileRotatesTheMaskItsOwnWay) {
    ModelPtr m = load(model_path("model_2d"));
    const uint32_t n = 16;
    SamplerPtr s = make({m.get()}, n, 2, 5, DPC_SAMPLER_NO_FOLD, 0);
    const float *mask = dpc_sampler_mask();
    std::vector<float> tab = table_of(s.get(), 1, n);
    for (uint32_t tile = 0; tile < 4; tile++) {
        const uint32_t bx = 32 * (tile * 7 + 1), by = 32 * (tile * 3);
        double a[2], b[2], c[2], e[2];
        ASSERT_TRUE(shift_of(s.get(), tab, n, bx + 3, by + 4, 1, a));
        ASSERT_TRUE(shift_of(s.get(), tab, n, bx + 20, by + 9, 1, b));
        ASSERT_TRUE(shift_of(s.get(), tab, n, bx + 32 + 3, by + 4, 1, c));
        ASSERT_TRUE(shift_of(s.get(), tab, n, bx + 3, by + 32 + 4, 1, e));
        // the mask moved by the key's (ox, oy) is unknown here, so compare differences over
        // all 1,024 offsets: exactly the mask's difference of some pair 17 right, 5 down apart
        bool kept = false;
        for (uint32_t o = 0; o < 1024 && !kept; o++) {
            const uint32_t ox = o % 32, oy = o / 32;
            const float *p = mask + ((oy + 4) % 32 * 32 + (ox + 3) % 32) * 3;
            const float *q = mask + ((oy + 9) % 32 * 32 + (ox + 20) % 32) * 3;
            kept = torus_diff(b[0] - a[0], q[0] - p[0]) < 1e-5 && torus_diff(b[1] - a[1], q[1] - p[1]) < 1e-5;
        }
        EXPECT_TRUE(kept) << "tile " << tile;
        EXPECT_GT(torus_diff(c[0], a[0]) + torus_diff(c[1], a[1]), 1e-4)
            << "tile " << tile << ": the tile to the right";
        EXPECT_GT(torus_diff(e[0], a[0]) + torus_diff(e[1], a[1]), 1e-4) << "tile " << tile << ": the tile below";
    }
}

// Each dyadic box of volume 2^(1-m) in [0,1)^3 holds exactly two of the n = 2^m points (x, y, z
// consecutive in pts): a (1,m,3)-net.
bool is_13_net(const std::vector<float> &pts, uint32_t m) {
    const uint32_t n = 1u << m;
    if (m == 0) return pts.size() == 3;
    for (uint32_t a1 = 0; a1 < m; a1++)
        for (uint32_t a2 = 0; a1 + a2 < m; a2++) {
            const uint32_t a3 = m - 1 - a1 - a2;
            std::vector<uint32_t> count(n / 2, 0);
            for (uint32_t i = 0; i < n; i++) {
                const uint32_t c1 = (uint32_t)(pts[3 * i] * (float)(1u << a1));
                const uint32_t c2 = (uint32_t)(pts[3 * i + 1] * (float)(1u << a2));
                const uint32_t c3 = (uint32_t)(pts[3 * i + 2] * (float)(1u << a3));
                count[(c1 << (a2 + a3)) | (c2 << a3) | c3]++;
            }
            for (uint32_t c : count)
                if (c != 2) return false;
        }
    return true;
}

// Each (0,m,2) elementary interval (2^a x 2^(m-a) boxes of a grid of 2^-m cells) holds exactly
// one of the n = 2^m points.
bool is_net(const std::vector<float> &pts, uint32_t m) {
    const uint32_t n = 1u << m;
    for (uint32_t a = 0; a <= m; a++) {
        std::vector<int> count(n, 0);
        for (uint32_t i = 0; i < n; i++) {
            const uint32_t cx = (uint32_t)(pts[2 * i] * (float)(1u << a));
            const uint32_t cy = (uint32_t)(pts[2 * i + 1] * (float)(1u << (m - a)));
            if (cx >= (1u << a) || cy >= (1u << (m - a)) || count[cx << (m - a) | cy]++) return false;
        }
    }
    return true;
}

// Net slots (net_dims): every pixel's samples of every pass are a (0,m,2)-net, also through
// dimensions past D that reuse a net slot; get_1d is in get_2d's x's stratum, or after a net slot
// one (1,m,3)-net with that slot's 2-D values, and the pixel's values fill the hero-wavelength
// strata; the table shows the cells'
// centres; other slots keep the shifted set (the same table as with net_dims = 0).
TEST(SamplerStructure, NetSlotsGiveEachPixelANet) {
    ModelPtr m = load(model_path("model_2d"));
    for (uint32_t log_n : {1u, 2u, 4u, 6u}) {
        const uint32_t n = 1u << log_n;
        SamplerPtr s = make({m.get()}, n, 3, 9, DPC_SAMPLER_NO_FOLD, 2);
        SamplerPtr plain = make({m.get()}, n, 3, 9, DPC_SAMPLER_NO_FOLD, 0);
        EXPECT_TRUE(is_net(table_of(s.get(), 0, n), log_n));
        EXPECT_TRUE(is_net(table_of(s.get(), 1, n), log_n));
        EXPECT_EQ(table_of(s.get(), 2, n), table_of(plain.get(), 2, n));
        for (uint32_t d : {0u, 1u, 3u, 4u, 70u}) // 3, 4, 70 reuse slots 0, 1, 1
            for (uint32_t pass : {0u, 2u})
                for (uint32_t p = 0; p < 4; p++) {
                    std::vector<float> pts, one, joint;
                    for (uint32_t i = pass * n; i < (pass + 1) * n; i++) {
                        float v[2], w;
                        ASSERT_EQ(dpc_sampler_get_2d(s.get(), p * 91 + 5, p * 7, i, d, v), DPC_OK);
                        ASSERT_EQ(dpc_sampler_get_1d(s.get(), p * 91 + 5, p * 7, i, d, &w), DPC_OK);
                        float prev[2];
                        if (d % 3 == 0) { // after a set slot or none: the stratum of the net point's x
                            EXPECT_EQ(std::floor(w * (float)n), std::floor(v[0] * (float)n));
                        } else { // after a net slot: one 3-D net with its 2-D values
                            ASSERT_EQ(dpc_sampler_get_2d(s.get(), p * 91 + 5, p * 7, i, d - 1, prev), DPC_OK);
                            joint.insert(joint.end(), {prev[0], prev[1], w});
                        }
                        pts.push_back(v[0]);
                        pts.push_back(v[1]);
                        one.push_back(w);
                    }
                    EXPECT_TRUE(is_net(pts, log_n)) << "n " << n << " dimension " << d << " pass " << pass;
                    EXPECT_TRUE(fills_hero_strata(one, n)) << "n " << n << " dimension " << d << " pass " << pass;
                    if (d % 3 != 0) {
                        EXPECT_TRUE(is_13_net(joint, log_n)) << "n " << n << " dimension " << d << " pass " << pass;
                    }
                }
    }
    // spp not a power of two: no nets, slot 0 is the shifted set
    SamplerPtr odd = make({m.get()}, 12, 2, 9, DPC_SAMPLER_NO_FOLD, 2);
    SamplerPtr odd_plain = make({m.get()}, 12, 2, 9, DPC_SAMPLER_NO_FOLD, 0);
    for (uint32_t i = 0; i < 12; i++) {
        float a[2], b[2];
        dpc_sampler_get_2d(odd.get(), 3, 4, i, 0, a);
        dpc_sampler_get_2d(odd_plain.get(), 3, 4, i, 0, b);
        EXPECT_EQ(a[0], b[0]);
        EXPECT_EQ(a[1], b[1]);
    }
}

// The default net_dims (DPC_SAMPLER_NET_DIMS_AUTO) is every slot for set models (from
// DPC_SAMPLER_AUTO_NETS_SPP = 2 spp on): tables and lookups equal those of the explicit count.
TEST(SamplerStructure, DefaultNetsEverySlot) {
    ModelPtr m = load(model_path("model_2d"));
    for (uint32_t n : {2u, 4u, 16u, 64u}) {
        SamplerPtr autos = make({m.get()}, n, 3, 4, 1, DPC_SAMPLER_NET_DIMS_AUTO);
        SamplerPtr all = make({m.get()}, n, 3, 4, 1, 3), one = make({m.get()}, n, 3, 4, 1, 1);
        const dpc_sampler *want = n >= DPC_SAMPLER_AUTO_NETS_SPP ? all.get() : one.get();
        EXPECT_NE(table_of(all.get(), 2, n), table_of(one.get(), 2, n));
        for (uint32_t t = 0; t < 3; t++) EXPECT_EQ(table_of(autos.get(), t, n), table_of(want, t, n)) << n << " " << t;
        for (uint32_t d = 0; d < 6; d++)
            for (uint32_t i : {0u, 5u, n + 3}) {
                float a[2], b[2];
                ASSERT_EQ(dpc_sampler_get_2d(autos.get(), 7, 40, i, d, a), DPC_OK);
                ASSERT_EQ(dpc_sampler_get_2d(want, 7, 40, i, d, b), DPC_OK);
                EXPECT_EQ(a[0], b[0]) << n << " " << d << " " << i;
                EXPECT_EQ(a[1], b[1]) << n << " " << d << " " << i;
            }
    }
}

// dpc_sampler_get_info reports the options as created, net_dims resolved: the default is every
// slot from DPC_SAMPLER_AUTO_NETS_SPP (2) on for set models and 1 for progressive models, at most D, none when spp is not a power of two >= 2. Bad calls are statuses.
TEST(SamplerInfo, ReportsTheOptionsAndTheResolvedNetSlots) {
    ModelPtr m = load(model_path("model_2d")), prog = load(model_path("model_2d_progressive"));
    struct Case {
        const dpc_model *model;
        uint32_t spp, dims, net_dims, want;
    };
    const uint32_t AUTO = DPC_SAMPLER_NET_DIMS_AUTO;
    for (const Case &c : {Case{m.get(), 16, 5, AUTO, 5}, Case{m.get(), 2, 5, AUTO, 5}, Case{m.get(), 64, 3, AUTO, 3},
                          Case{m.get(), 12, 5, AUTO, 0}, Case{m.get(), 1, 5, AUTO, 0}, Case{m.get(), 64, 8, 3, 3},
                          Case{m.get(), 64, 4, 9, 4}, Case{m.get(), 64, 4, 0, 0}, Case{prog.get(), 64, 4, AUTO, 1},
                          Case{prog.get(), 32, 4, 2, 2}}) {
        SamplerPtr s = make({c.model}, c.spp, c.dims, 99, 2, c.net_dims);
        dpc_sampler_info info;
        std::memset(&info, 0xAB, sizeof info);
        info.struct_size = sizeof info;
        ASSERT_EQ(dpc_sampler_get_info(s.get(), &info), DPC_OK) << dpc_last_error();
        EXPECT_EQ(info.struct_size, sizeof info);
        EXPECT_EQ(info.samples_per_pixel, c.spp);
        EXPECT_EQ(info.dimensions, c.dims);
        EXPECT_EQ(info.fold_from, 2u);
        EXPECT_EQ(info.net_slots, c.want) << c.spp << " " << c.dims << " " << c.net_dims;
        EXPECT_EQ(info.progressive, c.model == prog.get() ? 1u : 0u);
        EXPECT_EQ(info.seed, 99u);
        // the default layout: screen-ordered nets below DPC_SAMPLER_SCREEN_NETS_BELOW spp
        const bool screen = c.want > 0 && c.spp < DPC_SAMPLER_SCREEN_NETS_BELOW;
        EXPECT_EQ(info.net_layout, screen ? DPC_SAMPLER_NETS_SCREEN : DPC_SAMPLER_NETS_PER_PIXEL) << c.spp;
    }
    SamplerPtr s = make({m.get()}, 16, 2, 0);
    dpc_sampler_info info;
    // a caller built before net_layout: accepted, the field left alone
    std::memset(&info, 0xAB, sizeof info);
    info.struct_size = (uint32_t)offsetof(dpc_sampler_info, net_layout);
    ASSERT_EQ(dpc_sampler_get_info(s.get(), &info), DPC_OK) << dpc_last_error();
    EXPECT_EQ(info.samples_per_pixel, 16u);
    EXPECT_EQ(info.net_layout, 0xABABABABu);
    info.struct_size = sizeof info - 4;
    EXPECT_EQ(dpc_sampler_get_info(s.get(), &info), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(dpc_last_error()).find("struct_size"), std::string::npos) << dpc_last_error();
    info.struct_size = sizeof info;
    EXPECT_EQ(dpc_sampler_get_info(nullptr, &info), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_sampler_get_info(s.get(), nullptr), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(dpc_sampler_get_info(s.get(), &info), DPC_OK);
    EXPECT_STREQ(dpc_last_error(), "");
}

// Dimensions >= fold_from give the baker's transform of the unfolded value, on every path (the
// precomputed first 64 dimensions, later passes, dimensions past them), in [0, 1).
TEST(SamplerStructure, FoldedDimensionsAreTheBakerTransformOfTheUnfolded) {
    ModelPtr m = load(model_path("model_2d"));
    SamplerPtr plain = make({m.get()}, 8, 70, 5, DPC_SAMPLER_NO_FOLD);
    SamplerPtr folded = make({m.get()}, 8, 70, 5, 2);
    auto fold = [](float v) { return v < 0.5f ? 2.0f * v : 2.0f * (1.0f - v) - 0x1p-24f; };
    for (uint32_t d : {0u, 1u, 2u, 3u, 63u, 64u, 69u, 71u, 500u})
        for (uint32_t i : {0u, 7u, 8u, 29u})
            for (uint32_t x : {0u, 5u, 1000u}) {
                float a[2], b[2], a1, b1;
                dpc_sampler_get_2d(plain.get(), x, x + 3, i, d, a);
                dpc_sampler_get_2d(folded.get(), x, x + 3, i, d, b);
                dpc_sampler_get_1d(plain.get(), x, x + 3, i, d, &a1);
                dpc_sampler_get_1d(folded.get(), x, x + 3, i, d, &b1);
                const bool f = d >= 2;
                EXPECT_EQ(b[0], f ? fold(a[0]) : a[0]) << d << " " << i << " " << x;
                EXPECT_EQ(b[1], f ? fold(a[1]) : a[1]) << d << " " << i << " " << x;
                EXPECT_EQ(b1, f ? fold(a1) : a1) << d << " " << i << " " << x;
                EXPECT_TRUE(b[0] >= 0.0f && b[0] < 1.0f && b[1] >= 0.0f && b[1] < 1.0f && b1 >= 0.0f && b1 < 1.0f);
            }
    EXPECT_EQ(fold(0.5f), 1.0f - 0x1p-24f);
    EXPECT_EQ(fold(1.0f - 0x1p-24f), 0x1p-24f);
    EXPECT_EQ(fold(0.0f), 0.0f);
}

TEST(SamplerThreads, ConcurrentLookupsMatchSerialOnes) {
    ModelPtr m = load(model_path("model_2d"));
    SamplerPtr s = make({m.get()}, 32, 8, 77);
    const uint32_t W = 64;
    std::vector<float> serial(W * W * 32 * 2);
    for (uint32_t y = 0; y < W; y++)
        for (uint32_t x = 0; x < W; x++)
            for (uint32_t i = 0; i < 32; i++)
                dpc_sampler_get_2d(s.get(), x, y, i, (x + i) % 8, &serial[((y * W + x) * 32 + i) * 2]);
    std::vector<std::vector<float>> got(8, std::vector<float>(serial.size()));
    std::vector<std::thread> threads;
    for (int t = 0; t < 8; t++)
        threads.emplace_back([&, t] {
            for (uint32_t y = 0; y < W; y++)
                for (uint32_t x = 0; x < W; x++)
                    for (uint32_t i = 0; i < 32; i++)
                        dpc_sampler_get_2d(s.get(), x, y, i, (x + i) % 8, &got[t][((y * W + x) * 32 + i) * 2]);
        });
    for (std::thread &th : threads) th.join();
    for (int t = 0; t < 8; t++) EXPECT_EQ(got[t], serial) << "thread " << t;
}

TEST(SamplerThreads, ConcurrentCreationFromOneModel) {
    ModelPtr m = load(model_path("model_2d"));
    std::vector<std::vector<float>> tables(6);
    std::vector<std::thread> threads;
    for (int t = 0; t < 6; t++)
        threads.emplace_back([&, t] {
            SamplerPtr s = make({m.get()}, 64, 4, 123);
            tables[t] = table_of(s.get(), 3, 64);
        });
    for (std::thread &th : threads) th.join();
    for (int t = 1; t < 6; t++) EXPECT_EQ(tables[t], tables[0]);
}

namespace {
struct Creation {
    std::atomic<uint64_t> calls{0}, last_done{0}, total{0};
    std::atomic<bool> backwards{false};
    std::chrono::steady_clock::time_point start, stopped;
    double stop_after_s = -1; // < 0: never stop
    std::atomic<bool> stop{false};
};

int on_creation(void *user, uint64_t done, uint64_t total) {
    Creation *c = static_cast<Creation *>(user);
    if (done < c->last_done) c->backwards = true;
    c->calls++, c->last_done = done, c->total = total;
    if (c->stop_after_s >= 0 && !c->stop &&
        std::chrono::steady_clock::now() - c->start > std::chrono::duration<double>(c->stop_after_s)) {
        c->stopped = std::chrono::steady_clock::now();
        c->stop = true;
    }
    return c->stop ? 1 : 0;
}
} // namespace

TEST(SamplerProgress, ReportsEverySetAndChangesNoBit) {
    ModelPtr m = load(model_path("model_2d"), DPC_ISA_AUTO, 4);
    const dpc_model *h = m.get();
    dpc_sampler_options o;
    dpc_sampler_options_init(&o);
    EXPECT_EQ(o.progress, nullptr);
    EXPECT_EQ(o.user, nullptr);
    o.models = &h;
    o.n_models = 1;
    o.samples_per_pixel = 64;
    o.dimensions = 8;
    o.net_dims = 1; // slot 0 a net: 7 sets to make
    Creation c;
    o.progress = on_creation;
    o.user = &c;
    dpc_sampler *s = nullptr;
    ASSERT_EQ(dpc_sampler_create(&o, &s), DPC_OK) << dpc_last_error();
    SamplerPtr with(s);
    EXPECT_EQ(c.total.load(), 7u);
    EXPECT_EQ(c.last_done.load(), 7u);
    EXPECT_FALSE(c.backwards.load());
    EXPECT_GT(c.calls.load(), 7u); // polls inside the sets too
    SamplerPtr plain = make({h}, 64, 8, 0, 1, 1);
    for (uint32_t t = 0; t < 8; t++) EXPECT_EQ(table_of(with.get(), t, 64), table_of(plain.get(), t, 64)) << t;
}

TEST(SamplerProgress, OptionsWithoutTheCallbackFieldsStillWork) {
    ModelPtr m = load(model_path("model_2d"));
    const dpc_model *h = m.get();
    dpc_sampler_options o;
    dpc_sampler_options_init(&o);
    o.models = &h;
    o.n_models = 1;
    o.progress = [](void *, uint64_t, uint64_t) -> int { return 1; }; // beyond the old struct: ignored
    o.struct_size = (uint32_t)offsetof(dpc_sampler_options, progress);
    dpc_sampler *s = nullptr;
    ASSERT_EQ(dpc_sampler_create(&o, &s), DPC_OK) << dpc_last_error();
    SamplerPtr old(s);
    SamplerPtr now = make({h}, 16, 16, 0, 1, DPC_SAMPLER_NET_DIMS_AUTO);
    EXPECT_EQ(table_of(old.get(), 3, 16), table_of(now.get(), 3, 16));
    o.struct_size = (uint32_t)sizeof o - 4;
    EXPECT_EQ(dpc_sampler_create(&o, &s), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(s, nullptr);
}

// net_layout: a caller built before it passes a shorter struct (the default, AUTO, applies); a
// value other than the three names is a status with a message.
TEST(SamplerOptions, NetLayoutIsCheckedAndOptional) {
    ModelPtr m = load(model_path("model_2d"));
    const dpc_model *h = m.get();
    dpc_sampler_options o;
    dpc_sampler_options_init(&o);
    EXPECT_EQ(o.net_layout, DPC_SAMPLER_NETS_AUTO);
    o.models = &h;
    o.n_models = 1;
    o.net_layout = 7;
    dpc_sampler *s = nullptr;
    EXPECT_EQ(dpc_sampler_create(&o, &s), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(dpc_last_error()).find("net_layout"), std::string::npos) << dpc_last_error();
    o.struct_size = (uint32_t)offsetof(dpc_sampler_options, net_layout);
    ASSERT_EQ(dpc_sampler_create(&o, &s), DPC_OK) << dpc_last_error();
    SamplerPtr old(s);
    dpc_sampler_info info;
    info.struct_size = sizeof info;
    ASSERT_EQ(dpc_sampler_get_info(old.get(), &info), DPC_OK);
    EXPECT_EQ(info.net_layout, DPC_SAMPLER_NETS_SCREEN); // 16 spp: the default's screen-ordered nets
}

// A progressive model with the prefix relaxation (seconds per large table): a cancel is seen
// within a relaxation step, not after the set or the sampler.
TEST(SamplerProgress, CancelStopsAProgressiveRelaxationPromptly) {
    ModelPtr m = load(model_path("model_2d_progressive_relaxed"), DPC_ISA_AUTO, 2);
    const dpc_model *h = m.get();
    dpc_sampler_options o;
    dpc_sampler_options_init(&o);
    o.models = &h;
    o.n_models = 1;
    o.samples_per_pixel = 16384;
    o.dimensions = 4;
    Creation c;
    c.stop_after_s = 0.3;
    o.progress = on_creation;
    o.user = &c;
    dpc_sampler *s = reinterpret_cast<dpc_sampler *>(1);
    c.start = std::chrono::steady_clock::now();
    EXPECT_EQ(dpc_sampler_create(&o, &s), DPC_ERROR_CANCELLED);
    const double late = std::chrono::duration<double>(std::chrono::steady_clock::now() - c.stopped).count();
    EXPECT_EQ(s, nullptr);
    EXPECT_TRUE(c.stop.load());
    EXPECT_LT(late, 0.5) << "creation went on for " << late << " s after the callback asked to stop";
    EXPECT_NE(std::string(dpc_last_error()).find("cancelled"), std::string::npos) << dpc_last_error();
    EXPECT_EQ(c.last_done.load(), 0u); // no set finished in 0.3 s
}

// Frames (options.frames): checked options, the info, and the structure that makes each frame's
// error blue: tables of spp * F points read in order (no rotation, no nets), every pixel's values
// its table point shifted by one mask entry for all dimensions (each rotated by its own key), the
// same shift for every frame of a pass, a new one from frame F on.
TEST(SamplerFrames, OptionsInfoAndOneShiftPerPixelForEveryDimensionAndFrame) {
    ModelPtr m = load(model_path("model_2d"));
    const dpc_model *h = m.get();
    dpc_sampler_options o;
    dpc_sampler_options_init(&o);
    EXPECT_EQ(o.frames, 1u);
    o.models = &h;
    o.n_models = 1;
    o.samples_per_pixel = 1;
    o.dimensions = 3;
    o.seed = 17;
    dpc_sampler *s = nullptr;
    o.frames = DPC_SAMPLER_MAX_SPP + 1;
    EXPECT_EQ(dpc_sampler_create(&o, &s), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(dpc_last_error()).find("frames"), std::string::npos) << dpc_last_error();
    o.frames = 16;
    o.net_dims = 2;
    EXPECT_EQ(dpc_sampler_create(&o, &s), DPC_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(std::string(dpc_last_error()).find("net_dims"), std::string::npos) << dpc_last_error();
    o.net_dims = DPC_SAMPLER_NET_DIMS_AUTO;
    o.samples_per_pixel = 256;
    o.frames = 256;
    o.dimensions = 300;
    EXPECT_EQ(dpc_sampler_create(&o, &s), DPC_ERROR_LIMIT);
    EXPECT_EQ(s, nullptr);

    const uint32_t F = 16, D = 3;
    o.samples_per_pixel = 1;
    o.frames = F;
    o.dimensions = D;
    ASSERT_EQ(dpc_sampler_create(&o, &s), DPC_OK) << dpc_last_error();
    SamplerPtr frames(s);
    dpc_sampler_info info;
    info.struct_size = sizeof info;
    ASSERT_EQ(dpc_sampler_get_info(s, &info), DPC_OK);
    EXPECT_EQ(info.samples_per_pixel, 1u);
    EXPECT_EQ(info.frames, F);
    EXPECT_EQ(info.net_slots, 0u);
    // frames 0 reads as 1 (an older caller's zeroed field): the bits of frames = 1
    o.frames = 0;
    ASSERT_EQ(dpc_sampler_create(&o, &s), DPC_OK) << dpc_last_error();
    SamplerPtr zero(s);
    o.frames = 1;
    ASSERT_EQ(dpc_sampler_create(&o, &s), DPC_OK) << dpc_last_error();
    SamplerPtr one(s);
    EXPECT_EQ(table_of(zero.get(), 1, 1), table_of(one.get(), 1, 1));

    std::vector<std::vector<float>> tables;
    for (uint32_t d = 0; d < D; d++) tables.push_back(table_of(frames.get(), d, F));
    auto shift = [&](uint32_t x, uint32_t y, uint32_t index, uint32_t d, int c) {
        float v[2];
        EXPECT_EQ(dpc_sampler_get_2d(frames.get(), x, y, index, d, v), DPC_OK);
        const double r = (double)v[c] - tables[d][(index % F) * 2 + c];
        return r - std::floor(r);
    };
    auto same = [](double a, double b) { // equal on the torus, up to float rounding
        const double e = std::fabs(a - b);
        return std::min(e, 1.0 - e) < 1e-6;
    };
    for (uint32_t y = 0; y < 32; y += 5)
        for (uint32_t x = 0; x < 32; x += 3)
            for (int c = 0; c < 2; c++) {
                const double s0 = shift(x, y, 0, 0, c);
                for (uint32_t f = 1; f < F; f++)
                    EXPECT_TRUE(same(shift(x, y, f, 0, c), s0)) << x << " " << y << " " << f;
                // dimension 1's shift is dimension 0's plus its own rotation, the same at every pixel
                const double k1 = shift(0, 0, 0, 1, c) - shift(0, 0, 0, 0, c);
                EXPECT_TRUE(same(shift(x, y, 3, 1, c) - s0, k1)) << x << " " << y;
            }
    // frame F starts a new pass: a new shift
    int moved = 0;
    for (uint32_t x = 0; x < 32; x++) moved += !same(shift(x, 0, F, 0, 0), shift(x, 0, 0, 0, 0));
    EXPECT_GT(moved, 28);
}
