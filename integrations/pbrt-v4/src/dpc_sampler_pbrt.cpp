// dpc_sampler_pbrt.cpp: see dpc_sampler_pbrt.h.
#include "dpc_sampler_pbrt.h"

#include <pbrt/options.h>
#include <pbrt/paramdict.h>
#include <pbrt/util/error.h>
#include <pbrt/util/print.h>

#include <vector>

namespace pbrt {

namespace {

dpc_pbrt::PixelSampler make(const dpc_pbrt::Config &config, const FileLoc *loc) {
    std::string error;
    dpc_pbrt::SharedSampler sampler = dpc_pbrt::make_sampler(config, error);
    if (!sampler) ErrorExit(loc, "dpc sampler: %s", error);
    return dpc_pbrt::PixelSampler(std::move(sampler));
}

dpc_pbrt::Config defaults(int samplesPerPixel, const std::string &model, int seed) {
    dpc_pbrt::Config c;
    c.samples_per_pixel = samplesPerPixel;
    c.model = model;
    c.seed = seed;
    return c;
}

} // namespace

DPCSampler::DPCSampler(const dpc_pbrt::Config &config, const FileLoc *loc)
    : config(std::make_shared<const dpc_pbrt::Config>(config)), pixel(make(config, loc)) {}

DPCSampler::DPCSampler(int samplesPerPixel, const std::string &model, int seed)
    : DPCSampler(defaults(samplesPerPixel, model, seed)) {}

DPCSampler *DPCSampler::Create(const ParameterDictionary &parameters, const FileLoc *loc, Allocator alloc) {
    dpc_pbrt::Config c;
    c.samples_per_pixel = parameters.GetOneInt("pixelsamples", c.samples_per_pixel);
    if (Options->pixelSamples) c.samples_per_pixel = *Options->pixelSamples;
    // "string model" "a" or "a,b" or ["a" "b"]: the models in turn
    std::string models;
    for (const std::string &m : parameters.GetStringArray("model")) models += (models.empty() ? "" : ",") + m;
    if (!models.empty()) c.model = models;
    c.dimensions = parameters.GetOneInt("dimensions", c.dimensions);
    c.fold_from = parameters.GetOneInt("fold_from", c.fold_from);
    c.net_dims = parameters.GetOneInt("net_dims", c.net_dims);
    c.net_layout = parameters.GetOneString("net_layout", c.net_layout);
    c.seed = parameters.GetOneInt("seed", Options->seed);
    // the tables are made on pbrt's threads (--nthreads; 0 is one per CPU): the values are the same
    c.threads = Options->nThreads > 0 ? (uint32_t)Options->nThreads : 0u;
    return alloc.new_object<DPCSampler>(c, loc);
}

Sampler DPCSampler::Clone(Allocator alloc) { return alloc.new_object<DPCSampler>(*this); }

std::string DPCSampler::ToString() const {
    return StringPrintf("[ DPCSampler %s pixel: (%d, %d) sampleIndex: %d nextSlot: %d ]", dpc_pbrt::describe(*config),
                        (int)pixel.x(), (int)pixel.y(), (int)pixel.sample_index(), (int)pixel.next_slot());
}

} // namespace pbrt
