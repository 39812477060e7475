// The Mitsuba 3 sampler plugin "dpc": next_1d / next_2d served by libdpc's dpc_sampler, so each
// pixel gets a dpc blue-noise set and neighbouring pixels' errors cancel at low screen
// frequencies (docs/rendering.md). dpc.mitsuba compiles this file against the installed
// Mitsuba and the libdpc inside the dpc package, and puts the plugin on Mitsuba's search path.
//
// Mitsuba's scalar renderer seeds a pixel's sampler with
//   render_seed * width * height + block_id * block_size^2 + morton_index(pixel in block)
// and renders each block's pixels in Morton order on one forked sampler. The first seed a fork
// sees starts a block, so (seed - first seed) mod block_size^2 is the Morton index: the pixel's
// position inside its block, and seed - morton index (the block's first seed) names the block.
// The plugin asks libdpc for pixel (bx * block_size + x, by * block_size + y), (bx, by) the low
// and high 16 bits of that name: every block, and every mi.render seed, gets values of its own,
// and with the 32-pixel mask tile dividing the block size (32 unless the integrator's
// block_size says otherwise) the mask tiles seamlessly across blocks without knowing where a
// block lies in the image.
#include <memory>
#include <string>
#include <vector>

#include <mitsuba/core/properties.h>
#include <mitsuba/render/sampler.h>

#include "dpc/dpc.h"

NAMESPACE_BEGIN(mitsuba)

