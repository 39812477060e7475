#version 450
#extension GL_GOOGLE_include_directive : require
// All-pairs filter sum for subspaces where a grid does not pay (few points, more than 4
// dimensions, radius near the domain size): each workgroup holds 64 points and streams the
// points of one partner range through shared memory in tiles. With pc.splits = 1 the range is
// the whole set and the sum goes to the displacements; with more (a few thousand points, too few
// workgroups to fill a GPU otherwise) each range's sum goes to split_sum and pairs_sum.comp adds
// them in range order. Coordinates are packed in NV4 vec4s per point (a specialization constant,
// ceil(k / 4); unused lanes are 0 and contribute nothing), so the per-point loops have constant
// trip counts and the arrays stay in registers.
#include "common.glsl"
layout(local_size_x = 64) in;
layout(constant_id = 0) const uint NV4 = 1u;

#define TILE_VEC4 512u
shared vec4 tile[TILE_VEC4];
shared uint sdim[64];

void main() {
    const uint set = gl_WorkGroupID.y, lid = gl_LocalInvocationID.x;
    const uint pbase = set * pc.m, k = pc.k;
    if (lid == 0u) {
        uint q = 0u;
        for (uint d = 0u; d < pc.n; d++)
            if (in_subspace(d)) sdim[q++] = d;
    }
    barrier();
    const uint per_tile = TILE_VEC4 / NV4, lanes = 4u * NV4;
    const uint S = pc.splits, chunk = (pc.m + S - 1u) / S;
    const uint units = ((pc.m + 63u) / 64u) * S; // (block of 64 points, partner range) pairs
    for (uint unit = gl_WorkGroupID.x; unit < units; unit += gl_NumWorkGroups.x) {
        const uint blk = unit / S, part = unit - blk * S;
        const uint jb = min(pc.m, part * chunk), je = min(pc.m, jb + chunk);
        const uint i = blk * 64u + lid;
        const bool live = i < pc.m;
        vec4 xi[NV4], sum[NV4], t[NV4];
        for (uint c = 0u; c < NV4; c++) {
            vec4 v = vec4(0.0);
            for (uint l = 0u; l < 4u; l++) {
                const uint q = 4u * c + l;
                if (live && q < k) v[l] = x[(pbase + i) * pc.n + sdim[q]];
            }
            xi[c] = v;
            sum[c] = vec4(0.0);
        }
        for (uint j0 = jb; j0 < je; j0 += per_tile) {
            const uint cnt = min(per_tile, je - j0);
            barrier(); // the previous tile has been read
            for (uint e = lid; e < cnt * lanes; e += 64u) {
                const uint p = e / lanes, q = e - p * lanes;
                tile[e >> 2u][e & 3u] = q < k ? x[(pbase + j0 + p) * pc.n + sdim[q]] : 0.0;
            }
            barrier();
            if (!live) continue;
            for (uint p = 0u; p < cnt; p++) {
                float d2 = 0.0;
                for (uint c = 0u; c < NV4; c++) {
                    t[c] = tile[p * NV4 + c] - xi[c];
                    t[c] -= roundEven(t[c]); // minimum-image toroidal difference
                    d2 += dot(t[c], t[c]);
                }
                const float d = sqrt(d2);
                if (!(d > pc.cutoff && d < pc.radius)) continue;
                const float u = min(d * pc.scale, pc.umax);
                const int b = min(int(u), pc.qmax);
                const float f = u - float(b);
                const float coef = (tables[pc.w_off + uint(b)] + f * tables[pc.dw_off + uint(b)]) / d;
                for (uint c = 0u; c < NV4; c++) sum[c] += coef * t[c];
            }
        }
        if (live)
            for (uint c = 0u; c < NV4; c++)
                for (uint l = 0u; l < 4u; l++) {
                    const uint q = 4u * c + l;
                    if (q >= k) continue;
                    if (S == 1u) delta[(pbase + i) * pc.n + sdim[q]] += pc.h * sum[c][l];
                    else split_sum[((set * S + part) * pc.m + i) * k + q] = sum[c][l];
                }
    }
}
