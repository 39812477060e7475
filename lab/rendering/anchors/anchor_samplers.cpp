// The samplers dpc's sampler is measured against, as Mitsuba 3 plugins compiled like dpc's (C++,
// so that render times compare). Bench code, not the package: lab/rendering/anchors/__init__.py
// builds this file once and registers one plugin per sampler (the same library under each
// name; init_plugin below picks the class by the name Mitsuba loads it under).
//
//   zsobol        Ahmed and Wonka 2020, as pbrt-v4's ZSobolSampler describes it: the pixel's
//                 Morton code with its base-4 digits permuted from the top by a hash of the digits
//                 above (per dimension), followed by the sample index, indexes one 2-D Sobol'
//                 sequence, Owen-scrambled per dimension.
//   owen_sobol    one Sobol' sequence across all dimensions (Joe and Kuo's direction numbers),
//                 each dimension Owen-scrambled per pixel (Burley 2020's hash): joint structure.
//   padded_sobol  every 2-D (or 1-D) request its own Sobol' (0,2)-sequence, index shuffled and
//                 coordinates Owen-scrambled per pixel and dimension (pbrt-v4's PaddedSobol).
//   pmj02bn       Christensen et al. 2018's PMJ02BN: 16 tables of 256 points; per pixel and
//                 dimension pair a table, the index shuffled, a Cranley-Patterson rotation.
//   heitz2019     Heitz et al. 2019's published tables (256 spp x 256 dimensions of one
//                 Owen-scrambled Sobol' sequence, 128 x 128 scrambling and ranking keys optimised
//                 per sample count); the tile is moved by a hash of the seed so that seeds differ.
//                 Property "rotate" (a study's variant): each dimension's values also rotated
//                 toroidally per seed, as dpc's set slots are.
//
// Mitsuba tells a sampler only a seed per pixel: render_seed * w * h + block_id * block^2 + the
// pixel's Morton index in its block. As dpc's plugin, a fork's first seed starts a block; the
// pixel's position is its Morton index's (x, y) in the block, and the block's first seed is hashed
// into the randomisation. So screen-space structure is exact inside a block: the bench renders
// with the integrator's block_size equal to the image side (one block), for every sampler.
//
// Tables (the Sobol' direction numbers, PMJ02BN points, Heitz's keys) come from a binary file,
// property "tables", which the Python side writes.
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <mitsuba/core/properties.h>
#include <mitsuba/render/sampler.h>

NAMESPACE_BEGIN(mitsuba)

