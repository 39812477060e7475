// The pbrt-v4 integration's mapping (dpc_pbrt_map.h), tested against direct dpc_sampler calls
// without pbrt. tests.cmake builds it into dpc's C tests; the models come from the repository's
// models/ through $DPC_MODEL_PATH, so the name search (dpc_model_find) is the one exercised.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "dpc_pbrt_map.h"

using dpc_pbrt::Config;
using dpc_pbrt::PixelSampler;
using dpc_pbrt::SharedSampler;
using dpc_pbrt::Value2;

namespace {

SharedSampler make(Config c) {
    std::string error;
    SharedSampler s = dpc_pbrt::make_sampler(c, error);
    EXPECT_TRUE(s) << error;
    EXPECT_EQ(error, "");
    return s;
}

SharedSampler make_default(int spp = 16, int64_t seed = 0) {
    Config c;
    c.samples_per_pixel = spp;
    c.seed = seed;
    return make(c);
}

float direct_1d(const SharedSampler &s, int32_t x, int32_t y, uint32_t i, uint32_t d) {
    float v = -1.f;
    EXPECT_EQ(dpc_sampler_get_1d(s.get(), (uint32_t)x, (uint32_t)y, i, d, &v), DPC_OK);
    return v;
}

Value2 direct_2d(const SharedSampler &s, int32_t x, int32_t y, uint32_t i, uint32_t d) {
    float v[2] = {-1.f, -1.f};
    EXPECT_EQ(dpc_sampler_get_2d(s.get(), (uint32_t)x, (uint32_t)y, i, d, v), DPC_OK);
    return {v[0], v[1]};
}

void expect_same(Value2 a, Value2 b) {
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
}

// The call pattern of pbrt's path integrator: a wavelength sample, then GetCameraSample
// (GetPixel2D, time, lens), then per bounce 1-D and 2-D values.
struct Drawn {
    Value2 film;
    std::vector<float> values; // every value, 2-D ones as two entries
};

Drawn draw(PixelSampler &p, int32_t x, int32_t y, int32_t i, int32_t dimension = 0) {
    Drawn out;
    p.start_pixel_sample(x, y, i, dimension);
    out.values.push_back(p.get_1d());
    out.film = p.get_pixel_2d();
    out.values.push_back(p.get_1d());
    for (int k = 0; k < 5; ++k) {
        Value2 v = p.get_2d();
        out.values.push_back(v.x);
        out.values.push_back(v.y);
        out.values.push_back(p.get_1d());
    }
    return out;
}

} // namespace

TEST(PbrtMap, ModelsFolderIsSearched) {
    const char *path = std::getenv("DPC_MODEL_PATH");
    ASSERT_NE(path, nullptr) << "tests.cmake sets DPC_MODEL_PATH to the repository's models/";
    char found[DPC_PATH_MAX];
    ASSERT_EQ(dpc_model_find("bnot-2d-stratified", found, sizeof found), DPC_OK) << dpc_last_error();
}

TEST(PbrtMap, SlotsMatchDirectCalls) {
    SharedSampler s = make_default();
    PixelSampler p(s);
    EXPECT_EQ(p.samples_per_pixel(), 16u);
    for (int32_t i = 0; i < 16; ++i) {
        Drawn d = draw(p, 3, 11, i);
        expect_same(d.film, direct_2d(s, 3, 11, i, 0));
        // slot 1: the first 1-D value; slot 2: the second; then 2-D, 1-D in turn from slot 3
        EXPECT_EQ(d.values[0], direct_1d(s, 3, 11, i, 1));
        EXPECT_EQ(d.values[1], direct_1d(s, 3, 11, i, 2));
        for (uint32_t k = 0; k < 5; ++k) {
            Value2 v = direct_2d(s, 3, 11, i, 3 + 2 * k);
            EXPECT_EQ(d.values[2 + 3 * k], v.x);
            EXPECT_EQ(d.values[3 + 3 * k], v.y);
            EXPECT_EQ(d.values[4 + 3 * k], direct_1d(s, 3, 11, i, 4 + 2 * k));
        }
        EXPECT_EQ(p.next_slot(), 13u);
    }
}

