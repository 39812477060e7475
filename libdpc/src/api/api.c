/* The only file on the ABI boundary: checks every argument, turns every failure into a status
 * with a message, and hands valid requests to the model and the backend. */
#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/error.h"
#include "common/rng.h"
#include "cpu/cpu_cascade.h"
#include "cpu/cpu_layer_train.h"
#include "api/model_handle.h"

#define MAX_FLOATS_PER_SET (1ull << 28) /* n_points * dims: 1 GiB of floats */

#define STR2(x) #x
#define STR(x) STR2(x)

unsigned dpc_version_number(void) { return DPC_VERSION_NUMBER; }

const char *dpc_version_string(void) {
    return STR(DPC_VERSION_MAJOR) "." STR(DPC_VERSION_MINOR) "." STR(DPC_VERSION_PATCH);
}

const char *dpc_status_string(dpc_status status) {
    switch (status) {
    case DPC_OK: return "DPC_OK";
    case DPC_ERROR_INVALID_ARGUMENT: return "DPC_ERROR_INVALID_ARGUMENT";
    case DPC_ERROR_IO: return "DPC_ERROR_IO";
    case DPC_ERROR_FORMAT: return "DPC_ERROR_FORMAT";
    case DPC_ERROR_UNSUPPORTED: return "DPC_ERROR_UNSUPPORTED";
    case DPC_ERROR_OUT_OF_MEMORY: return "DPC_ERROR_OUT_OF_MEMORY";
    case DPC_ERROR_LIMIT: return "DPC_ERROR_LIMIT";
    case DPC_ERROR_INTERNAL: return "DPC_ERROR_INTERNAL";
    }
    return "DPC_ERROR_UNKNOWN";
}

void dpc_load_options_init(dpc_load_options *options) {
    if (!options) return;
    memset(options, 0, sizeof *options);
    options->struct_size = (uint32_t)sizeof *options;
    options->isa = DPC_ISA_AUTO;
    options->threads = 1;
    options->backend = DPC_BACKEND_AUTO;
    options->input = DPC_INPUT_AUTO;
}

/* Resolve the input kind of a freshly parsed model: AUTO takes the file's "dpc.input". */
static dpc_status choose_input(dpc_model *model, dpc_input requested) {
    const dpc_cascade *c = &model->cascade;
    dpc_input input = requested;
    if (requested == DPC_INPUT_AUTO) {
        const char *v = dpc_cascade_meta(c, "dpc.input");
        if (!v || strcmp(v, "uniform") == 0) input = DPC_INPUT_UNIFORM;
        else if (strcmp(v, "stratified") == 0) input = DPC_INPUT_STRATIFIED;
        else
            return dpc_fail(DPC_ERROR_FORMAT, "metadata dpc.input is \"%.64s\": \"uniform\" or \"stratified\"", v);
    }
    if (input == DPC_INPUT_STRATIFIED && c->grid_dims) /* the file's fault, or the caller's */
        return requested == DPC_INPUT_AUTO
                   ? dpc_fail(DPC_ERROR_FORMAT, "metadata dpc.input is \"stratified\", but the model has grid axes")
                   : dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                              "stratified input is for models without grid axes; this model fixes %u of its %u "
                              "dimensions to a grid",
                              c->grid_dims, c->dims);
    model->input = input;
    return DPC_OK;
}

/* Resolve the backend of a freshly parsed model: AUTO takes a Vulkan GPU if there is one and
 * falls back to the CPU on any failure; VULKAN reports why it cannot run. */
static dpc_status choose_backend(dpc_model *model, dpc_backend requested) {
    model->backend = DPC_BACKEND_CPU;
    if (requested == DPC_BACKEND_CPU) return DPC_OK;
#if defined(DPC_HAVE_VULKAN)
    if (requested == DPC_BACKEND_AUTO) {
        if (dpc_vk_gpu_present() && dpc_vk_engine_create(&model->cascade, 1, &model->vk) == DPC_OK)
            model->backend = DPC_BACKEND_VULKAN;
        dpc_clear_error(); /* falling back to the CPU is not an error */
        return DPC_OK;
    }
    dpc_status st = dpc_vk_engine_create(&model->cascade, 0, &model->vk);
    if (st == DPC_OK) model->backend = DPC_BACKEND_VULKAN;
    return st;
#else
    if (requested == DPC_BACKEND_AUTO) return DPC_OK;
    return dpc_fail(DPC_ERROR_UNSUPPORTED,
                    "backend VULKAN requested, but this libdpc was built without the Vulkan backend "
                    "(configure with -DDPC_VULKAN=ON)");
#endif
}

