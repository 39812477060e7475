// dpc_pbrt_map.h: pbrt-v4's sampler calls mapped onto libdpc's dpc_sampler, with no pbrt header.
// The pbrt class DPCSampler (dpc_sampler_pbrt.h) only forwards to this unit, so the mapping is
// compiled and tested (test_dpc_pbrt_map.cpp) in dpc's CI, where pbrt is not built.
//
// The mapping (dpc_sampler.h, rules 1-2: each dimension slot gives one 1-D or one 2-D value, and
// slot 0 is the film position):
//   StartPixelSample(p, sampleIndex, dimension)  pixel p, sample index; the next slot is 1 + dimension
//                                                (pbrt counts `dimension` in scalar dimensions)
//   GetPixel2D()                                 slot 0, whenever it is called (it takes no slot)
//   Get1D(), Get2D()                             the next slot, 1, 2, 3, ... in call order
//   SamplesPerPixel()                            the sampler's spp
//   Clone()                                      a copy of the state; the dpc_sampler is shared
// Pixel coordinates may be negative (crop windows): they are cast to uint32_t, which dpc_sampler.h
// allows (the mask tiles seamlessly). A created dpc_sampler is immutable and its lookups are
// lock-free, so clones on any number of threads share one.
#ifndef DPC_PBRT_MAP_H
#define DPC_PBRT_MAP_H

#include <cstdint>
#include <memory>
#include <string>

#include "dpc/dpc.h"

namespace dpc_pbrt {

// The parameters of `Sampler "dpc"` in a pbrt scene; the names after pixelsamples are the Mitsuba
// plugin's properties (python/dpc/mitsuba/dpc_sampler.cpp), with the same defaults.
struct Config {
    // "string model": a model name found by libdpc's model search (dpc_model_find: $DPC_MODEL_PATH,
    // then the installed models), or a path (it has a '/' or ends in ".onnx"); several, separated
    // by ',', are used in turn for the slots (dpc_sampler_options.models).
    std::string model = "bnot-2d-stratified";
    int samples_per_pixel = 16; // "integer pixelsamples" (pbrt's --spp overrides it)
    int dimensions = 16;        // "integer dimensions": the tables D; slots d >= D reuse table d mod D
    int fold_from = -1;         // "integer fold_from": first folded slot; -1 (default) folds none
    // "integer net_dims": slots that are (0,m,2)-nets. -2, the default: NET_DIMS_PBRT for set
    // models, libdpc's default for progressive ones; -1: libdpc's default (every slot).
    int net_dims = -2;
    int64_t seed = 0; // "integer seed" (pbrt's --seed is the default)
    // "string net_layout": "auto" (libdpc's default), "screen" (one Sobol' sequence per 32 x 32
    // tile, pixels in a randomised Morton order) or "pixel" (nets digitally shifted per pixel)
    std::string net_layout = "auto";
    // Threads that make the tables (dpc_load_options.threads: 0 is one per CPU); the values do
    // not depend on it.
    uint32_t threads = 1;
};

// net_dims by default: nets in slots 0-5, pbrt's film position, wavelength, time, lens, light
// choice and light position, and dpc's sets from the BSDF samples on (the Mitsuba plugin's rule,
// nets up to the first light sample, in pbrt's numbering: reports/pbrt.md's diagnostics).
constexpr int NET_DIMS_PBRT = 6;

// The immutable libdpc sampler, shared by a pbrt sampler and all its clones; freed with the last.
using SharedSampler = std::shared_ptr<const dpc_sampler>;

// Loads the models, makes the dpc_sampler and frees the models. On failure: null, and `error`
// says why (the parameter, or the model and libdpc's message; for an unknown name it lists the
// models the search finds).
SharedSampler make_sampler(const Config &config, std::string &error);

// One line describing a config (for pbrt's ToString).
std::string describe(const Config &config);

struct Value2 {
    float x, y;
};

// pbrt's sampler state for one thread: which pixel sample, and which slot comes next.
class PixelSampler {
  public:
    PixelSampler() = default;
    explicit PixelSampler(SharedSampler sampler);

    uint32_t samples_per_pixel() const { return spp_; }
    void start_pixel_sample(int32_t x, int32_t y, int32_t sample_index, int32_t dimension);
    float get_1d();
    Value2 get_2d();
    Value2 get_pixel_2d() const;

    uint32_t x() const { return x_; }
    uint32_t y() const { return y_; }
    uint32_t sample_index() const { return index_; }
    uint32_t next_slot() const { return slot_; }
    const dpc_sampler *sampler() const { return sampler_.get(); }
    const SharedSampler &shared() const { return sampler_; }

  private:
    SharedSampler sampler_;
    uint32_t spp_ = 0, x_ = 0, y_ = 0, index_ = 0, slot_ = 1;
};

} // namespace dpc_pbrt

#endif // DPC_PBRT_MAP_H