TEST(PbrtMap, Pixel2DIsSlotZeroWhateverTheCallOrder) {
    SharedSampler s = make_default();
    PixelSampler p(s);
    p.start_pixel_sample(5, 2, 7, 0);
    const Value2 first = p.get_pixel_2d();
    expect_same(first, direct_2d(s, 5, 2, 7, 0));
    p.get_2d();
    p.get_1d();
    expect_same(p.get_pixel_2d(), first); // after other values
    expect_same(p.get_pixel_2d(), first); // twice
    EXPECT_EQ(p.next_slot(), 3u);         // it takes no slot
    // and with a dimension argument: still slot 0
    p.start_pixel_sample(5, 2, 7, 9);
    expect_same(p.get_pixel_2d(), first);
}

TEST(PbrtMap, StartPixelSampleResets) {
    SharedSampler s = make_default();
    PixelSampler p(s);
    const Drawn a = draw(p, 4, 4, 3);
    draw(p, 9, 1, 12); // elsewhere
    p.start_pixel_sample(4, 4, 3, 0);
    p.get_2d(); // partly consumed, then restarted
    const Drawn b = draw(p, 4, 4, 3);
    expect_same(a.film, b.film);
    EXPECT_EQ(a.values, b.values);
    // a different sample index or pixel gives other values
    EXPECT_NE(a.values, draw(p, 4, 4, 4).values);
    EXPECT_NE(a.values, draw(p, 5, 4, 3).values);
}

TEST(PbrtMap, DimensionArgumentStartsTheSlotCounter) {
    SharedSampler s = make_default();
    PixelSampler p(s);
    for (int32_t dim : {0, 1, 6, 13, 40}) {
        p.start_pixel_sample(2, 8, 5, dim);
        EXPECT_EQ(p.next_slot(), 1u + (uint32_t)dim);
        EXPECT_EQ(p.get_1d(), direct_1d(s, 2, 8, 5, 1 + dim));
        expect_same(p.get_2d(), direct_2d(s, 2, 8, 5, 2 + dim));
    }
    // StartPixelSample(p, i, k) then Get1D is the value that StartPixelSample(p, i) gives as its
    // (k + 1)-th 1-D value
    p.start_pixel_sample(2, 8, 5, 0);
    std::vector<float> seq;
    for (int k = 0; k < 8; ++k) seq.push_back(p.get_1d());
    for (int32_t k = 0; k < 8; ++k) {
        p.start_pixel_sample(2, 8, 5, k);
        EXPECT_EQ(p.get_1d(), seq[k]) << k;
    }
}

TEST(PbrtMap, NegativePixelsCastToUnsigned) {
    SharedSampler s = make_default();
    PixelSampler p(s);
    p.start_pixel_sample(-3, -70, 2, 0);
    EXPECT_EQ(p.x(), 0xFFFFFFFDu);
    EXPECT_EQ(p.y(), (uint32_t)-70);
    expect_same(p.get_pixel_2d(), direct_2d(s, -3, -70, 2, 0));
    EXPECT_EQ(p.get_1d(), direct_1d(s, -3, -70, 2, 1));
}

TEST(PbrtMap, CloneIsIndependentAndSharesTheSampler) {
    SharedSampler s = make_default();
    PixelSampler original(s);
    original.start_pixel_sample(1, 5, 6, 0);
    original.get_1d();
    PixelSampler clone = original; // pbrt's Clone: a copy of the state
    EXPECT_EQ(clone.sampler(), original.sampler());
    EXPECT_EQ(s.use_count(), 3); // s, original, clone: one dpc_sampler
    EXPECT_EQ(clone.next_slot(), 2u);
    const float next = direct_1d(s, 1, 5, 6, 2);
    EXPECT_EQ(clone.get_1d(), next);
    clone.start_pixel_sample(30, 30, 0, 0);
    clone.get_2d();
    // the original is where it was
    EXPECT_EQ(original.x(), 1u);
    EXPECT_EQ(original.next_slot(), 2u);
    EXPECT_EQ(original.get_1d(), next);
    // the shared sampler outlives the handles that made it
    s.reset();
    PixelSampler last = clone;
    last.start_pixel_sample(1, 5, 6, 1);
    EXPECT_EQ(last.get_1d(), next);
}