namespace dpc_plugin {

inline std::vector<std::string> split(const std::string &s, char sep) {
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

// Load one model of the "model" property: a path (with a '/' or ending in ".onnx") as it is, a
// name through libdpc's model search (dpc_model_load_named: $DPC_MODEL_PATH's folders, then the
// package's; regular files only, never opened while searching), the one dpc.load uses. A
// FIFO or device is refused at once by dpc_model_load_file. nullptr and a message on failure
// (for an unknown name libdpc's message lists the models the search finds).
inline dpc_model *load(const std::string &spec, std::string &error) {
    dpc_model *h = nullptr;
    const bool path =
        spec.find('/') != std::string::npos || (spec.size() > 5 && spec.compare(spec.size() - 5, 5, ".onnx") == 0);
    const dpc_status st =
        path ? dpc_model_load_file(spec.c_str(), nullptr, &h) : dpc_model_load_named(spec.c_str(), nullptr, &h);
    if (st != DPC_OK) error = dpc_last_error();
    return h;
}

// One libdpc sampler, shared by a plugin instance and all its forks.
struct Table {
    dpc_sampler *sampler = nullptr;
    ~Table() { dpc_sampler_free(sampler); }
};

// The plugin's net_dims when the scene does not give one (see the constructor): through the
// first light sample, which spectral variants draw after the wavelength.
constexpr uint32_t PLUGIN_NET_DIMS_RGB = 2, PLUGIN_NET_DIMS_SPECTRAL = 3;

inline std::shared_ptr<Table> build(const std::vector<std::string> &models, uint32_t spp, uint32_t dims, uint64_t seed,
                                    uint32_t fold_from, uint32_t net_dims, bool net_dims_given,
                                    uint32_t plugin_net_dims, uint32_t net_layout, uint32_t frames,
                                    std::string &error) {
    std::vector<dpc_model *> loaded;
    auto table = std::make_shared<Table>();
    for (const std::string &m : models) {
        std::string why;
        dpc_model *h = load(m, why);
        if (!h) {
            error = std::string("model \"") + m + "\": " + why;
            break;
        }
        loaded.push_back(h);
    }
    if (error.empty()) {
        dpc_sampler_options o;
        dpc_sampler_options_init(&o);
        std::vector<const dpc_model *> handles(loaded.begin(), loaded.end());
        o.models = handles.data();
        o.n_models = (uint32_t)handles.size();
        o.samples_per_pixel = spp;
        o.dimensions = dims;
        o.seed = seed;
        o.fold_from = fold_from;
        const char *order = dpc_model_metadata(handles[0], "dpc.order");
        const bool progressive = order && std::string(order) == "progressive";
        o.net_dims = net_dims_given || progressive || frames > 1 ? net_dims : plugin_net_dims;
        o.net_layout = net_layout;
        o.frames = frames;
        if (dpc_sampler_create(&o, &table->sampler) != DPC_OK) error = dpc_last_error();
    }
    for (dpc_model *h : loaded) dpc_model_free(h);
    return error.empty() ? table : nullptr;
}

inline uint32_t compact_bits(uint32_t v) { // every other bit of v, packed
    v &= 0x55555555u;
    v = (v | (v >> 1)) & 0x33333333u;
    v = (v | (v >> 2)) & 0x0F0F0F0Fu;
    v = (v | (v >> 4)) & 0x00FF00FFu;
    v = (v | (v >> 8)) & 0x0000FFFFu;
    return v;
}

} // namespace dpc_plugin

template <typename Float, typename Spectrum> class DpcSampler final : public Sampler<Float, Spectrum> {
  public:
    MI_IMPORT_BASE(Sampler, m_sample_count, m_base_seed, m_dimension_index, m_sample_index)
    MI_IMPORT_TYPES()

    DpcSampler(const Properties &props) : Base(props) {
        if constexpr (dr::is_jit_v<Float>)
            Throw("the dpc sampler serves Mitsuba's scalar variants (e.g. scalar_rgb); this is %s",
                  this->variant_name());
        const std::string model(props.get<std::string_view>("model", "bnot-2d-stratified"));
        if (model.find('\0') != std::string::npos) // C would read only the part before it
            Throw("property \"model\" contains a NUL character");
        m_models = dpc_plugin::split(model, ',');
        if (m_models.empty()) Throw("property \"model\" names no model");
        int dims = props.get<int>("dimensions", 16);
        int block = props.get<int>("block_size", 32);
        if (dims < 1 || dims > (int)DPC_SAMPLER_MAX_DIMENSIONS)
            Throw("property \"dimensions\" is %d, must be 1 .. %u", dims, DPC_SAMPLER_MAX_DIMENSIONS);
        if (block < 32 || block > 4096 || (block & (block - 1)))
            Throw("property \"block_size\" is %d: a power of two from 32 (the mask tile) to 4096", block);
        m_dims = (uint32_t)dims;
        // -1, the default: no dimension folded (libdpc's default)
        int fold_from = props.get<int>("fold_from", -1);
        if (fold_from < -1) Throw("property \"fold_from\" is %d: a dimension (>= 0), or -1 to fold none", fold_from);
        m_fold_from = fold_from < 0 ? DPC_SAMPLER_NO_FOLD : (uint32_t)fold_from;
        // Not given: nets in dimensions 0 and 1 (the film position and the integrators' first
        // sample, the direct and path tracers' light sample; in spectral variants 0-2, the
        // wavelength's 1-D sample coming between them), the sets beyond (BSDF samples, later
        // bounces), for set models; libdpc's default for progressive ones and frames. Measured in
        // Mitsuba's scenes (lab/rendering/slots_study.py, spectral_study.py): nets beyond the
        // light sample had up to 1.6 times the sets' MSE (glossy reflection) and never less. -1:
        // libdpc's default (every dimension a net at power-of-two counts).
        m_net_dims_given = props.has_property("net_dims");
        int net_dims = props.get<int>("net_dims", -1);
        if (net_dims < -1)
            Throw("property \"net_dims\" is %d: a dimension count (>= 0), or -1 for libdpc's default", net_dims);
        m_net_dims = net_dims < 0 ? DPC_SAMPLER_NET_DIMS_AUTO : (uint32_t)net_dims;
        // "auto", the default: libdpc's (screen-ordered nets below 64 spp, per pixel from there on)
        const std::string layout = props.get<std::string>("net_layout", "auto");
        if (layout != "auto" && layout != "screen" && layout != "pixel")
            Throw("property \"net_layout\" is \"%s\": \"auto\", \"screen\" or \"pixel\"", layout);
        m_net_layout = layout == "screen"  ? DPC_SAMPLER_NETS_SCREEN
                       : layout == "pixel" ? DPC_SAMPLER_NETS_PER_PIXEL
                                           : DPC_SAMPLER_NETS_AUTO;
        // real-time use: sample_count samples per frame, `frames` frames averaged; this render is
        // frame `frame` (the same render seed for every frame: the pixels must keep their place)
        int frames = props.get<int>("frames", 1), frame = props.get<int>("frame", 0);
        if (frames < 1 || frames > (int)DPC_SAMPLER_MAX_SPP)
            Throw("property \"frames\" is %d, must be 1 .. %u", frames, DPC_SAMPLER_MAX_SPP);
        if (frame < 0) Throw("property \"frame\" is %d, must be >= 0", frame);
        m_frames = (uint32_t)frames;
        m_frame = (uint32_t)frame;
        m_block_side = (uint32_t)block;
        m_block_pixels = (uint32_t)block * (uint32_t)block;
        rebuild();
    }

    void set_sample_count(uint32_t spp) override {
        if (spp == m_sample_count && m_table) return;
        m_sample_count = spp;
        rebuild();
    }

    ref<Sampler<Float, Spectrum>> fork() override {
        DpcSampler *s = new DpcSampler(*this);
        s->m_phase_known = false; // the fork's first seed starts a block
        return s;
    }

    ref<Sampler<Float, Spectrum>> clone() override { return new DpcSampler(*this); }

    void seed(UInt32 seed, uint32_t wavefront_size = (uint32_t)-1) override {
        Base::seed(seed, wavefront_size);
        if constexpr (!dr::is_jit_v<Float>) {
            if (!m_phase_known) {
                m_phase = seed;
                m_phase_known = true;
            }
            const uint32_t i = (uint32_t)(seed - m_phase) & (m_block_pixels - 1);
            // the block's first seed names the block (and the render's seed): it places the
            // block at its own tile of the sampler's pixel plane, so every block (and every
            // mi.render seed) draws its own values; the mask tiles across blocks all the same
            const uint32_t start = (uint32_t)seed - i, block = m_block_side;
            m_x = (start & 0xFFFFu) * block + dpc_plugin::compact_bits(i);
            m_y = (start >> 16) * block + dpc_plugin::compact_bits(i >> 1);
        }
    }

    Float next_1d(Mask active = true) override {
        if constexpr (!dr::is_jit_v<Float>) {
            DRJIT_MARK_USED(active);
            float v = 0.f;
            dpc_sampler_get_1d(m_table->sampler, m_x, m_y, index(), m_dimension_index++, &v);
            return v;
        } else {
            DRJIT_MARK_USED(active);
            Throw("not available in JIT variants");
        }
    }

    Point2f next_2d(Mask active = true) override {
        if constexpr (!dr::is_jit_v<Float>) {
            DRJIT_MARK_USED(active);
            float v[2] = {0.f, 0.f};
            dpc_sampler_get_2d(m_table->sampler, m_x, m_y, index(), m_dimension_index++, v);
            return Point2f(v[0], v[1]);
        } else {
            DRJIT_MARK_USED(active);
            Throw("not available in JIT variants");
        }
    }

    std::string to_string() const override {
        std::string models;
        for (const std::string &m : m_models) models += (models.empty() ? "" : ",") + m;
        return "DpcSampler[model = " + models + ", sample_count = " + std::to_string(m_sample_count) +
               ", dimensions = " + std::to_string(m_dims) + ", fold_from = " +
               (m_fold_from == DPC_SAMPLER_NO_FOLD ? std::string("none") : std::to_string(m_fold_from)) +
               ", net_dims = " +
               (!m_net_dims_given                         ? std::string("default")
                : m_net_dims == DPC_SAMPLER_NET_DIMS_AUTO ? std::string("auto")
                                                          : std::to_string(m_net_dims)) +
               ", net_layout = " +
               (m_net_layout == DPC_SAMPLER_NETS_SCREEN      ? std::string("screen")
                : m_net_layout == DPC_SAMPLER_NETS_PER_PIXEL ? std::string("pixel")
                                                             : std::string("auto")) +
               ", frames = " + std::to_string(m_frames) + ", frame = " + std::to_string(m_frame) +
               ", seed = " + std::to_string(m_base_seed) + "]";
    }

    MI_DECLARE_CLASS(DpcSampler)

  private:
    DpcSampler(const DpcSampler &other) : Base(other) {
        m_models = other.m_models;
        m_dims = other.m_dims;
        m_block_pixels = other.m_block_pixels;
        m_block_side = other.m_block_side;
        m_table = other.m_table;
        m_phase = other.m_phase;
        m_phase_known = other.m_phase_known;
        m_x = other.m_x;
        m_fold_from = other.m_fold_from;
        m_net_dims = other.m_net_dims;
        m_net_layout = other.m_net_layout;
        m_net_dims_given = other.m_net_dims_given;
        m_frames = other.m_frames;
        m_frame = other.m_frame;
        m_y = other.m_y;
    }

    // the libdpc sample index: this frame's samples (index + frame * sample_count, modulo 2^32)
    uint32_t index() const { return (uint32_t)m_sample_index + m_frame * m_sample_count; }

    void rebuild() {
        std::string error;
        constexpr uint32_t plugin_net_dims =
            is_spectral_v<Spectrum> ? dpc_plugin::PLUGIN_NET_DIMS_SPECTRAL : dpc_plugin::PLUGIN_NET_DIMS_RGB;
        m_table = dpc_plugin::build(m_models, m_sample_count, m_dims, m_base_seed, m_fold_from, m_net_dims,
                                    m_net_dims_given, plugin_net_dims, m_net_layout, m_frames, error);
        if (!m_table) Throw("dpc sampler: %s", error);
    }

    std::vector<std::string> m_models;
    uint32_t m_dims = 16, m_block_side = 32, m_block_pixels = 1024, m_fold_from = DPC_SAMPLER_NO_FOLD,
             m_net_dims = DPC_SAMPLER_NET_DIMS_AUTO, m_net_layout = DPC_SAMPLER_NETS_AUTO, m_frames = 1, m_frame = 0;
    bool m_net_dims_given = false;
    std::shared_ptr<dpc_plugin::Table> m_table;
    uint32_t m_phase = 0;
    bool m_phase_known = false;
    uint32_t m_x = 0, m_y = 0;
};

MI_EXPORT_PLUGIN(DpcSampler)
NAMESPACE_END(mitsuba)
