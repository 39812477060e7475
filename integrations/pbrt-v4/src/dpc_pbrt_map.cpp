// dpc_pbrt_map.cpp: see dpc_pbrt_map.h.
#include "dpc_pbrt_map.h"

#include <cstdio>
#include <cstdlib>
#include <vector>

namespace dpc_pbrt {

namespace {

std::vector<std::string> split(const std::string &s, char sep) {
    std::vector<std::string> out;
    size_t start = 0;
    while (start <= s.size()) {
        size_t end = s.find(sep, start);
        if (end == std::string::npos) end = s.size();
        if (end > start) out.push_back(s.substr(start, end - start));
        start = end + 1;
    }
    return out;
}

// One model: a path as it is, a name through libdpc's model search (dpc_model_load_named). Null
// and a message on failure (for an unknown name libdpc's message lists the models it finds).
dpc_model *load(const std::string &spec, const dpc_load_options &options, std::string &error) {
    dpc_model *model = nullptr;
    const bool path =
        spec.find('/') != std::string::npos || (spec.size() > 5 && spec.compare(spec.size() - 5, 5, ".onnx") == 0);
    const dpc_status st = path ? dpc_model_load_file(spec.c_str(), &options, &model)
                               : dpc_model_load_named(spec.c_str(), &options, &model);
    if (st != DPC_OK) error = dpc_last_error();
    return model;
}

// A lookup on a created sampler cannot fail (dpc_sampler.h: any pixel, index and dimension); a
// failure here is a broken invariant, so it stops the renderer loudly rather than shade with 0.
void check(dpc_status status) {
    if (status == DPC_OK) return;
    std::fprintf(stderr, "dpc sampler: lookup failed: %s\n", dpc_last_error());
    std::abort();
}

} // namespace

std::string describe(const Config &c) {
    return "model \"" + c.model + "\" pixelsamples " + std::to_string(c.samples_per_pixel) + " dimensions " +
           std::to_string(c.dimensions) + " fold_from " + std::to_string(c.fold_from) + " net_dims " +
           std::to_string(c.net_dims) + " net_layout " + c.net_layout + " seed " + std::to_string(c.seed);
}

SharedSampler make_sampler(const Config &config, std::string &error) {
    error.clear();
    if (config.samples_per_pixel < 1 || config.samples_per_pixel > (int)DPC_SAMPLER_MAX_SPP) {
        error = "\"integer pixelsamples\" is " + std::to_string(config.samples_per_pixel) + ", must be 1 .. " +
                std::to_string(DPC_SAMPLER_MAX_SPP);
        return nullptr;
    }
    if (config.dimensions < 1 || config.dimensions > (int)DPC_SAMPLER_MAX_DIMENSIONS) {
        error = "\"integer dimensions\" is " + std::to_string(config.dimensions) + ", must be 1 .. " +
                std::to_string(DPC_SAMPLER_MAX_DIMENSIONS);
        return nullptr;
    }
    if (config.fold_from < -1) {
        error = "\"integer fold_from\" is " + std::to_string(config.fold_from) + ": a slot (>= 0), or -1 to fold none";
        return nullptr;
    }
    if (config.net_dims < -2) {
        error = "\"integer net_dims\" is " + std::to_string(config.net_dims) +
                ": a slot count (>= 0), -1 for libdpc's default or -2 for the integration's";
        return nullptr;
    }
    if (config.net_layout != "auto" && config.net_layout != "pixel" && config.net_layout != "screen") {
        error = "\"string net_layout\" is \"" + config.net_layout + "\": \"auto\", \"screen\" or \"pixel\"";
        return nullptr;
    }
    if (config.model.find('\0') != std::string::npos) {
        error = "\"string model\" contains a NUL character";
        return nullptr;
    }
    const std::vector<std::string> specs = split(config.model, ',');
    if (specs.empty()) {
        error = "\"string model\" names no model";
        return nullptr;
    }

    dpc_load_options load_options;
    dpc_load_options_init(&load_options);
    load_options.threads = config.threads;
    std::vector<dpc_model *> models;
    for (const std::string &spec : specs) {
        std::string why;
        dpc_model *model = load(spec, load_options, why);
        if (!model) {
            error = "model \"" + spec + "\": " + why;
            break;
        }
        models.push_back(model);
    }
    dpc_sampler *sampler = nullptr;
    if (error.empty()) {
        dpc_sampler_options o;
        dpc_sampler_options_init(&o);
        std::vector<const dpc_model *> handles(models.begin(), models.end());
        o.models = handles.data();
        o.n_models = (uint32_t)handles.size();
        o.samples_per_pixel = (uint32_t)config.samples_per_pixel;
        o.dimensions = (uint32_t)config.dimensions;
        o.fold_from = config.fold_from < 0 ? DPC_SAMPLER_NO_FOLD : (uint32_t)config.fold_from;
        const char *order = dpc_model_metadata(handles[0], "dpc.order");
        const bool progressive = order && std::string(order) == "progressive";
        o.net_dims = config.net_dims == -2 && !progressive ? (uint32_t)NET_DIMS_PBRT
                     : config.net_dims < 0                 ? DPC_SAMPLER_NET_DIMS_AUTO
                                                           : (uint32_t)config.net_dims;
        o.seed = (uint64_t)config.seed;
        o.net_layout = config.net_layout == "screen"  ? DPC_SAMPLER_NETS_SCREEN
                       : config.net_layout == "pixel" ? DPC_SAMPLER_NETS_PER_PIXEL
                                                      : DPC_SAMPLER_NETS_AUTO;
        if (dpc_sampler_create(&o, &sampler) != DPC_OK)
            error = std::string(dpc_last_error()) + " (" + describe(config) + ")";
    }
    // the sampler keeps no reference to its models (dpc_sampler.h, "Threads")
    for (dpc_model *model : models) dpc_model_free(model);
    if (!sampler) return nullptr;
    return SharedSampler(sampler, [](const dpc_sampler *s) { dpc_sampler_free(const_cast<dpc_sampler *>(s)); });
}

PixelSampler::PixelSampler(SharedSampler sampler) : sampler_(std::move(sampler)) {
    dpc_sampler_info info;
    info.struct_size = sizeof info;
    check(dpc_sampler_get_info(sampler_.get(), &info));
    spp_ = info.samples_per_pixel;
}

void PixelSampler::start_pixel_sample(int32_t x, int32_t y, int32_t sample_index, int32_t dimension) {
    x_ = (uint32_t)x; // negative coordinates wrap modulo 2^32 (dpc_sampler.h allows it)
    y_ = (uint32_t)y;
    index_ = (uint32_t)sample_index;
    slot_ = 1u + (uint32_t)dimension; // slot 0 is the film position, read by get_pixel_2d
}

float PixelSampler::get_1d() {
    float v = 0.f;
    check(dpc_sampler_get_1d(sampler_.get(), x_, y_, index_, slot_++, &v));
    return v;
}

Value2 PixelSampler::get_2d() {
    float v[2] = {0.f, 0.f};
    check(dpc_sampler_get_2d(sampler_.get(), x_, y_, index_, slot_++, v));
    return {v[0], v[1]};
}

Value2 PixelSampler::get_pixel_2d() const {
    float v[2] = {0.f, 0.f};
    check(dpc_sampler_get_2d(sampler_.get(), x_, y_, index_, 0u, v));
    return {v[0], v[1]};
}

} // namespace dpc_pbrt