TEST(PbrtMap, ClonesOnThreadsGiveTheSequentialValues) {
    SharedSampler s = make_default(32);
    PixelSampler prototype(s);
    auto render = [](PixelSampler p, int row, std::vector<float> *out) {
        for (int32_t x = 0; x < 16; ++x)
            for (int32_t i = 0; i < 32; ++i) {
                Drawn d = draw(p, x, row, i);
                out->push_back(d.film.x);
                out->push_back(d.film.y);
                out->insert(out->end(), d.values.begin(), d.values.end());
            }
    };
    std::vector<std::vector<float>> sequential(4), threaded(4);
    for (int row = 0; row < 4; ++row) render(prototype, row, &sequential[row]);
    std::vector<std::thread> threads;
    for (int row = 0; row < 4; ++row) threads.emplace_back(render, prototype, row, &threaded[row]);
    for (std::thread &t : threads) t.join();
    EXPECT_EQ(sequential, threaded);
}

TEST(PbrtMap, FilmPositionIsANetPerPixel) {
    // spp = 2^m: slot 0 (GetPixel2D) is a (0,m,2)-net in every pixel, negative ones included
    for (int m = 1; m <= 8; ++m) {
        const uint32_t spp = 1u << m;
        PixelSampler p(make_default((int)spp, 3));
        for (int32_t y = -2; y < 2; ++y)
            for (int32_t x = -2; x < 2; ++x)
                for (int k = 0; k <= m; ++k) {
                    const uint32_t nx = 1u << k, ny = 1u << (m - k);
                    std::vector<int> count(spp, 0);
                    for (uint32_t i = 0; i < spp; ++i) {
                        p.start_pixel_sample(x, y, (int32_t)i, 0);
                        const Value2 v = p.get_pixel_2d();
                        ASSERT_TRUE(v.x >= 0.f && v.x < 1.f && v.y >= 0.f && v.y < 1.f);
                        ++count[(uint32_t)(v.y * ny) * nx + (uint32_t)(v.x * nx)];
                    }
                    for (uint32_t c = 0; c < spp; ++c)
                        ASSERT_EQ(count[c], 1)
                            << "spp " << spp << " pixel " << x << "," << y << " interval " << nx << "x" << ny;
                }
    }
}

TEST(PbrtMap, Deterministic) {
    SharedSampler a = make_default(16, 7), b = make_default(16, 7), c = make_default(16, 8);
    PixelSampler pa(a), pb(b), pc(c);
    const Drawn da = draw(pa, 12, 3, 9), db = draw(pb, 12, 3, 9), dc = draw(pc, 12, 3, 9);
    EXPECT_NE(a.get(), b.get());
    expect_same(da.film, db.film);
    EXPECT_EQ(da.values, db.values);
    EXPECT_NE(da.values, dc.values); // the seed matters
    // the table threads do not change the values
    Config threaded;
    threaded.seed = 7;
    threaded.threads = 0;
    PixelSampler pt(make(threaded));
    EXPECT_EQ(draw(pt, 12, 3, 9).values, da.values);
}

