// A renderer's pixel loop on libdpc's sampler: a pbrt-style Sampler adaptor (StartPixelSample,
// Get1D, Get2D, GetPixel2D) over dpc_sampler_get_1d / _get_2d, rendering a small analytic scene
// on several threads: a plane lit by a square area light, partly hidden by a disc, each pixel
// integrating over its footprint and over the light. It prints the error of 16 spp against a
// 4,096-spp render, for dpc and for independent uniform samples.
// Build and run (one line):
//   c++ -std=c++17 render_sampler.cpp -Ilibdpc/include -Lbuild/libdpc -ldpc -pthread
//   -Wl,-rpath,build/libdpc -o render_sampler && ./render_sampler models/bnot-2d-stratified.onnx
#include <cmath>
#include <cstdio>
#include <random>
#include <thread>
#include <vector>

#include "dpc/dpc.h"

namespace {

// The adaptor a pbrt-like renderer expects: one object per thread, pointing at a shared sampler.
class DpcSampler {
  public:
    explicit DpcSampler(const dpc_sampler *s) : s_(s) {}
    void StartPixelSample(int x, int y, int index) {
        x_ = (uint32_t)x;
        y_ = (uint32_t)y;
        index_ = (uint32_t)index;
        dim_ = 1; // dimension 0 is the pixel footprint
    }
    float Get1D() {
        float v;
        dpc_sampler_get_1d(s_, x_, y_, index_, dim_++, &v);
        return v;
    }
    void Get2D(float out[2]) { dpc_sampler_get_2d(s_, x_, y_, index_, dim_++, out); }
    void GetPixel2D(float out[2]) { dpc_sampler_get_2d(s_, x_, y_, index_, 0, out); }

  private:
    const dpc_sampler *s_;
    uint32_t x_ = 0, y_ = 0, index_ = 0, dim_ = 0;
};

class RandomSampler { // the baseline: independent uniform numbers
  public:
    void StartPixelSample(int x, int y, int index) {
        rng_.seed((uint64_t)y << 40 ^ (uint64_t)x << 20 ^ (uint64_t)index);
    }
    float Get1D() { return u_(rng_); }
    void Get2D(float out[2]) { out[0] = u_(rng_), out[1] = u_(rng_); }
    void GetPixel2D(float out[2]) { Get2D(out); }

  private:
    std::mt19937_64 rng_;
    std::uniform_real_distribution<float> u_{0.0f, 1.0f};
};

const int W = 64;

// Radiance reaching a point of the plane z = 0 from a point of the light (a unit square at
// height 1, centred above (0.5, 0.5)), blocked by a disc of radius 0.18 at height 0.5.
float shade(float px, float py, const float light[2]) {
    const float lx = light[0], ly = light[1];
    const float mx = 0.5f * (px + lx), my = 0.5f * (py + ly); // where the ray crosses z = 0.5
    const float dx = mx - 0.5f, dy = my - 0.5f;
    return dx * dx + dy * dy < 0.18f * 0.18f ? 0.0f : 1.0f;
}

template <class Sampler> void render(std::vector<float> &image, int spp, Sampler make(), int threads) {
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; t++)
        pool.emplace_back([&, t] {
            Sampler s = make();
            for (int y = t; y < W; y += threads)
                for (int x = 0; x < W; x++) {
                    double sum = 0.0;
                    for (int i = 0; i < spp; i++) {
                        s.StartPixelSample(x, y, i);
                        float pixel[2], light[2];
                        s.GetPixel2D(pixel);
                        s.Get2D(light);
                        sum += shade((x + pixel[0]) / W, (y + pixel[1]) / W, light);
                    }
                    image[y * W + x] = (float)(sum / spp);
                }
        });
    for (std::thread &th : pool) th.join();
}

const dpc_sampler *g_sampler = nullptr;
DpcSampler make_dpc() { return DpcSampler(g_sampler); }
RandomSampler make_random() { return RandomSampler(); }

double mse(const std::vector<float> &a, const std::vector<float> &b) {
    double e = 0.0;
    for (size_t i = 0; i < a.size(); i++) e += (a[i] - b[i]) * (double)(a[i] - b[i]);
    return e / a.size();
}

dpc_sampler *create(const dpc_model *model, uint32_t spp, uint64_t seed) {
    dpc_sampler_options o;
    dpc_sampler_options_init(&o);
    const dpc_model *models[] = {model};
    o.models = models;
    o.n_models = 1;
    o.samples_per_pixel = spp;
    o.dimensions = 2;
    o.seed = seed;
    dpc_sampler *s = nullptr;
    if (dpc_sampler_create(&o, &s) != DPC_OK) std::fprintf(stderr, "dpc: %s\n", dpc_last_error());
    return s;
}

} // namespace

int main(int argc, char **argv) {
    const char *path = argc > 1 ? argv[1] : "models/bnot-2d-stratified.onnx";
    dpc_model *model = nullptr;
    if (dpc_model_load_file(path, nullptr, &model) != DPC_OK) {
        std::fprintf(stderr, "dpc: %s\n", dpc_last_error());
        return 1;
    }
    dpc_sampler *reference = create(model, 4096, 1), *sampler = create(model, 16, 2);
    dpc_model_free(model); // the samplers keep their tables, not the model
    if (!reference || !sampler) return 1;
    std::vector<float> ref(W * W), img(W * W), rnd(W * W);
    g_sampler = reference;
    render(ref, 4096, make_dpc, 4);
    g_sampler = sampler;
    render(img, 16, make_dpc, 4);
    render(rnd, 16, make_random, 4);
    std::printf("16 spp, %dx%d, 4 threads: MSE dpc %.3g, independent %.3g (%.1fx lower)\n", W, W, mse(img, ref),
                mse(rnd, ref), mse(rnd, ref) / mse(img, ref));
    dpc_sampler_free(reference);
    dpc_sampler_free(sampler);
    return 0;
}
