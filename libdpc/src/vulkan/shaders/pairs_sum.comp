#version 450
#extension GL_GOOGLE_include_directive : require
// After a split all-pairs pass (pairs.comp, pc.splits > 1): each point's filter sum is the sum of
// its partner ranges' sums, added in range order (a fixed order: the bits do not depend on
// timing); h * sum is added to the point's displacement.
#include "common.glsl"
layout(local_size_x = 128) in;

void main() {
    const uint set = gl_WorkGroupID.y, k = pc.k, S = pc.splits, total = pc.m * k;
    for (uint e = gl_GlobalInvocationID.x; e < total; e += gl_NumWorkGroups.x * 128u) {
        const uint i = e / k, q = e - i * k;
        uint d = 0u; // the subspace's q-th dimension
        for (uint seen = 0u;; d++)
            if (in_subspace(d) && seen++ == q) break;
        float sum = 0.0;
        for (uint part = 0u; part < S; part++) sum += split_sum[((set * S + part) * pc.m + i) * k + q];
        delta[(set * pc.m + i) * pc.n + d] += pc.h * sum;
    }
}
