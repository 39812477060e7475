// Shared declarations of the libdpc compute shaders: one descriptor set and one push-constant
// block for every pipeline (vk_engine.c fills them; the C struct dpc_vk_params mirrors Params).
// Every buffer holds `sets` point sets back to back; gl_WorkGroupID.y is the set.

layout(push_constant) uniform Params {
    uint m;        // points per set
    uint n;        // dimensions per point
    uint k;        // dimensions of the subspace
    uint cells;    // G^k cells of the grid (grid passes)
    uint G;        // cells per axis
    uint R;        // cell offsets searched per axis
    uint cstride;  // per-set stride of counts and starts (>= cells + 1)
    uint nblocks;  // scan blocks of SCAN_BLOCK cells per set
    uint w_off;    // kernel table of the subspace in `tables`
    uint dw_off;   // its slopes w[q+1] - w[q]
    int qmax;      // b - 2
    uint c_off;    // the layer's per-dimension subspace counts c_k in `tables`
    float h;       // mean spacing of the subspace
    float radius;  // r_t
    float cutoff;  // e_t
    float scale;   // (b - 1) / r_t
    float umax;    // b - 1
    uint mask_lo;  // subspace dimensions 0..31 (all-pairs pass)
    uint mask_hi;  // dimensions 32..63
    uint dims;     // grid passes (k <= 4): dimension of subspace axis q in bits 8q .. 8q+7
    uint splits;   // all-pairs pass: partner ranges per point (1: no split, pairs_sum.comp not run)
} pc;

layout(std430, set = 0, binding = 0) buffer PointsBuf { float x[]; };        // sets * m * n
layout(std430, set = 0, binding = 1) buffer DeltaBuf { float delta[]; };     // sets * m * n
layout(std430, set = 0, binding = 2) buffer CellOfBuf { uint cell_of[]; };   // sets * m
layout(std430, set = 0, binding = 3) buffer CountsBuf { uint counts[]; };    // sets * cstride
layout(std430, set = 0, binding = 4) buffer StartsBuf { uint starts[]; };    // sets * cstride
layout(std430, set = 0, binding = 5) buffer SortedBuf { uint sorted_idx[]; }; // sets * m
layout(std430, set = 0, binding = 6) buffer CoordsBuf { vec4 coords[]; };    // sets * m
layout(std430, set = 0, binding = 7) readonly buffer TablesBuf { float tables[]; };
layout(std430, set = 0, binding = 8) buffer PartialsBuf { uint partials[]; }; // sets * nblocks
layout(std430, set = 0, binding = 9) buffer SplitBuf { float split_sum[]; };  // sets * splits * m * k

#define SCAN_THREADS 256u
#define SCAN_PER_THREAD 4u
#define SCAN_BLOCK (SCAN_THREADS * SCAN_PER_THREAD)

// Dimension of subspace axis q (grid passes).
uint grid_dim(uint q) { return (pc.dims >> (8u * q)) & 255u; }

// Whether dimension d is in the subspace (all-pairs passes).
bool in_subspace(uint d) { return ((d < 32u ? (pc.mask_lo >> d) : (pc.mask_hi >> (d - 32u))) & 1u) != 0u; }
