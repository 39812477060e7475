#version 450
#extension GL_GOOGLE_include_directive : require
// Grid pass 7: for every point (in slot order, so neighbouring invocations read the same
// cells), the filter sum of docs/model-format.md section 3 over the (2R+1)^k cells around it,
// walked in a fixed order; h * sum is added to the point's displacement.
#include "common.glsl"
layout(local_size_x = 128) in;

void main() {
    const uint set = gl_WorkGroupID.y;
    const uint pbase = set * pc.m, cbase = set * pc.cstride;
    const int G = int(pc.G), R = int(pc.R);
    for (uint s = gl_GlobalInvocationID.x; s < pc.m; s += gl_NumWorkGroups.x * 128u) {
        const uint i = sorted_idx[pbase + s];
        const vec4 xi = coords[pbase + s];
        uint id = cell_of[pbase + i];
        int c[4], off[4];
        for (uint q = 0u; q < 4u; q++) {
            c[q] = int(id % pc.G);
            id /= pc.G;
            off[q] = -R;
        }
        vec4 sum = vec4(0.0);
        for (;;) {
            uint row = 0u; // cell id of (0, c1 + o1, c2 + o2, ...)
            for (uint q = pc.k; q-- > 1u;) {
                int v = c[q] + off[q];
                v += v < 0 ? G : (v >= G ? -G : 0);
                row = row * pc.G + uint(v);
            }
            row *= pc.G;
            const int lo = c[0] - R, hi = c[0] + R;
            uint a[2], b[2], parts = 1u;
            if (lo < 0) {
                a[0] = uint(lo + G); b[0] = pc.G; a[1] = 0u; b[1] = uint(hi + 1); parts = 2u;
            } else if (hi >= G) {
                a[0] = uint(lo); b[0] = pc.G; a[1] = 0u; b[1] = uint(hi - G + 1); parts = 2u;
            } else {
                a[0] = uint(lo); b[0] = uint(hi + 1);
            }
            for (uint z = 0u; z < parts; z++) {
                const uint j1 = pbase + starts[cbase + row + b[z]];
                for (uint j = pbase + starts[cbase + row + a[z]]; j < j1; j++) {
                    vec4 t = coords[j] - xi;
                    t -= roundEven(t); // minimum-image toroidal difference
                    const float d = sqrt(dot(t, t));
                    if (!(d > pc.cutoff && d < pc.radius)) continue;
                    const float u = min(d * pc.scale, pc.umax);
                    const int q = min(int(u), pc.qmax);
                    const float f = u - float(q);
                    const float coef = (tables[pc.w_off + uint(q)] + f * tables[pc.dw_off + uint(q)]) / d;
                    sum += coef * t;
                }
            }
            uint q = 1u; // odometer over axes 1 .. k-1
            while (q < pc.k && ++off[q] > R) off[q++] = -R;
            if (q >= pc.k) break;
        }
        const uint p = (pbase + i) * pc.n;
        for (uint q = 0u; q < pc.k; q++) delta[p + grid_dim(q)] += pc.h * sum[q];
    }
}