/* ---- loading ----------------------------------------------------------------------------- */

dpc_status dpc_model_load_memory(const void *data, size_t size, const dpc_load_options *options,
                                 dpc_model **out_model) {
    dpc_clear_error();
    if (!out_model) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "out_model is NULL");
    *out_model = NULL;
    if (!data && size) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "data is NULL");
    dpc_load_options opts;
    dpc_load_options_init(&opts);
    if (options) {
        /* Older callers pass the struct without `backend` or `input`: read what they have,
         * default the rest. */
        const size_t before_backend = offsetof(dpc_load_options, backend);
        const size_t before_input = offsetof(dpc_load_options, input);
        if (options->struct_size == sizeof opts) {
            opts = *options;
        } else if (options->struct_size == before_backend || options->struct_size == before_input) {
            memcpy(&opts, options, options->struct_size);
            opts.struct_size = (uint32_t)sizeof opts;
        } else {
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                            "options.struct_size is %u, expected %u: initialise with dpc_load_options_init",
                            options->struct_size, (unsigned)sizeof opts);
        }
    }
    if (opts.backend != DPC_BACKEND_AUTO && opts.backend != DPC_BACKEND_CPU && opts.backend != DPC_BACKEND_VULKAN)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.backend is %d: use DPC_BACKEND_AUTO, _CPU or _VULKAN",
                        (int)opts.backend);
    if (opts.input != DPC_INPUT_AUTO && opts.input != DPC_INPUT_UNIFORM && opts.input != DPC_INPUT_STRATIFIED)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.input is %d: use DPC_INPUT_AUTO, _UNIFORM or _STRATIFIED",
                        (int)opts.input);
    dpc_model *model = (dpc_model *)calloc(1, sizeof *model);
    if (!model) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory");
    dpc_status st = dpc_cpu_engine_init(&model->engine, opts.isa, opts.threads);
    if (st == DPC_OK) st = dpc_cascade_parse((const uint8_t *)data, size, &model->cascade);
    if (st == DPC_OK && (st = choose_input(model, opts.input)) != DPC_OK) dpc_cascade_release(&model->cascade);
    if (st != DPC_OK) {
        free(model);
        return st;
    }
    st = choose_backend(model, opts.backend);
    if (st != DPC_OK) {
        dpc_cascade_release(&model->cascade);
        free(model);
        return st;
    }
    *out_model = model;
    return DPC_OK;
}

dpc_status dpc_model_load_file(const char *path, const dpc_load_options *options, dpc_model **out_model) {
    dpc_clear_error();
    if (!out_model) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "out_model is NULL");
    *out_model = NULL;
    if (!path) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "path is NULL");
    FILE *f = fopen(path, "rb");
    if (!f) return dpc_fail(DPC_ERROR_IO, "cannot open model file '%.300s'", path);
    struct stat info;
    if (fstat(fileno(f), &info) != 0 || !S_ISREG(info.st_mode)) {
        fclose(f);
        return dpc_fail(DPC_ERROR_IO, "'%.300s' is not a regular file", path);
    }
    long size = -1;
    if (fseek(f, 0, SEEK_END) == 0) size = ftell(f);
    if (size < 0 || fseek(f, 0, SEEK_SET) != 0) {
        fclose(f);
        return dpc_fail(DPC_ERROR_IO, "cannot read model file '%.300s' (not a regular file?)", path);
    }
    if ((unsigned long long)size > DPC_MAX_FILE_BYTES) {
        fclose(f);
        return dpc_fail(DPC_ERROR_LIMIT, "model file '%.300s' is larger than 1 GiB", path);
    }
    void *buf = malloc(size ? (size_t)size : 1);
    if (!buf) {
        fclose(f);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory reading '%.300s'", path);
    }
    size_t got = fread(buf, 1, (size_t)size, f);
    fclose(f);
    if (got != (size_t)size) {
        free(buf);
        return dpc_fail(DPC_ERROR_IO, "short read of model file '%.300s'", path);
    }
    dpc_status st = dpc_model_load_memory(buf, (size_t)size, options, out_model);
    free(buf);
    if (st != DPC_OK) {
        /* Prefix the file name to the reader's message. */
        char msg[512];
        snprintf(msg, sizeof msg, "%s", dpc_last_error());
        return dpc_fail(st, "%.200s: %s", path, msg);
    }
    return DPC_OK;
}

