#version 450
#extension GL_GOOGLE_include_directive : require
// All-pairs filter sum for subspaces where a grid does not pay (few points, more than 4
// dimensions, radius near the domain size): each workgroup holds 64 points and streams every
// point of the set through shared memory in tiles. KMAX (a specialization constant: 4, 16 or
// 64) bounds the subspace dimensions so per-point arrays stay small.
#include "common.glsl"
layout(local_size_x = 64) in;
layout(constant_id = 0) const uint KMAX = 4u;

#define TILE_FLOATS 2048u
shared float tile[TILE_FLOATS];
shared uint sdim[64];

void main() {
    const uint set = gl_WorkGroupID.y, lid = gl_LocalInvocationID.x;
    const uint pbase = set * pc.m, k = pc.k;
    if (lid == 0u) {
        uint q = 0u;
        for (uint d = 0u; d < pc.n; d++) {
            const uint bit = d < 32u ? (pc.mask_lo >> d) & 1u : (pc.mask_hi >> (d - 32u)) & 1u;
            if (bit != 0u) sdim[q++] = d;
        }
    }
    barrier();
    const uint per_tile = TILE_FLOATS / k;
    const uint blocks = (pc.m + 63u) / 64u;
    for (uint blk = gl_WorkGroupID.x; blk < blocks; blk += gl_NumWorkGroups.x) {
        const uint i = blk * 64u + lid;
        const bool live = i < pc.m;
        float xi[KMAX], sum[KMAX];
        for (uint q = 0u; q < k; q++) {
            xi[q] = live ? x[(pbase + i) * pc.n + sdim[q]] : 0.0;
            sum[q] = 0.0;
        }
        for (uint j0 = 0u; j0 < pc.m; j0 += per_tile) {
            const uint cnt = min(per_tile, pc.m - j0);
            barrier(); // the previous tile has been read
            for (uint e = lid; e < cnt * k; e += 64u) {
                const uint p = e / k, q = e - p * k;
                tile[e] = x[(pbase + j0 + p) * pc.n + sdim[q]];
            }
            barrier();
            if (!live) continue;
            for (uint p = 0u; p < cnt; p++) {
                float d2 = 0.0;
                for (uint q = 0u; q < k; q++) {
                    float t = tile[p * k + q] - xi[q];
                    t -= roundEven(t);
                    d2 += t * t;
                }
                const float d = sqrt(d2);
                if (!(d > pc.cutoff && d < pc.radius)) continue;
                const float u = min(d * pc.scale, pc.umax);
                const int b = min(int(u), pc.qmax);
                const float f = u - float(b);
                const float coef = (tables[pc.w_off + uint(b)] + f * tables[pc.dw_off + uint(b)]) / d;
                for (uint q = 0u; q < k; q++) {
                    float t = tile[p * k + q] - xi[q];
                    t -= roundEven(t);
                    sum[q] += coef * t;
                }
            }
        }
        if (live)
            for (uint q = 0u; q < k; q++) delta[(pbase + i) * pc.n + sdim[q]] += pc.h * sum[q];
    }
}
