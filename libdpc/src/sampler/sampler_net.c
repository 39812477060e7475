/* The sampler's net tables (docs/rendering.md, "Net dimensions"): an Owen-scrambled 2-D Sobol'
 * (0,m,2)-net whose scrambling flips are chosen, greedily, to minimise a pair energy averaged
 * over the digital shifts (XORs) that randomise it per pixel. Integer arithmetic only, so the
 * same flips on every machine; tests/python/reference_sampler.py transcribes it. */
#include <stdlib.h>

#include "common/error.h"
#include "sampler/sampler.h"

/* Sobol's second coordinate of index i as an m-bit integer: the XOR of the direction numbers
 * v_k of i's set bits, v_0 = 2^(m-1), v_k = v_{k-1} XOR (v_{k-1} >> 1) (Pascal's matrix mod 2). */
static uint32_t sobol_y(uint32_t i, uint32_t m) {
    uint32_t y = 0, v = 1u << (m - 1);
    for (; i; i >>= 1, v ^= v >> 1)
        if (i & 1u) y ^= v;
    return y;
}

static uint32_t reverse_bits(uint32_t i, uint32_t m) {
    uint32_t r = 0;
    for (uint32_t b = 0; b < m; b++) r |= ((i >> b) & 1u) << (m - 1 - b);
    return r;
}

/* The XOR-averaged kernel h(c), c = a XOR b of two cells' coordinates: the mean over u of
 * w(torus distance of u and u XOR c), w(e) = 65535 (Q - e^2)^4 / Q^4 for e^2 < Q, Q = 81 n / 50
 * (a Gaussian of sigma 0.45 / sqrt(n) in [0, 1) units, as a polynomial with integer values).
 * Since a per-pixel XOR moves both points of a pair by the same digital shift, the energy a pair
 * has on average over the shifts depends on a XOR b only. */
static void net_kernel(uint32_t m, uint64_t *h) {
    const uint32_t n = 1u << m;
    const uint64_t q = (81ull * n) / 50, q4 = q * q * q * q;
    for (uint32_t c = 0; c < n; c++) {
        uint64_t sum = 0;
        for (uint32_t u = 0; u < n; u++) {
            const uint32_t v = u ^ c, d = u > v ? u - v : v - u, e = d < n - d ? d : n - d;
            if ((uint64_t)e * e >= q) continue;
            const uint64_t r = q - (uint64_t)e * e;
            sum += r * r * r * r * 65535u / q4;
        }
        h[c] = sum >> m;
    }
}

dpc_status dpc_sampler_make_net(uint32_t m, uint64_t seed, uint32_t *cells) {
    const uint32_t n = 1u << m;
    uint32_t *base = (uint32_t *)malloc((size_t)n * 2 * sizeof *base);   /* unscrambled x, y of point i */
    uint32_t *order = (uint32_t *)malloc((size_t)n * 2 * sizeof *order); /* point with base value v */
    uint32_t *p = (uint32_t *)malloc((size_t)n * 2 * sizeof *p);         /* scrambled x, y of point i */
    uint64_t *h = m >= 1 && n <= DPC_SAMPLER_NET_OPTIMISED ? (uint64_t *)malloc((size_t)n * sizeof *h) : NULL;
    dpc_status st = DPC_OK;
    if (!base || !order || !p || (m >= 1 && n <= DPC_SAMPLER_NET_OPTIMISED && !h)) {
        st = dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory for a %u-point net", n);
        goto done;
    }
    for (uint32_t i = 0; i < n; i++) {
        base[i * 2] = reverse_bits(i, m);
        base[i * 2 + 1] = sobol_y(i, m);
        order[base[i * 2] * 2] = i;
        order[base[i * 2 + 1] * 2 + 1] = i;
    }
    /* Owen scrambling: the output bit at level j (from the top, j >= 1) is the input bit XOR a
     * flip chosen by the input's top j bits; the flips are random bits of the seed's stream
     * (flip number f of coordinate c: bit 63 of mix(seed + (f + 1) * golden), f counting the
     * nodes level by level, coordinate x first). Level 0 is left: the per-pixel XOR covers it. */
    uint64_t f = 0;
    for (uint32_t c = 0; c < 2; c++) {
        for (uint32_t i = 0; i < n; i++) p[i * 2 + c] = base[i * 2 + c];
        for (uint32_t j = 1; j < m; j++)
            for (uint32_t pre = 0; pre < (1u << j); pre++, f++) {
                if (!(dpc_stream_at(seed, DPC_STREAM_NET_FLIP, f) >> 63)) continue;
                const uint32_t width = n >> j, bit = 1u << (m - 1 - j);
                for (uint32_t v = pre * width; v < (pre + 1) * width; v++) p[order[v * 2 + c] * 2 + c] ^= bit;
            }
    }
    if (h) {
        net_kernel(m, h);
        /* Greedy descent: toggle a node's flip when that lowers the energy; the pairs inside the
         * node's points keep their XOR, so only pairs across its boundary change. */
        for (uint32_t sweep = 0; sweep < DPC_SAMPLER_NET_SWEEPS; sweep++) {
            int changed = 0;
            for (uint32_t j = 1; j < m; j++)
                for (uint32_t pre = 0; pre < (1u << j); pre++)
                    for (uint32_t c = 0; c < 2; c++) {
                        const uint32_t width = n >> j, bit = 1u << (m - 1 - j), o = 1 - c;
                        int64_t delta = 0;
                        for (uint32_t v = pre * width; v < (pre + 1) * width; v++) {
                            const uint32_t a = order[v * 2 + c], ac = p[a * 2 + c], ao = p[a * 2 + o];
                            for (uint32_t b = 0; b < n; b++) {
                                if ((base[b * 2 + c] >> (m - j)) == pre) continue;
                                const uint32_t bc = p[b * 2 + c];
                                delta +=
                                    ((int64_t)h[ac ^ bit ^ bc] - (int64_t)h[ac ^ bc]) * (int64_t)h[ao ^ p[b * 2 + o]];
                            }
                        }
                        if (delta < 0) {
                            for (uint32_t v = pre * width; v < (pre + 1) * width; v++)
                                p[order[v * 2 + c] * 2 + c] ^= bit;
                            changed = 1;
                        }
                    }
            if (!changed) break;
        }
    }
    for (uint32_t i = 0; i < n; i++) cells[i] = p[i * 2] << 16 | p[i * 2 + 1];
done:
    free(base);
    free(order);
    free(p);
    free(h);
    return st;
}