void dpc_model_free(dpc_model *model) {
    if (!model) return;
#if defined(DPC_HAVE_VULKAN)
    dpc_vk_engine_destroy(model->vk);
#endif
    dpc_cascade_release(&model->cascade);
    free(model);
}

/* ---- information ------------------------------------------------------------------------- */

dpc_status dpc_model_get_info(const dpc_model *model, dpc_model_info *out_info) {
    dpc_clear_error();
    if (!model || !out_info) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out_info is NULL");
    const dpc_cascade *c = &model->cascade;
    memset(out_info, 0, sizeof *out_info);
    out_info->dims = c->dims;
    out_info->n_points = c->n_points;
    out_info->layers = c->n_layers;
    out_info->grid_dims = c->grid_dims;
    for (uint32_t g = 0; g < c->grid_dims; g++) {
        out_info->grid_axis[g] = c->grid_axis[g];
        out_info->grid_shape[g] = c->grid_shape[g];
    }
    out_info->isa = model->engine.isa;
    out_info->threads = model->engine.threads;
    return DPC_OK;
}

dpc_status dpc_model_get_backend(const dpc_model *model, dpc_backend *out_backend) {
    dpc_clear_error();
    if (!model || !out_backend) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out_backend is NULL");
    *out_backend = model->backend;
    return DPC_OK;
}

const char *dpc_model_device(const dpc_model *model) {
    if (!model) return "";
#if defined(DPC_HAVE_VULKAN)
    if (model->backend == DPC_BACKEND_VULKAN) return dpc_vk_engine_device(model->vk);
#endif
    return "cpu";
}

dpc_status dpc_model_get_input(const dpc_model *model, dpc_input *out_input) {
    dpc_clear_error();
    if (!model || !out_input) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out_input is NULL");
    *out_input = model->input;
    return DPC_OK;
}

const char *dpc_model_name(const dpc_model *model) {
    if (!model) return "";
    const char *v = dpc_cascade_meta(&model->cascade, "dpc.name");
    return v ? v : "";
}

const char *dpc_model_metadata(const dpc_model *model, const char *key) {
    if (!model || !key) return NULL;
    return dpc_cascade_meta(&model->cascade, key);
}

size_t dpc_model_metadata_count(const dpc_model *model) { return model ? model->cascade.n_meta : 0; }

dpc_status dpc_model_metadata_at(const dpc_model *model, size_t index, const char **out_key,
                                 const char **out_value) {
    dpc_clear_error();
    if (!model || !out_key || !out_value) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "NULL argument");
    if (index >= model->cascade.n_meta)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "metadata index %zu out of range (%zu entries)", index,
                        model->cascade.n_meta);
    *out_key = model->cascade.meta_keys[index];
    *out_value = model->cascade.meta_values[index];
    return DPC_OK;
}

/* ---- generation -------------------------------------------------------------------------- */

static void fill_uniform(uint64_t seed, size_t count, float *out) {
    const uint64_t state0 = dpc_mix64(seed);
    for (size_t c = 0; c < count; c++) out[c] = dpc_uniform_at(state0, c);
}

/* The stratified input of docs/model-format.md §5 for m points in n dimensions. The cell lists
 * live in out itself (cell of point i in word i; for n >= 2 the cell permutation in words
 * m .. m + C), so the CPU and Vulkan paths need no allocation. m <= DPC_MAX_POINTS < 2^32. */
static uint32_t below(uint64_t state1, uint64_t *counter, uint32_t bound) {
    /* an integer in [0, bound): the high 32 bits of the next stream value, scaled */
    uint64_t z = dpc_mix64(state1 + (++*counter) * 0x9E3779B97F4A7C15ull);
    return (uint32_t)(((z >> 32) * (uint64_t)bound) >> 32);
}

