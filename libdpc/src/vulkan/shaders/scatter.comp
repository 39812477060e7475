#version 450
#extension GL_GOOGLE_include_directive : require
// Grid pass 5: each point takes a slot of its cell. The order within a cell depends on atomic
// timing here; cellsort.comp makes it the point-index order. Counts return to zero.
#include "common.glsl"
layout(local_size_x = 128) in;

void main() {
    const uint set = gl_WorkGroupID.y;
    const uint pbase = set * pc.m, cbase = set * pc.cstride;
    for (uint i = gl_GlobalInvocationID.x; i < pc.m; i += gl_NumWorkGroups.x * 128u) {
        const uint id = cell_of[pbase + i];
        const uint left = atomicAdd(counts[cbase + id], 0xFFFFFFFFu); // decrement, old value >= 1
        sorted_idx[pbase + starts[cbase + id] + left - 1u] = i;
    }
}
