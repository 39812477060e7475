#version 450
#extension GL_GOOGLE_include_directive : require
// Grid pass 7: for every point (in slot order, so neighbouring invocations read the same
// cells), the filter sum of docs/model-format.md section 3 over the (2R+1)^k cells around it,
// rows of cells along axis 0 in a fixed order (axis 1 fastest, as on the CPU); h * sum is added
// to the point's displacement. Axes the subspace lacks (k < 4) have one offset, 0, so the same
// code serves k = 1 .. 4 without arrays (dynamically indexed arrays are slow on GPUs).
#include "common.glsl"
layout(local_size_x = 128) in;

// Adds the contributions of slots [j, j1) to sum.
void gather(uint j, uint j1, vec4 xi, inout vec4 sum) {
    for (; j < j1; j++) {
        vec4 t = coords[j] - xi;
        t -= roundEven(t); // minimum-image toroidal difference
        const float d = sqrt(dot(t, t));
        if (!(d > pc.cutoff && d < pc.radius)) continue;
        const float u = min(d * pc.scale, pc.umax);
        const int q = min(int(u), pc.qmax);
        const float f = u - float(q);
        sum += ((tables[pc.w_off + uint(q)] + f * tables[pc.dw_off + uint(q)]) / d) * t;
    }
}

int wrap(int v, int G) { return v < 0 ? v + G : (v >= G ? v - G : v); }

void main() {
    const uint set = gl_WorkGroupID.y;
    const uint pbase = set * pc.m, cbase = set * pc.cstride;
    const int G = int(pc.G), R = int(pc.R);
    const int R1 = pc.k > 1u ? R : 0, R2 = pc.k > 2u ? R : 0, R3 = pc.k > 3u ? R : 0;
    for (uint s = gl_GlobalInvocationID.x; s < pc.m; s += gl_NumWorkGroups.x * 128u) {
        const uint i = sorted_idx[pbase + s];
        const vec4 xi = coords[pbase + s];
        uint id = cell_of[pbase + i];
        const int c0 = int(id % pc.G);
        id /= pc.G;
        const int c1 = int(id % pc.G);
        id /= pc.G;
        const int c2 = int(id % pc.G);
        const int c3 = int(id / pc.G);
        // Axis 0 of every row: cells [lo, hi], split where it wraps.
        const int lo = c0 - R, hi = c0 + R;
        const uint a0 = uint(lo < 0 ? lo + G : lo);
        const uint b0 = uint(lo < 0 || hi >= G ? G : hi + 1);
        const uint b1 = uint(lo < 0 ? hi + 1 : (hi >= G ? hi - G + 1 : 0));
        vec4 sum = vec4(0.0);
        for (int o3 = -R3; o3 <= R3; o3++) {
            const uint r3 = uint(R3 > 0 ? wrap(c3 + o3, G) : 0);
            for (int o2 = -R2; o2 <= R2; o2++) {
                const uint r2 = r3 * pc.G + uint(R2 > 0 ? wrap(c2 + o2, G) : 0);
                for (int o1 = -R1; o1 <= R1; o1++) {
                    const uint row = cbase + (r2 * pc.G + uint(R1 > 0 ? wrap(c1 + o1, G) : 0)) * pc.G;
                    gather(pbase + starts[row + a0], pbase + starts[row + b0], xi, sum);
                    if (b1 > 0u) gather(pbase + starts[row], pbase + starts[row + b1], xi, sum);
                }
            }
        }
        const uint p = (pbase + i) * pc.n;
        delta[p + grid_dim(0u)] += pc.h * sum.x;
        if (pc.k > 1u) delta[p + grid_dim(1u)] += pc.h * sum.y;
        if (pc.k > 2u) delta[p + grid_dim(2u)] += pc.h * sum.z;
        if (pc.k > 3u) delta[p + grid_dim(3u)] += pc.h * sum.w;
    }
}