static uint32_t word_at(const float *out, size_t i) {
    uint32_t w;
    memcpy(&w, out + i, sizeof w);
    return w;
}

static void set_word(float *out, size_t i, uint32_t w) { memcpy(out + i, &w, sizeof w); }

/* Whether g^n <= m, without overflow. */
static int power_fits(uint64_t g, size_t n, size_t m) {
    uint64_t p = 1;
    for (size_t a = 0; a < n; a++) {
        p *= g;
        if (p > m) return 0;
    }
    return 1;
}

static void fill_stratified(uint64_t seed, size_t m, size_t n, float *out) {
    uint32_t g = (uint32_t)floor(pow((double)m, 1.0 / (double)n)); /* then exactly: the largest g^n <= m */
    if (g < 1) g = 1;
    while (g > 1 && !power_fits(g, n, m)) g--;
    while (power_fits((uint64_t)g + 1, n, m)) g++;
    uint64_t cells = 1;
    for (size_t a = 0; a < n; a++) cells *= g;
    const size_t base = m / (size_t)cells, extra = m % (size_t)cells;
    const uint64_t state1 = dpc_mix64(seed ^ 0x5354524154494649ull); /* a stream of its own */
    uint64_t counter = 0;
    /* every cell `base` times, then `extra` distinct cells (a partial Fisher-Yates shuffle of all
     * cells; extra > 0 implies n >= 2, since g = m in 1-D, so words m .. m + cells are free) */
    for (size_t i = 0; i < base * (size_t)cells; i++) set_word(out, i, (uint32_t)(i % cells));
    if (extra) {
        for (size_t c = 0; c < cells; c++) set_word(out, m + c, (uint32_t)c);
        for (size_t t = 0; t < extra; t++) {
            const size_t j = t + below(state1, &counter, (uint32_t)(cells - t));
            const uint32_t wj = word_at(out, m + j);
            set_word(out, m + j, word_at(out, m + t));
            set_word(out, base * (size_t)cells + t, wj);
            set_word(out, m + t, wj);
        }
    }
    for (size_t i = m - 1; i > 0; i--) { /* random order: any prefix of the set covers the domain */
        const size_t j = below(state1, &counter, (uint32_t)(i + 1));
        const uint32_t wi = word_at(out, i);
        set_word(out, i, word_at(out, j));
        set_word(out, j, wi);
    }
    /* point i = its cell plus the uniform numbers of point i; from the last point down, so
     * point i's coordinates (words i n .. i n + n - 1 >= i) overwrite only cells already read */
    const uint64_t state0 = dpc_mix64(seed);
    const float below_one = 0x1.fffffep-1f;
    for (size_t i = m; i-- > 0;) {
        uint32_t cell = word_at(out, i);
        for (size_t a = 0; a < n; a++) {
            const uint32_t digit = cell % g;
            cell /= g;
            const float u = dpc_uniform_at(state0, i * n + a);
            const float x = (float)(((double)digit + (double)u) / (double)g);
            out[i * n + a] = x < 1.0f ? x : below_one;
        }
    }
}

static dpc_status check_input_size(const float *out, size_t n_points, size_t dims) {
    if (!out) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "out is NULL");
    if (n_points == 0 || dims == 0) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "n_points and dims must be positive");
    if (n_points > SIZE_MAX / dims) return dpc_fail(DPC_ERROR_LIMIT, "n_points * dims overflows");
    return DPC_OK;
}

dpc_status dpc_uniform(uint64_t seed, size_t n_points, size_t dims, float *out) {
    dpc_clear_error();
    dpc_status st = check_input_size(out, n_points, dims);
    if (st != DPC_OK) return st;
    fill_uniform(seed, n_points * dims, out);
    return DPC_OK;
}

dpc_status dpc_stratified(uint64_t seed, size_t n_points, size_t dims, float *out) {
    dpc_clear_error();
    dpc_status st = check_input_size(out, n_points, dims);
    if (st != DPC_OK) return st;
    if (n_points > DPC_MAX_POINTS)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points requested, at most %u per set", n_points, DPC_MAX_POINTS);
    fill_stratified(seed, n_points, dims, out);
    return DPC_OK;
}

