// dpc_sampler_pbrt.h: pbrt-v4's `Sampler "dpc"`, libdpc's renderer sampler (dpc_sampler.h).
// apply.py copies this folder into pbrt's tree as src/pbrt/dpc/ and adds DPCSampler to pbrt's
// Sampler type list; every method forwards to dpc_pbrt::PixelSampler (dpc_pbrt_map.h), which
// holds the mapping of pbrt's calls onto dpc's slots and is tested in dpc's CI without pbrt.
//
// CPU only: the methods carry no PBRT_CPU_GPU, and the patched CMakeLists.txt refuses
// -DPBRT_DPC=ON together with the GPU build. pbrt's CPU integrators, --wavefront on the CPU
// included, can use it.
#ifndef PBRT_DPC_SAMPLER_PBRT_H
#define PBRT_DPC_SAMPLER_PBRT_H

#include <pbrt/pbrt.h>

#include <pbrt/base/sampler.h>
#include <pbrt/util/vecmath.h>

#include <memory>
#include <string>

#include "dpc_pbrt_map.h"

namespace pbrt {

class DPCSampler {
  public:
    // Makes the libdpc sampler; a bad model or option ends pbrt with ErrorExit (at loc) and
    // libdpc's message.
    explicit DPCSampler(const dpc_pbrt::Config &config, const FileLoc *loc = nullptr);
    // The defaults with spp samples per pixel (for tests, like the other samplers' constructors).
    explicit DPCSampler(int samplesPerPixel, const std::string &model = "bnot-2d-stratified", int seed = 0);

    static constexpr const char *Name() { return "DPCSampler"; }
    static DPCSampler *Create(const ParameterDictionary &parameters, const FileLoc *loc, Allocator alloc);

    int SamplesPerPixel() const { return (int)pixel.samples_per_pixel(); }
    void StartPixelSample(Point2i p, int sampleIndex, int dimension = 0) {
        pixel.start_pixel_sample(p.x, p.y, sampleIndex, dimension);
    }
    Float Get1D() { return pixel.get_1d(); }
    Point2f Get2D() {
        const dpc_pbrt::Value2 v = pixel.get_2d();
        return Point2f(v.x, v.y);
    }
    Point2f GetPixel2D() {
        const dpc_pbrt::Value2 v = pixel.get_pixel_2d();
        return Point2f(v.x, v.y);
    }

    Sampler Clone(Allocator alloc);
    std::string ToString() const;

  private:
    std::shared_ptr<const dpc_pbrt::Config> config; // shared by the clones, as the sampler is
    dpc_pbrt::PixelSampler pixel;
};

} // namespace pbrt

#endif // PBRT_DPC_SAMPLER_PBRT_H
