#version 450
#extension GL_GOOGLE_include_directive : require
// Grid pass 6: one invocation per cell sorts the cell's slots by point index, so every later
// sum runs in an order that does not depend on atomic timing (bit-identical runs), then copies
// the subspace coordinates of those points, in slot order, for the neighbour pass.
#include "common.glsl"
layout(local_size_x = 128) in;

void swap_slots(uint a, uint b) {
    const uint t = sorted_idx[a];
    sorted_idx[a] = sorted_idx[b];
    sorted_idx[b] = t;
}

// Heapsort of sorted_idx[lo .. lo + len): O(len log len) however crowded a cell gets.
void heap_sort(uint lo, uint len) {
    for (uint start = len / 2u; start-- > 0u;) {
        uint root = start;
        while (2u * root + 1u < len) {
            uint child = 2u * root + 1u;
            if (child + 1u < len && sorted_idx[lo + child] < sorted_idx[lo + child + 1u]) child++;
            if (sorted_idx[lo + root] >= sorted_idx[lo + child]) break;
            swap_slots(lo + root, lo + child);
            root = child;
        }
    }
    for (uint end = len; end-- > 1u;) {
        swap_slots(lo, lo + end);
        uint root = 0u;
        while (2u * root + 1u < end) {
            uint child = 2u * root + 1u;
            if (child + 1u < end && sorted_idx[lo + child] < sorted_idx[lo + child + 1u]) child++;
            if (sorted_idx[lo + root] >= sorted_idx[lo + child]) break;
            swap_slots(lo + root, lo + child);
            root = child;
        }
    }
}

void main() {
    const uint set = gl_WorkGroupID.y;
    const uint pbase = set * pc.m, cbase = set * pc.cstride;
    for (uint c = gl_GlobalInvocationID.x; c < pc.cells; c += gl_NumWorkGroups.x * 128u) {
        const uint s0 = pbase + starts[cbase + c], s1 = pbase + starts[cbase + c + 1u];
        if (s1 - s0 <= 16u) {
            for (uint a = s0 + 1u; a < s1; a++) { // insertion sort: cells hold a few points
                const uint v = sorted_idx[a];
                uint b = a;
                while (b > s0 && sorted_idx[b - 1u] > v) {
                    sorted_idx[b] = sorted_idx[b - 1u];
                    b--;
                }
                sorted_idx[b] = v;
            }
        } else {
            heap_sort(s0, s1 - s0);
        }
        for (uint s = s0; s < s1; s++) {
            const uint p = (pbase + sorted_idx[s]) * pc.n;
            vec4 v = vec4(0.0);
            for (uint q = 0u; q < pc.k; q++) v[q] = x[p + grid_dim(q)];
            coords[s] = v;
        }
    }
}