/* Resolve and check the point count of a request. */
static dpc_status check_count(const dpc_model *model, size_t *n_points) {
    const dpc_cascade *c = &model->cascade;
    size_t m = *n_points ? *n_points : c->n_points;
    if (m > DPC_MAX_POINTS) return dpc_fail(DPC_ERROR_LIMIT, "%zu points requested, at most %u per set", m, DPC_MAX_POINTS);
    if ((unsigned long long)m * c->dims > MAX_FLOATS_PER_SET)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points x %u dims exceeds 2^28 floats per set", m, c->dims);
    if (c->grid_dims && m != c->n_points)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "gridded model generates exactly %u points, %zu requested",
                        c->n_points, m);
    *n_points = m;
    return DPC_OK;
}

static void fill_grid(const dpc_cascade *c, size_t m, float *x) {
    for (size_t i = 0; i < m; i++) {
        size_t rest = i;
        for (uint32_t g = 0; g < c->grid_dims; g++) {
            size_t cell = rest % c->grid_shape[g];
            rest /= c->grid_shape[g];
            x[i * c->dims + c->grid_axis[g]] = (float)(((double)cell + 0.5) / c->grid_shape[g]);
        }
    }
}

/* The input points of one set: the model's input kind, then the grid's cell centres. */
static void fill_input(const dpc_model *model, uint64_t seed, size_t m, float *x) {
    const dpc_cascade *c = &model->cascade;
    if (model->input == DPC_INPUT_STRATIFIED) fill_stratified(seed, m, c->dims, x);
    else fill_uniform(seed, m * c->dims, x);
    fill_grid(c, m, x);
}

static dpc_status generate_one(const dpc_model *model, const dpc_cpu_engine *engine, uint64_t seed,
                               size_t m, float *out) {
    fill_input(model, seed, m, out);
    return dpc_cpu_filter(&model->cascade, engine, m, out);
}

dpc_status dpc_model_generate_pinned(const dpc_model *model, uint64_t seed, size_t m, float *out) {
    dpc_cpu_engine scalar;
    dpc_status st = dpc_cpu_engine_init(&scalar, DPC_ISA_SCALAR, 1);
    if (st != DPC_OK) return st;
    if ((st = check_count(model, &m)) != DPC_OK) return st;
    return generate_one(model, &scalar, seed, m, out);
}

#if defined(DPC_HAVE_VULKAN)
/* Inputs of a Vulkan run: the CPU backend's input points (same code), or the caller's points. */
typedef struct vk_inputs {
    const dpc_model *model;
    uint64_t seed;
    size_t m;
    const float *given; /* dpc_filter: the caller's points */
} vk_inputs;

static void vk_fill(void *ctx, size_t set, float *x) {
    const vk_inputs *in = (const vk_inputs *)ctx;
    const dpc_cascade *c = &in->model->cascade;
    if (in->given) {
        memcpy(x, in->given, in->m * c->dims * sizeof(float));
        return;
    }
    fill_input(in->model, in->seed + set, in->m, x);
}

static dpc_status vk_generate(const dpc_model *model, uint64_t seed, size_t count, size_t m, float *out) {
    vk_inputs in = {model, seed, m, NULL};
    return dpc_vk_run(model->vk, &model->cascade, count, m, vk_fill, &in, out);
}
#endif

dpc_status dpc_generate_n(const dpc_model *model, uint64_t seed, size_t n_points, float *out) {
    dpc_clear_error();
    if (!model || !out) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out is NULL");
    dpc_status st = check_count(model, &n_points);
    if (st != DPC_OK) return st;
#if defined(DPC_HAVE_VULKAN)
    if (model->backend == DPC_BACKEND_VULKAN) return vk_generate(model, seed, 1, n_points, out);
#endif
    return generate_one(model, &model->engine, seed, n_points, out);
}

dpc_status dpc_generate(const dpc_model *model, uint64_t seed, float *out) {
    return dpc_generate_n(model, seed, 0, out);
}

size_t dpc_output_size(const dpc_model *model, size_t count, size_t n_points) {
    if (!model) return 0;
    size_t m = n_points ? n_points : model->cascade.n_points;
    size_t per = m * model->cascade.dims;
    if (m && per / m != model->cascade.dims) return 0;
    if (count && per > SIZE_MAX / count) return 0;
    return per * count;
}

