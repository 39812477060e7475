#version 450
#extension GL_GOOGLE_include_directive : require
// End of a layer: y = x + (sum of subspace displacements) / c_k on moving dimensions, wrapped
// into [0, 1) (1 and non-finite values become 0, as on the CPU); clears the displacements.
#include "common.glsl"
layout(local_size_x = 128) in;

void main() {
    const uint base = gl_WorkGroupID.y * pc.m * pc.n, total = pc.m * pc.n;
    for (uint e = gl_GlobalInvocationID.x; e < total; e += gl_NumWorkGroups.x * 128u) {
        const float c = tables[pc.c_off + e % pc.n];
        if (c != 0.0) {
            const float step = delta[base + e];
            float y = x[base + e] + (c == 1.0 ? step : step / c);
            y -= floor(y);
            x[base + e] = (y >= 0.0 && y < 1.0) ? y : 0.0;
        }
        delta[base + e] = 0.0;
    }
}