namespace anchors {

inline uint64_t mix64(uint64_t z) { // splitmix64's finaliser
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
inline uint64_t hash(uint64_t a, uint64_t b) {
    return mix64(a * 0x9E3779B97F4A7C15ull + mix64(b + 0x632BE59BD9B4E019ull));
}
inline uint64_t hash(uint64_t a, uint64_t b, uint64_t c) { return hash(hash(a, b), c); }

inline uint32_t reverse_bits(uint32_t v) {
    v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
    v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
    v = ((v >> 4) & 0x0F0F0F0Fu) | ((v & 0x0F0F0F0Fu) << 4);
    v = ((v >> 8) & 0x00FF00FFu) | ((v & 0x00FF00FFu) << 8);
    return (v >> 16) | (v << 16);
}

// Owen scrambling of a 32-bit fixed-point value: Laine and Karras 2011's hash on the reversed
// bits, with Burley 2020's constants (each bit flipped by a function of the bits above it).
inline uint32_t owen(uint32_t v, uint32_t seed) {
    v = reverse_bits(v);
    v ^= v * 0x3d20adeau;
    v += seed;
    v *= (seed >> 16) | 1u;
    v ^= v * 0x05526c56u;
    v ^= v * 0x53a22864u;
    return reverse_bits(v);
}

// A permutation of [0, n): Owen scrambling of the index's bits (a nested permutation of its
// power-of-two blocks), cycle-walked into [0, n) when n is not a power of two.
inline uint32_t shuffle(uint32_t i, uint32_t n, uint32_t seed) {
    uint32_t bits = 0;
    while ((1u << bits) < n) bits++;
    if (bits == 0) return 0;
    do {
        i = owen(i << (32 - bits), seed) >> (32 - bits);
    } while (i >= n);
    return i;
}

inline float to_unit(uint32_t v) { return (float)(v >> 8) * 0x1p-24f; } // exact, < 1

inline uint32_t compact_bits(uint32_t v) { // every other bit of v, packed
    v &= 0x55555555u;
    v = (v | (v >> 1)) & 0x33333333u;
    v = (v | (v >> 2)) & 0x0F0F0F0Fu;
    v = (v | (v >> 4)) & 0x00FF00FFu;
    v = (v | (v >> 8)) & 0x0000FFFFu;
    return v;
}

// Sobol' dimensions 0 and 1 (van der Corput and the second), index a, 32-bit fixed point.
inline uint32_t sobol2(uint64_t a, int dim) {
    uint32_t v = 0;
    if (dim == 0) return reverse_bits((uint32_t)a);
    uint32_t c = 1u << 31;
    for (; a; a >>= 1, c ^= c >> 1)
        if (a & 1) v ^= c;
    return v;
}

inline std::vector<uint8_t> read_file(const std::string &path) {
    std::vector<uint8_t> out;
    FILE *f = std::fopen(path.c_str(), "rb");
    if (!f) return out;
    uint8_t buf[65536];
    size_t got;
    while ((got = std::fread(buf, 1, sizeof buf, f)) > 0) out.insert(out.end(), buf, buf + got);
    std::fclose(f);
    return out;
}

} // namespace anchors

// What every anchor shares: the pixel and the block from Mitsuba's seed, and the counters.
template <typename Float, typename Spectrum> class AnchorSampler : public Sampler<Float, Spectrum> {
  public:
    MI_IMPORT_BASE(Sampler, m_sample_count, m_base_seed, m_dimension_index, m_sample_index)
    MI_IMPORT_TYPES()

    AnchorSampler(const Properties &props) : Base(props) {
        if constexpr (dr::is_jit_v<Float>) Throw("the anchor samplers serve scalar variants only");
        int block = props.get<int>("block_size", 32);
        if (block < 1 || block > 4096 || (block & (block - 1)))
            Throw("block_size %d: a power of two up to 4096", block);
        m_block_pixels = (uint32_t)block * (uint32_t)block;
        m_tables_path = std::string(props.get<std::string_view>("tables", ""));
    }

    void seed(UInt32 seed, uint32_t wavefront_size = (uint32_t)-1) override {
        Base::seed(seed, wavefront_size);
        if constexpr (!dr::is_jit_v<Float>) {
            if (!m_phase_known) {
                m_phase = seed;
                m_phase_known = true;
            }
            const uint32_t i = (uint32_t)(seed - m_phase) & (m_block_pixels - 1);
            m_x = anchors::compact_bits(i);
            m_y = anchors::compact_bits(i >> 1);
            const uint32_t block = (uint32_t)seed - i; // the block's first seed names it
            m_run_key = anchors::hash(m_base_seed, block);
            m_pixel_key = anchors::hash(((uint64_t)m_y << 32) | m_x, m_run_key);
        }
    }

  protected:
    AnchorSampler(const AnchorSampler &o) : Base(o) {
        m_block_pixels = o.m_block_pixels;
        m_tables_path = o.m_tables_path;
        m_phase = o.m_phase;
        m_phase_known = o.m_phase_known;
        m_x = o.m_x;
        m_y = o.m_y;
        m_run_key = o.m_run_key;
        m_pixel_key = o.m_pixel_key;
    }
    std::vector<uint8_t> tables(size_t bytes) const {
        std::vector<uint8_t> t = anchors::read_file(m_tables_path);
        if (t.size() != bytes) Throw("tables \"%s\": %zu bytes, expected %zu", m_tables_path, t.size(), bytes);
        return t;
    }
    uint64_t run_key() const { return m_run_key; } // the seed and the block, hashed once per pixel
    template <typename S> ref<Sampler<Float, Spectrum>> fork_as(const S &self) {
        S *s = new S(self);
        s->m_phase_known = false; // the fork's first seed starts a block
        return s;
    }

    uint32_t m_block_pixels = 1024;
    std::string m_tables_path;
    uint32_t m_phase = 0;
    bool m_phase_known = false;
    uint32_t m_x = 0, m_y = 0;
    uint64_t m_run_key = 0, m_pixel_key = 0;
};

#define ANCHOR_BOILERPLATE(Name)                                                                            \
    MI_IMPORT_BASE(AnchorSampler, m_sample_count, m_base_seed, m_dimension_index, m_sample_index, m_x, m_y, \
                   m_pixel_key)                                                                             \
    MI_IMPORT_TYPES()                                                                                       \
    ref<Sampler<Float, Spectrum>> fork() override { return this->fork_as(*this); }                          \
    ref<Sampler<Float, Spectrum>> clone() override { return new Name(*this); }                              \
    Float next_1d(Mask active = true) override {                                                            \
        DRJIT_MARK_USED(active);                                                                            \
        if constexpr (!dr::is_jit_v<Float>) return value(m_dimension_index++, 1).x();                       \
        else Throw("scalar variants only");                                                                 \
    }                                                                                                       \
    Point2f next_2d(Mask active = true) override {                                                          \
        DRJIT_MARK_USED(active);                                                                            \
        if constexpr (!dr::is_jit_v<Float>) {                                                               \
            Point2f v = value(m_dimension_index, 2);                                                        \
            m_dimension_index += 2;                                                                         \
            return v;                                                                                       \
        } else Throw("scalar variants only");                                                               \
    }                                                                                                       \
    std::string to_string() const override {                                                                \
        return std::string(#Name "[sample_count = ") + std::to_string(m_sample_count) + "]";                \
    }                                                                                                       \
    MI_DECLARE_CLASS(Name)

// ZSobol (Ahmed and Wonka 2020; pbrt-v4's ZSobolSampler).
template <typename Float, typename Spectrum> class ZSobolAnchor final : public AnchorSampler<Float, Spectrum> {
  public:
    ANCHOR_BOILERPLATE(ZSobolAnchor)
    ZSobolAnchor(const Properties &props) : Base(props) {}

  private:
    template <typename, typename> friend class AnchorSampler;
    ZSobolAnchor(const ZSobolAnchor &o) : Base(o) {}

    uint64_t index(uint32_t dim) const {
        static const uint8_t perm[24][4] = {{0, 1, 2, 3}, {0, 1, 3, 2}, {0, 2, 1, 3}, {0, 2, 3, 1}, {0, 3, 2, 1},
                                            {0, 3, 1, 2}, {1, 0, 2, 3}, {1, 0, 3, 2}, {1, 2, 0, 3}, {1, 2, 3, 0},
                                            {1, 3, 2, 0}, {1, 3, 0, 2}, {2, 1, 0, 3}, {2, 1, 3, 0}, {2, 0, 1, 3},
                                            {2, 0, 3, 1}, {2, 3, 0, 1}, {2, 3, 1, 0}, {3, 1, 2, 0}, {3, 1, 0, 2},
                                            {3, 2, 1, 0}, {3, 2, 0, 1}, {3, 0, 2, 1}, {3, 0, 1, 2}};
        uint32_t log2spp = 0;
        while ((1u << log2spp) < m_sample_count) log2spp++;
        uint64_t morton = 0;
        for (int b = 0; b < 16; b++)
            morton |= (uint64_t)((m_x >> b) & 1) << (2 * b) | (uint64_t)((m_y >> b) & 1) << (2 * b + 1);
        const uint64_t code = (morton << log2spp) | m_sample_index;
        const bool odd = log2spp & 1;
        const int digits = 16 + (int)(log2spp + 1) / 2; // covers 16-bit pixel coordinates
        const uint64_t key = this->run_key() + dim;
        uint64_t out = 0;
        for (int i = digits - 1; i >= (odd ? 1 : 0); i--) {
            const int shift = 2 * i - (odd ? 1 : 0);
            const uint32_t digit = (code >> shift) & 3;
            const uint64_t higher = code >> (shift + 2);
            out |= (uint64_t)perm[anchors::hash(higher, key) % 24][digit] << shift;
        }
        if (odd) out |= (code & 1) ^ (anchors::hash(code >> 1, key) & 1);
        return out;
    }
    Point2f value(uint32_t dim, int) const {
        const uint64_t i = index(dim);
        const uint64_t h = anchors::hash(this->run_key(), dim, 0x5A0B);
        return Point2f(anchors::to_unit(anchors::owen(anchors::sobol2(i, 0), (uint32_t)h)),
                       anchors::to_unit(anchors::owen(anchors::sobol2(i, 1), (uint32_t)(h >> 32))));
    }
};

// Owen-scrambled Sobol' across dimensions: one 1-D dimension of the sequence per value.
template <typename Float, typename Spectrum> class OwenSobolAnchor final : public AnchorSampler<Float, Spectrum> {
  public:
    ANCHOR_BOILERPLATE(OwenSobolAnchor)
    static constexpr uint32_t DIMS = 256; // past these, dimensions wrap with other scrambles
    OwenSobolAnchor(const Properties &props) : Base(props) {
        std::vector<uint8_t> t = this->tables(DIMS * 32 * 4);
        m_v = std::make_shared<std::vector<uint32_t>>(DIMS * 32);
        std::memcpy(m_v->data(), t.data(), t.size());
    }

  private:
    template <typename, typename> friend class AnchorSampler;
    OwenSobolAnchor(const OwenSobolAnchor &o) : Base(o) { m_v = o.m_v; }
    float one(uint32_t dim) const {
        const uint32_t *v = m_v->data() + (dim % DIMS) * 32;
        uint32_t s = 0;
        for (uint32_t a = m_sample_index, k = 0; a; a >>= 1, k++)
            if (a & 1) s ^= v[k];
        return anchors::to_unit(anchors::owen(s, (uint32_t)anchors::hash(m_pixel_key, dim)));
    }
    Point2f value(uint32_t dim, int n) const { return Point2f(one(dim), n == 2 ? one(dim + 1) : 0.f); }
    std::shared_ptr<std::vector<uint32_t>> m_v;
};

// Padded Sobol': every request a (0,2)-sequence of its own.
template <typename Float, typename Spectrum> class PaddedSobolAnchor final : public AnchorSampler<Float, Spectrum> {
  public:
    ANCHOR_BOILERPLATE(PaddedSobolAnchor)
    PaddedSobolAnchor(const Properties &props) : Base(props) {}

  private:
    template <typename, typename> friend class AnchorSampler;
    PaddedSobolAnchor(const PaddedSobolAnchor &o) : Base(o) {}
    Point2f value(uint32_t dim, int) const {
        const uint64_t h = anchors::hash(m_pixel_key, dim);
        const uint32_t i = anchors::shuffle(m_sample_index, m_sample_count, (uint32_t)h);
        const uint64_t s = anchors::hash(h, 0x0E11);
        return Point2f(anchors::to_unit(anchors::owen(anchors::sobol2(i, 0), (uint32_t)s)),
                       anchors::to_unit(anchors::owen(anchors::sobol2(i, 1), (uint32_t)(s >> 32))));
    }
};

// PMJ02BN: a prefix of one of 16 tables per pixel and dimension pair.
template <typename Float, typename Spectrum> class Pmj02bnAnchor final : public AnchorSampler<Float, Spectrum> {
  public:
    ANCHOR_BOILERPLATE(Pmj02bnAnchor)
    static constexpr uint32_t TABLES = 16, POINTS = 256;
    Pmj02bnAnchor(const Properties &props) : Base(props) {
        if (m_sample_count > POINTS) Throw("pmj02bn: at most %u samples per pixel", POINTS);
        std::vector<uint8_t> t = this->tables(TABLES * POINTS * 2 * 4);
        m_points = std::make_shared<std::vector<uint32_t>>(TABLES * POINTS * 2);
        std::memcpy(m_points->data(), t.data(), t.size());
    }
    void set_sample_count(uint32_t spp) override {
        if (spp > POINTS) Throw("pmj02bn: at most %u samples per pixel", POINTS);
        m_sample_count = spp;
    }

  private:
    template <typename, typename> friend class AnchorSampler;
    Pmj02bnAnchor(const Pmj02bnAnchor &o) : Base(o) { m_points = o.m_points; }
    Point2f value(uint32_t dim, int) const {
        const uint64_t h = anchors::hash(m_pixel_key, dim);
        const uint32_t table = (uint32_t)(h >> 60);
        const uint32_t i = anchors::shuffle(m_sample_index, m_sample_count, (uint32_t)h);
        const uint32_t *p = m_points->data() + (table * POINTS + i) * 2;
        const uint64_t r = anchors::hash(h, 0xC0DE);
        return Point2f(anchors::to_unit(p[0] + (uint32_t)r), anchors::to_unit(p[1] + (uint32_t)(r >> 32)));
    }
    std::shared_ptr<std::vector<uint32_t>> m_points;
};

// Heitz et al. 2019: their sampler function, per sample count the keys optimised for it.
template <typename Float, typename Spectrum> class Heitz2019Anchor final : public AnchorSampler<Float, Spectrum> {
  public:
    ANCHOR_BOILERPLATE(Heitz2019Anchor)
    // file layout: sobol[256 * 256], then for spp = 1, 2, 4, ..., 256: scrambling[128 * 128 * 8],
    // ranking[128 * 128 * 8] (bytes)
    static constexpr size_t SOBOL = 256 * 256, TILE = 128 * 128 * 8, COUNTS = 9;
    Heitz2019Anchor(const Properties &props) : Base(props) {
        m_data = std::make_shared<std::vector<uint8_t>>(this->tables(SOBOL + COUNTS * 2 * TILE));
        // a study's variant, not the published sampler: every value of a dimension rotated
        // toroidally by a random amount per seed, as dpc's set slots are (uniform over seeds)
        m_rotate = props.get<bool>("rotate", false);
        select();
    }
    void set_sample_count(uint32_t spp) override {
        m_sample_count = spp;
        select();
    }

  private:
    template <typename, typename> friend class AnchorSampler;
    Heitz2019Anchor(const Heitz2019Anchor &o) : Base(o) {
        m_data = o.m_data;
        m_level = o.m_level;
        m_rotate = o.m_rotate;
    }
    void select() { // the keys optimised for the smallest tabulated count >= spp
        if (m_sample_count > 256) Throw("heitz2019: at most 256 samples per pixel");
        m_level = 0;
        while ((1u << m_level) < m_sample_count) m_level++;
    }
    float one(uint32_t dim) const {
        const uint64_t k = this->run_key();
        const uint32_t i = (m_x + (uint32_t)k) & 127, j = (m_y + (uint32_t)(k >> 32)) & 127; // the seed's tile offset
        const uint8_t *scr = m_data->data() + SOBOL + m_level * 2 * TILE, *rnk = scr + TILE;
        const uint32_t d = dim & 255, s = m_sample_index & 255;
        // the published code reads the ranking key at [d + pixel * 8], past the pixel's 8 keys for
        // d >= 8 (and past the table's end in the last pixels); d mod 8, as for the scrambling key
        const uint32_t ranked = s ^ rnk[(d & 7) + (i + j * 128) * 8];
        const uint32_t v = (*m_data)[d + ranked * 256] ^ scr[(d & 7) + (i + j * 128) * 8];
        const float u = (0.5f + (float)v) / 256.0f;
        if (!m_rotate) return u;
        const float r = u + (float)(anchors::hash(k, dim, 0xC0) >> 40) * 0x1p-24f;
        return r >= 1.0f ? r - 1.0f : r;
    }
    Point2f value(uint32_t dim, int n) const { return Point2f(one(dim), n == 2 ? one(dim + 1) : 0.f); }
    std::shared_ptr<std::vector<uint8_t>> m_data;
    uint32_t m_level = 0;
    bool m_rotate = false;
};

extern "C" MI_EXPORT void init_plugin(std::string_view name, PluginRegisterFn fn) {
    if (name == "zsobol") {
        MI_REGISTER_PLUGIN(fn, name, ZSobolAnchor)
    } else if (name == "owen_sobol") {
        MI_REGISTER_PLUGIN(fn, name, OwenSobolAnchor)
    } else if (name == "padded_sobol") {
        MI_REGISTER_PLUGIN(fn, name, PaddedSobolAnchor)
    } else if (name == "pmj02bn") {
        MI_REGISTER_PLUGIN(fn, name, Pmj02bnAnchor)
    } else if (name == "heitz2019") {
        MI_REGISTER_PLUGIN(fn, name, Heitz2019Anchor)
    }
}

NAMESPACE_END(mitsuba)
