#version 450
#extension GL_GOOGLE_include_directive : require
// Grid pass 1: the cell of every point (axis 0 varies fastest, as on the CPU) and the number of
// points per cell. counts[] is zero on entry (the scatter pass leaves it so).
#include "common.glsl"
layout(local_size_x = 128) in;

void main() {
    const uint set = gl_WorkGroupID.y;
    const uint pbase = set * pc.m, cbase = set * pc.cstride;
    const float g = float(pc.G);
    for (uint i = gl_GlobalInvocationID.x; i < pc.m; i += gl_NumWorkGroups.x * 128u) {
        uint id = 0u;
        for (uint q = pc.k; q-- > 0u;) {
            const uint c = uint(x[(pbase + i) * pc.n + grid_dim(q)] * g);
            id = id * pc.G + min(c, pc.G - 1u);
        }
        cell_of[pbase + i] = id;
        atomicAdd(counts[cbase + id], 1u);
    }
}
