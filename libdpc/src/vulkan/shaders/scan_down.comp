#version 450
#extension GL_GOOGLE_include_directive : require
// Grid pass 4: starts[c] = number of points in cells before c (starts[cells] = m), from the
// counts and the scanned block sums.
#include "common.glsl"
layout(local_size_x = 256) in;

shared uint sums[SCAN_THREADS];

void main() {
    const uint set = gl_WorkGroupID.y, lid = gl_LocalInvocationID.x;
    const uint cbase = set * pc.cstride, total = pc.cells + 1u;
    for (uint b = gl_WorkGroupID.x; b < pc.nblocks; b += gl_NumWorkGroups.x) {
        const uint c0 = b * SCAN_BLOCK + lid * SCAN_PER_THREAD;
        uint v[SCAN_PER_THREAD];
        uint s = 0u;
        for (uint e = 0u; e < SCAN_PER_THREAD; e++) {
            v[e] = c0 + e < total ? counts[cbase + c0 + e] : 0u;
            s += v[e];
        }
        sums[lid] = s;
        barrier();
        for (uint w = 1u; w < SCAN_THREADS; w <<= 1u) {
            const uint add = lid >= w ? sums[lid - w] : 0u;
            barrier();
            sums[lid] += add;
            barrier();
        }
        uint run = partials[set * pc.nblocks + b] + sums[lid] - s;
        for (uint e = 0u; e < SCAN_PER_THREAD; e++) {
            if (c0 + e < total) starts[cbase + c0 + e] = run;
            run += v[e];
        }
        barrier();
    }
}