TEST(PbrtMap, OptionsReachTheSampler) {
    Config c;
    c.samples_per_pixel = 8;
    c.dimensions = 5;
    c.fold_from = -1;
    c.net_dims = 0;
    c.seed = 42;
    SharedSampler s = make(c);
    ASSERT_TRUE(s);
    dpc_sampler_info info;
    info.struct_size = sizeof info;
    ASSERT_EQ(dpc_sampler_get_info(s.get(), &info), DPC_OK);
    EXPECT_EQ(info.samples_per_pixel, 8u);
    EXPECT_EQ(info.dimensions, 5u);
    EXPECT_EQ(info.fold_from, DPC_SAMPLER_NO_FOLD);
    EXPECT_EQ(info.net_slots, 0u);
    EXPECT_EQ(info.seed, 42u);
    EXPECT_EQ(info.net_layout, DPC_SAMPLER_NETS_PER_PIXEL); // no net slots
    // the defaults: nothing folded, slots 0 .. NET_DIMS_PBRT - 1 screen-ordered nets at 16 spp
    SharedSampler d = make_default(16);
    ASSERT_EQ(dpc_sampler_get_info(d.get(), &info), DPC_OK);
    EXPECT_EQ(info.fold_from, DPC_SAMPLER_NO_FOLD);
    EXPECT_EQ(info.net_slots, (uint32_t)dpc_pbrt::NET_DIMS_PBRT);
    Config every; // -1: libdpc's default, every slot
    every.net_dims = -1;
    SharedSampler e = make(every);
    ASSERT_EQ(dpc_sampler_get_info(e.get(), &info), DPC_OK);
    EXPECT_EQ(info.net_slots, 16u);
    Config progressive; // progressive models keep libdpc's default: one net slot
    progressive.model = "progressive-2d";
    SharedSampler g = make(progressive);
    ASSERT_TRUE(g);
    ASSERT_EQ(dpc_sampler_get_info(g.get(), &info), DPC_OK);
    EXPECT_EQ(info.net_slots, 1u);
    EXPECT_EQ(info.net_layout, DPC_SAMPLER_NETS_SCREEN);
    EXPECT_EQ(info.dimensions, 16u);
    c.net_dims = 2;
    c.net_layout = "pixel";
    SharedSampler p = make(c);
    ASSERT_TRUE(p);
    ASSERT_EQ(dpc_sampler_get_info(p.get(), &info), DPC_OK);
    EXPECT_EQ(info.net_layout, DPC_SAMPLER_NETS_PER_PIXEL);
    // two models by name, used in turn
    c.model = "bnot-2d-stratified,bnot-2d";
    EXPECT_TRUE(make(c));
}

TEST(PbrtMap, ErrorsNameTheProblem) {
    std::string error;
    Config c;
    c.model = "no-such-model";
    EXPECT_FALSE(dpc_pbrt::make_sampler(c, error));
    EXPECT_NE(error.find("model \"no-such-model\""), std::string::npos) << error;
    EXPECT_NE(error.find("models there:"), std::string::npos) << error;
    // libdpc's message from its model search
    char found[DPC_PATH_MAX];
    ASSERT_NE(dpc_model_find("no-such-model", found, sizeof found), DPC_OK);
    EXPECT_NE(error.find(dpc_last_error()), std::string::npos) << error;

    c.model = "/nonexistent/model.onnx"; // a path is loaded as it is
    EXPECT_FALSE(dpc_pbrt::make_sampler(c, error));
    EXPECT_NE(error.find("/nonexistent/model.onnx"), std::string::npos) << error;

    c.model = "bnot-2d-stratified,,";
    EXPECT_TRUE(dpc_pbrt::make_sampler(c, error)) << error;
    c.model = ",";
    EXPECT_FALSE(dpc_pbrt::make_sampler(c, error));
    EXPECT_NE(error.find("names no model"), std::string::npos) << error;

    c = Config();
    c.model = "dither-32"; // a gridded model: libdpc refuses it, and says why
    EXPECT_FALSE(dpc_pbrt::make_sampler(c, error));
    EXPECT_NE(error.find("gridded"), std::string::npos) << error;

    c = Config();
    c.samples_per_pixel = 0;
    EXPECT_FALSE(dpc_pbrt::make_sampler(c, error));
    EXPECT_NE(error.find("pixelsamples"), std::string::npos) << error;
    c = Config();
    c.dimensions = -4;
    EXPECT_FALSE(dpc_pbrt::make_sampler(c, error));
    EXPECT_NE(error.find("dimensions"), std::string::npos) << error;
    c = Config();
    c.samples_per_pixel = 65536;
    c.dimensions = 512; // 2^25 table points: libdpc's limit
    EXPECT_FALSE(dpc_pbrt::make_sampler(c, error));
    EXPECT_NE(error.find("exceeds 2^24"), std::string::npos) << error;
    c = Config();
    c.fold_from = -2;
    EXPECT_FALSE(dpc_pbrt::make_sampler(c, error));
    EXPECT_NE(error.find("fold_from"), std::string::npos) << error;
    c = Config();
    c.net_dims = -3;
    EXPECT_FALSE(dpc_pbrt::make_sampler(c, error));
    EXPECT_NE(error.find("net_dims"), std::string::npos) << error;
    c = Config();
    c.net_layout = "diagonal";
    EXPECT_FALSE(dpc_pbrt::make_sampler(c, error));
    EXPECT_NE(error.find("net_layout"), std::string::npos) << error;
}
