/* The model handle's shared steps: the point-count check and one-thread CPU generation. */
#include "model/model_handle.h"

#include "common/error.h"

static double model_max_radius(const dpc_cascade *c) {
    double r = 0.0;
    for (uint32_t l = 0; l < c->n_layers; l++)
        for (uint32_t t = 0; t < c->layers[l].n_sub; t++)
            if ((double)c->layers[l].radius[t] > r) r = (double)c->layers[l].radius[t];
    return r;
}

dpc_status dpc_model_check_count(const dpc_model *model, size_t *n_points) {
    const dpc_cascade *c = &model->cascade;
    size_t m = *n_points ? *n_points : c->n_points;
    if (m > DPC_MAX_POINTS)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points requested, at most %u per set", m, DPC_MAX_POINTS);
    if ((unsigned long long)m * c->dims > DPC_MAX_FLOATS_PER_SET)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points x %u dims exceeds 2^28 floats per set", m, c->dims);
    if (c->grid_dims && m != c->n_points)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "gridded model generates exactly %u points, %zu requested",
                        c->n_points, m);
    /* the work bound of dpc_load_options.max_neighbours */
    const double asked = model->neighbours < (double)(m - 1) ? model->neighbours : (double)(m - 1);
    if (asked > model->max_neighbours)
        return dpc_fail(DPC_ERROR_LIMIT,
                        "the model asks for %.4g neighbours per point at %zu points (radius %.4g spacings at most), "
                        "beyond the load option max_neighbours = %.4g: load it with a larger bound if you trust it",
                        asked, m, model_max_radius(c), model->max_neighbours);
    *n_points = m;
    return DPC_OK;
}

dpc_status dpc_model_generate_cpu(const dpc_model *model, uint64_t seed, size_t m, float *out, dpc_cpu_hook hook,
                                  void *ctx) {
    dpc_cpu_engine one;
    dpc_status st = dpc_cpu_engine_init(&one, model->engine.isa, 1); /* every ISA: the same bits */
    if (st != DPC_OK) return st;
    if ((st = dpc_model_check_count(model, &m)) != DPC_OK) return st;
    return dpc_cpu_generate(&model->cascade, model->input, &one, seed, 1, m, out, hook, ctx);
}
