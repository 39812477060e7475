/* The subspace plan (plan.h): one definition of h_t, r_t, e_t, the bin scale, the search and
 * c_k for the CPU engine, the Vulkan host code and the training kernels. */
#include "model/plan.h"

#include <math.h>
#include <string.h>

#define PI_VALUE 3.14159265358979323846

int dpc_plan_search(unsigned k, double r, size_t m, uint32_t *G_out, uint32_t *R_out) {
    if (k > 4 || m < 64) return 0;
    const double reach = k <= 2 ? 2.0 : 1.0; /* cells per radius: finer cells visit less area */
    /* Cell coordinates are rounded products x * G (float32: off by up to G * 6e-8 cells near cell
     * edges, G <= 16384; float64: ~1e-12 cells): a margin of 1e-3 cells keeps every neighbour
     * within R cells. */
    const double margin = 1e-3;
    double G = floor(reach / (r * (1.0 + margin)));
    const double cap = floor(pow(2.0 * (double)m, 1.0 / k) + 1e-9); /* at most ~2m cells */
    if (G > cap) G = cap;
    if (G > 16384) G = 16384;
    if (G < 3) return 0;
    const double R = ceil(r * G + margin);
    if (2 * R + 1 > G) return 0;                 /* a cell would be visited twice */
    if (pow((2 * R + 1) / G, k) > 0.5) return 0; /* most of the domain anyway: all pairs is faster */
    /* Guards of the range and cell buffers. The rules above already imply both (R <= 2, so at
     * most 2 * 5^3 = 250 rows; G <= cap, so G^k <= 2m), so they never change a choice. */
    if (2 * pow(2 * R + 1, k - 1) > DPC_PLAN_MAX_RANGES) return 0;
    if (pow(G, k) > 2.0 * (double)m + DPC_PLAN_CELL_SLACK) return 0;
    *G_out = (uint32_t)G;
    *R_out = (uint32_t)R;
    return 1;
}

void dpc_plan_subspace(uint64_t mask, uint64_t fixed, double rho, double eps, uint32_t bins, size_t m,
                       dpc_plan_precision precision, dpc_sub_plan *out) {
    memset(out, 0, sizeof *out);
    for (unsigned d = 0; d < DPC_MAX_DIMS; d++)
        if (mask >> d & 1) out->dim[out->k++] = d;
    out->moves = (mask & ~fixed) != 0;
    const double h = pow((double)m, -1.0 / out->k);
    if (precision == DPC_PLAN_F32) {
        /* float32 arithmetic on the file's float32 values (docs/model-format.md §3) */
        const float hf = (float)h;
        float r = (float)rho * hf;
        r = r < 0.5f ? r : 0.5f;
        out->h = hf;
        out->r = r;
        out->e = (float)eps * hf;
        out->scale = (float)(bins - 1) / r;
        out->umax = (float)(bins - 1);
    } else {
        const double r = rho * h;
        out->h = h;
        out->r = r < 0.5 ? r : 0.5;
        out->e = eps * h;
        out->scale = (double)(bins - 1) / out->r;
        out->umax = (double)(bins - 1);
    }
    out->qmax = (int32_t)bins - 2;
    out->grid = dpc_plan_search(out->k, out->r, m, &out->G, &out->R);
}

void dpc_plan_counts(unsigned n, unsigned n_sub, const uint64_t *masks, uint64_t fixed, unsigned *count) {
    for (unsigned d = 0; d < n; d++) {
        count[d] = 0;
        if (fixed >> d & 1) continue;
        for (unsigned t = 0; t < n_sub; t++) count[d] += (unsigned)(masks[t] >> d & 1);
    }
}

double dpc_plan_in_reach(unsigned k, double rho) {
    return pow(PI_VALUE, 0.5 * k) / tgamma(0.5 * k + 1.0) * pow(rho, (double)k);
}

double dpc_plan_neighbours(const dpc_cascade *c) {
    double most = 0.0;
    for (uint32_t l = 0; l < c->n_layers; l++) {
        const dpc_layer *L = &c->layers[l];
        for (uint32_t t = 0; t < L->n_sub; t++) {
            if (!(L->masks[t] & ~L->fixed)) continue; /* moves nothing: every backend skips it */
            unsigned k = 0;
            for (uint64_t bits = L->masks[t]; bits; bits &= bits - 1) k++;
            const double n = dpc_plan_in_reach(k, (double)L->radius[t]);
            if (!(n <= most)) most = n; /* inf stays inf */
        }
    }
    return most;
}