/* Batches: with several threads, whole sets go to threads (set c always from seed + c, so the
 * bits are those of the serial loop). */
typedef struct batch_job {
    const dpc_model *model;
    dpc_cpu_engine engine; /* single-threaded copy */
    uint64_t seed;
    size_t count, m, stride, next_step, first;
    float *out;
    dpc_status status;
} batch_job;

static void *batch_worker(void *arg) {
    batch_job *j = (batch_job *)arg;
    for (size_t c = j->first; c < j->count && j->status == DPC_OK; c += j->next_step)
        j->status = generate_one(j->model, &j->engine, j->seed + c, j->m, j->out + c * j->stride);
    return NULL;
}

dpc_status dpc_generate_batch(const dpc_model *model, uint64_t seed, size_t count, size_t n_points, float *out) {
    dpc_clear_error();
    if (!model || !out) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out is NULL");
    if (count == 0) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "count must be positive");
    dpc_status st = check_count(model, &n_points);
    if (st != DPC_OK) return st;
    const size_t stride = n_points * model->cascade.dims;
    if (count > SIZE_MAX / stride) return dpc_fail(DPC_ERROR_LIMIT, "count * n_points * dims overflows");
#if defined(DPC_HAVE_VULKAN)
    if (model->backend == DPC_BACKEND_VULKAN) return vk_generate(model, seed, count, n_points, out); /* many sets per dispatch */
#endif
    unsigned threads = model->engine.threads;
    if (threads > count) threads = (unsigned)count;
    if (threads <= 1 || n_points >= 65536) { /* big sets parallelise inside each set instead */
        for (size_t c = 0; c < count; c++)
            if ((st = generate_one(model, &model->engine, seed + c, n_points, out + c * stride)) != DPC_OK) return st;
        return DPC_OK;
    }
    batch_job jobs[64];
    pthread_t ids[64];
    int started[64];
    for (unsigned t = 0; t < threads; t++) {
        jobs[t] = (batch_job){model, model->engine, seed, count, n_points, stride, threads, t, out, DPC_OK};
        jobs[t].engine.threads = 1;
    }
    for (unsigned t = 1; t < threads; t++) started[t] = pthread_create(&ids[t], NULL, batch_worker, &jobs[t]) == 0;
    batch_worker(&jobs[0]);
    for (unsigned t = 1; t < threads; t++) {
        if (started[t]) pthread_join(ids[t], NULL);
        else batch_worker(&jobs[t]);
    }
    for (unsigned t = 0; t < threads; t++)
        if (jobs[t].status != DPC_OK)
            return dpc_fail(jobs[t].status, "generating a set of the batch failed (%s)", dpc_status_string(jobs[t].status));
    return DPC_OK;
}

dpc_status dpc_filter(const dpc_model *model, size_t n_points, float *points) {
    dpc_clear_error();
    if (!model || !points) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or points is NULL");
    if (n_points == 0) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "n_points must be positive");
    dpc_status st = check_count(model, &n_points);
    if (st != DPC_OK) return st;
    const size_t total = n_points * model->cascade.dims;
    for (size_t i = 0; i < total; i++)
        if (!(points[i] >= 0.0f && points[i] < 1.0f))
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "point %zu, dimension %zu is %g: points must lie in [0, 1)",
                            i / model->cascade.dims, i % model->cascade.dims, (double)points[i]);
#if defined(DPC_HAVE_VULKAN)
    if (model->backend == DPC_BACKEND_VULKAN) {
        vk_inputs in = {model, 0, n_points, points};
        return dpc_vk_run(model->vk, &model->cascade, 1, n_points, vk_fill, &in, points);
    }
#endif
    return dpc_cpu_filter(&model->cascade, &model->engine, n_points, points);
}

/* ---- training support: one filter layer in float64 ----------------------------------------- */

