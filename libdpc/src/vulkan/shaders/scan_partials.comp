#version 450
#extension GL_GOOGLE_include_directive : require
// Grid pass 3: exclusive prefix sum of the block sums of one set (one workgroup per set).
#include "common.glsl"
layout(local_size_x = 256) in;

shared uint sums[SCAN_THREADS];

void main() {
    const uint set = gl_WorkGroupID.y, lid = gl_LocalInvocationID.x;
    const uint base = set * pc.nblocks;
    uint carry = 0u;
    for (uint b0 = 0u; b0 < pc.nblocks; b0 += SCAN_THREADS) {
        const uint b = b0 + lid;
        const uint v = b < pc.nblocks ? partials[base + b] : 0u;
        sums[lid] = v;
        barrier();
        for (uint w = 1u; w < SCAN_THREADS; w <<= 1u) { // Hillis-Steele inclusive scan
            const uint add = lid >= w ? sums[lid - w] : 0u;
            barrier();
            sums[lid] += add;
            barrier();
        }
        if (b < pc.nblocks) partials[base + b] = carry + sums[lid] - v;
        carry += sums[SCAN_THREADS - 1u];
        barrier();
    }
}
