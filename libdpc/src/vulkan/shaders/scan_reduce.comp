#version 450
#extension GL_GOOGLE_include_directive : require
// Grid pass 2: the sum of each block of SCAN_BLOCK cell counts, into partials[].
#include "common.glsl"
layout(local_size_x = 256) in;

shared uint sums[SCAN_THREADS];

void main() {
    const uint set = gl_WorkGroupID.y, lid = gl_LocalInvocationID.x;
    const uint cbase = set * pc.cstride, total = pc.cells + 1u;
    for (uint b = gl_WorkGroupID.x; b < pc.nblocks; b += gl_NumWorkGroups.x) {
        uint s = 0u;
        for (uint e = 0u; e < SCAN_PER_THREAD; e++) {
            const uint c = b * SCAN_BLOCK + lid * SCAN_PER_THREAD + e;
            if (c < total) s += counts[cbase + c];
        }
        sums[lid] = s;
        barrier();
        for (uint w = SCAN_THREADS / 2u; w > 0u; w >>= 1u) {
            if (lid < w) sums[lid] += sums[lid + w];
            barrier();
        }
        if (lid == 0u) partials[set * pc.nblocks + b] = sums[0];
        barrier();
    }
}