/* Every check of the layer description and the shared inputs; fills *out for the kernels. */
static dpc_status check_layer_call(const dpc_layer_desc *layer, const double *kernels, size_t count,
                                   size_t n_points, const double *x, dpc_train_layer *out) {
    if (!layer) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "layer is NULL");
    if (!kernels || !x) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "kernels or x is NULL");
    const uint32_t n = layer->dims, s = layer->n_subspaces, b = layer->bins;
    if (n < 1 || n > DPC_MAX_DIMS)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "layer dims is %u, must be 1 .. %d", n, DPC_MAX_DIMS);
    if (s < 1 || s > DPC_MAX_SUBSPACES)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "layer has %u subspaces, must be 1 .. %u", s, DPC_MAX_SUBSPACES);
    if (b < 2 || b > DPC_MAX_BINS)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "layer has %u kernel bins, must be 2 .. %u", b, DPC_MAX_BINS);
    if (!layer->subspaces || !layer->radius)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "layer subspaces or radius is NULL");
    const uint64_t all = n == 64 ? ~0ull : (1ull << n) - 1;
    for (uint32_t t = 0; t < s; t++) {
        const uint64_t mask = layer->subspaces[t];
        if (mask == 0 || (mask & ~all))
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                            "subspace %u has mask 0x%llx: must be nonzero and use only dimensions < %u", t,
                            (unsigned long long)mask, n);
        for (uint32_t u = 0; u < t; u++)
            if (layer->subspaces[u] == mask)
                return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "subspaces %u and %u are equal (0x%llx)", u, t,
                                (unsigned long long)mask);
        const double rho = layer->radius[t];
        if (!(rho > 0.0 && rho <= 1e6))
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "radius of subspace %u is %g, must be in (0, 1e6]", t, rho);
    }
    if (!(layer->eps >= 0.0 && layer->eps <= DBL_MAX))
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "eps is %g, must be finite and >= 0", layer->eps);
    if (layer->fixed & ~all)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "fixed mask 0x%llx uses dimensions >= %u",
                        (unsigned long long)layer->fixed, n);
    if (count == 0 || n_points == 0)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "count and n_points must be positive");
    if (n_points > DPC_MAX_POINTS)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points per set, at most %u", n_points, DPC_MAX_POINTS);
    if ((unsigned long long)n_points * n > MAX_FLOATS_PER_SET)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points x %u dims exceeds 2^28 values per set", n_points, n);
    if (count > SIZE_MAX / sizeof(double) / (n_points * n))
        return dpc_fail(DPC_ERROR_LIMIT, "count * n_points * dims overflows");
    for (size_t i = 0; i < (size_t)s * b; i++)
        if (!isfinite(kernels[i]))
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "kernel value %zu (subspace %zu, bin %zu) is not finite", i,
                            i / b, i % b);
    const size_t total = count * n_points * n;
    for (size_t i = 0; i < total; i++)
        if (!(x[i] >= 0.0 && x[i] < 1.0))
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                            "x: set %zu, point %zu, dimension %zu is %g: points must be finite and in [0, 1)",
                            i / (n_points * n), i / n % n_points, i % n, x[i]);
    *out = (dpc_train_layer){n, s, b, layer->subspaces, layer->radius, layer->eps, layer->fixed, kernels};
    return DPC_OK;
}

dpc_status dpc_layer_forward(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                             const double *x, double *y, uint32_t threads) {
    dpc_clear_error();
    dpc_train_layer L;
    dpc_status st = check_layer_call(layer, kernels, count, n_points, x, &L);
    if (st != DPC_OK) return st;
    if (!y) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "y is NULL");
    return dpc_train_forward(&L, count, n_points, x, y, threads);
}

dpc_status dpc_layer_backward(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                              const double *x, const double *grad_y, double *grad_x, double *grad_kernels,
                              uint32_t threads) {
    dpc_clear_error();
    dpc_train_layer L;
    dpc_status st = check_layer_call(layer, kernels, count, n_points, x, &L);
    if (st != DPC_OK) return st;
    if (!grad_y || !grad_x || !grad_kernels)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "grad_y, grad_x or grad_kernels is NULL");
    const size_t total = count * n_points * L.n;
    for (size_t i = 0; i < total; i++)
        if (!isfinite(grad_y[i]))
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "grad_y: set %zu, point %zu, dimension %zu is not finite",
                            i / (n_points * L.n), i / L.n % n_points, i % L.n);
    return dpc_train_backward(&L, count, n_points, x, grad_y, grad_x, grad_kernels, threads);
}
