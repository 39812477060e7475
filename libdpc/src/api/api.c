/* The ABI boundary (with api_sampler.c): checks every argument, turns every failure into a
 * status with a message, and hands valid requests to the model layer (model/: the reader, the
 * input points, the plan) and to the backend the handle was loaded for (cpu/, vulkan/). */
#define _GNU_SOURCE /* dladdr: where this library lies, for dpc_model_dir() */
#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "common/error.h"
#include "common/threads.h"
#include "cpu/cpu_cascade.h"
#include "cpu/cpu_layer_train.h"
#include "density/density.h"
#include "model/balance.h"
#include "model/input.h"
#include "model/level_order.h"
#include "model/model_handle.h"
#include "model/plan.h"
#include "model/relax.h"

/* Where `cmake --install` puts the bundled models (CMake defines both for this file): the
 * configured absolute folder, and the same folder relative to the library's own folder. */
#ifndef DPC_MODEL_DIR
#define DPC_MODEL_DIR ""
#endif
#ifndef DPC_MODEL_DIR_FROM_LIB
#define DPC_MODEL_DIR_FROM_LIB ""
#endif

#define STR2(x) #x
#define STR(x) STR2(x)

unsigned dpc_version_number(void) { return DPC_VERSION_NUMBER; }

const char *dpc_version_string(void) {
    return STR(DPC_VERSION_MAJOR) "." STR(DPC_VERSION_MINOR) "." STR(DPC_VERSION_PATCH);
}

int dpc_isa_supported(dpc_isa isa) { return dpc_cpu_isa_available(isa); }

void dpc_load_options_init(dpc_load_options *options) {
    if (!options) return;
    memset(options, 0, sizeof *options);
    options->struct_size = (uint32_t)sizeof *options;
    options->isa = DPC_ISA_AUTO;
    options->threads = 1;
    options->backend = DPC_BACKEND_AUTO;
    options->input = DPC_INPUT_AUTO;
    options->max_neighbours = DPC_DEFAULT_MAX_NEIGHBOURS;
}

/* Resolve the input kind of a freshly parsed model: AUTO takes the file's "dpc.input". */
static dpc_status choose_input(dpc_model *model, dpc_input requested) {
    const dpc_cascade *c = &model->cascade;
    dpc_input input = requested;
    if (requested == DPC_INPUT_AUTO) {
        const char *v = dpc_cascade_meta(c, "dpc.input");
        if (!v || strcmp(v, "uniform") == 0) input = DPC_INPUT_UNIFORM;
        else if (strcmp(v, "stratified") == 0) input = DPC_INPUT_STRATIFIED;
        else return dpc_fail(DPC_ERROR_FORMAT, "metadata dpc.input is \"%.64s\": \"uniform\" or \"stratified\"", v);
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
    if (model->cascade.progressive_base) { /* its levels hold points in place: a CPU engine feature */
        if (requested == DPC_BACKEND_AUTO) return DPC_OK;
        return dpc_fail(DPC_ERROR_UNSUPPORTED,
                        "a progressive model (dpc.order = \"progressive\") runs on the CPU backend only");
    }
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
        const size_t before_neighbours = offsetof(dpc_load_options, max_neighbours);
        if (options->struct_size == sizeof opts) {
            opts = *options;
        } else if (options->struct_size == before_backend || options->struct_size == before_input ||
                   options->struct_size == before_neighbours) {
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
    if (!(opts.max_neighbours > 0.0))
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.max_neighbours is %g: must be > 0 (INFINITY: no bound)",
                        opts.max_neighbours);
    dpc_model *model = (dpc_model *)calloc(1, sizeof *model);
    if (!model) return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory");
    model->max_neighbours = opts.max_neighbours;
    dpc_status st = dpc_cpu_engine_init(&model->engine, opts.isa, opts.threads);
    if (st == DPC_OK) st = dpc_cascade_parse((const uint8_t *)data, size, &model->cascade);
    if (st == DPC_OK && (st = choose_input(model, opts.input)) != DPC_OK) dpc_cascade_release(&model->cascade);
    if (st != DPC_OK) {
        free(model);
        return st;
    }
    model->neighbours = dpc_plan_neighbours(&model->cascade);
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
    /* O_NONBLOCK: opening a FIFO (or a device that waits) returns at once instead of blocking
     * until a writer appears; fstat then refuses everything but a regular file. For a regular
     * file O_NONBLOCK changes nothing. */
    int fd;
    do fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    while (fd < 0 && errno == EINTR);
    if (fd < 0) return dpc_fail(DPC_ERROR_IO, "cannot open model file '%.300s': %s", path, strerror(errno));
    struct stat info;
    if (fstat(fd, &info) != 0) {
        const int e = errno;
        close(fd);
        return dpc_fail(DPC_ERROR_IO, "cannot stat model file '%.300s': %s", path, strerror(e));
    }
    if (!S_ISREG(info.st_mode)) {
        close(fd);
        const char *what = S_ISDIR(info.st_mode)    ? "a directory"
                           : S_ISFIFO(info.st_mode) ? "a FIFO"
                           : S_ISCHR(info.st_mode)  ? "a character device"
                           : S_ISBLK(info.st_mode)  ? "a block device"
                           : S_ISSOCK(info.st_mode) ? "a socket"
                                                    : "not a regular file";
        return dpc_fail(DPC_ERROR_IO, "'%.300s' is %s: a model must be a regular file", path, what);
    }
    if (info.st_size < 0 || (unsigned long long)info.st_size > DPC_MAX_FILE_BYTES) {
        close(fd);
        return dpc_fail(DPC_ERROR_LIMIT, "model file '%.300s' is larger than 1 GiB", path);
    }
    const size_t size = (size_t)info.st_size;
    void *buf = malloc(size ? size : 1);
    if (!buf) {
        close(fd);
        return dpc_fail(DPC_ERROR_OUT_OF_MEMORY, "out of memory reading '%.300s'", path);
    }
    size_t got = 0;
    while (got < size) {
        const ssize_t r = read(fd, (char *)buf + got, size - got);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) break;
        got += (size_t)r;
    }
    close(fd);
    if (got != size) {
        free(buf);
        return dpc_fail(DPC_ERROR_IO, "short read of model file '%.300s'", path);
    }
    dpc_status st = dpc_model_load_memory(buf, size, options, out_model);
    free(buf);
    if (st != DPC_OK) {
        /* Prefix the file name to the reader's message. */
        char msg[512];
        snprintf(msg, sizeof msg, "%s", dpc_last_error());
        return dpc_fail(st, "%.200s: %s", path, msg);
    }
    return DPC_OK;
}

static char model_dir[4096];
static pthread_once_t model_dir_once = PTHREAD_ONCE_INIT;

static int is_dir(const char *path) {
    struct stat info;
    return stat(path, &info) == 0 && S_ISDIR(info.st_mode);
}

/* The models beside this library: the first folder of DPC_MODEL_DIR_FROM_LIB (':'-separated,
 * relative to the folder of the binary this code is in: <libdir>/../share/dpc/models for an
 * install moved or made with `cmake --install --prefix`; in the Python package dpc/models, seen
 * from the extension in dpc/ and from dpc/lib/libdpc.so) that exists, else the configured
 * folder; canonical (realpath). */
static void find_model_dir(void) {
    char buf[4096] = "";
    Dl_info info;
    if (DPC_MODEL_DIR_FROM_LIB[0] && dladdr((void *)&find_model_dir, &info) && info.dli_fname) {
        const char *slash = strrchr(info.dli_fname, '/');
        for (const char *rel = DPC_MODEL_DIR_FROM_LIB; slash && rel && !buf[0];) {
            const char *end = strchr(rel, ':');
            const int len = (int)(end ? (size_t)(end - rel) : strlen(rel));
            const int n =
                snprintf(buf, sizeof buf, "%.*s/%.*s", (int)(slash - info.dli_fname), info.dli_fname, len, rel);
            if (n < 0 || (size_t)n >= sizeof buf || !is_dir(buf)) buf[0] = '\0';
            rel = end ? end + 1 : NULL;
        }
    }
    if (!buf[0] && DPC_MODEL_DIR[0] && strlen(DPC_MODEL_DIR) < sizeof buf)
        snprintf(buf, sizeof buf, "%s", DPC_MODEL_DIR);
    char *real = buf[0] ? realpath(buf, NULL) : NULL;
    snprintf(model_dir, sizeof model_dir, "%s", real && strlen(real) < sizeof model_dir ? real : buf);
    free(real);
}

const char *dpc_model_dir(void) {
    pthread_once(&model_dir_once, find_model_dir);
    return model_dir;
}

/* Whether dir/name.onnx is a regular file; its path in buf. */
static int named_file(const char *dir, size_t dir_len, const char *name, char *buf, size_t cap) {
    if (dir_len == 0) return 0;
    const int n = snprintf(buf, cap, "%.*s/%s.onnx", (int)dir_len, dir, name);
    if (n < 0 || (size_t)n >= cap) return 0;
    struct stat info;
    return stat(buf, &info) == 0 && S_ISREG(info.st_mode);
}

/* The index of name's first character outside [A-Za-z0-9._-], or len when there is none. */
static size_t bad_character(const char *name, size_t len) {
    for (size_t i = 0; i < len; i++) {
        const char ch = name[i];
        if (!((ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '-' ||
              ch == '_' || ch == '.'))
            return i;
    }
    return len;
}

/* Whether the len bytes at name are a model name: 1 .. 255 characters of [A-Za-z0-9._-], not
 * starting with '.'. */
static int valid_name(const char *name, size_t len) {
    return len > 0 && len <= 255 && name[0] != '.' && bad_character(name, len) == len;
}

#define LISTED_NAMES_MAX 256 /* names a failed search lists; a folder may hold any number of files */

static int compare_names(const void *a, const void *b) {
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* The names of the regular files NAME.onnx in one folder (dir_len bytes of dir), added to names. */
static void collect_names(const char *dir, size_t dir_len, char **names, size_t *count) {
    char path[DPC_PATH_MAX];
    if (dir_len == 0 || dir_len >= sizeof path) return;
    memcpy(path, dir, dir_len);
    path[dir_len] = '\0';
    DIR *d = opendir(path);
    if (!d) return;
    for (const struct dirent *e; *count < LISTED_NAMES_MAX && (e = readdir(d));) {
        const size_t len = strlen(e->d_name);
        if (len <= 5 || strcmp(e->d_name + len - 5, ".onnx") != 0 || !valid_name(e->d_name, len - 5)) continue;
        char *name = strndup(e->d_name, len - 5);
        if (!name) break;
        if (named_file(dir, dir_len, name, path, sizeof path)) names[(*count)++] = name;
        else free(name); /* a FIFO, a folder, ...: skipped */
    }
    closedir(d);
}

/* The names the search could find (every folder it reads), sorted, each once, joined by ", " into
 * out; "(none)" when there are none. For the message of a failed search, so that C clients (the
 * Mitsuba and pbrt-v4 samplers) show the list without reading the folders themselves. */
static void list_names(const char *env, const char *dir, char *out, size_t cap) {
    char *names[LISTED_NAMES_MAX];
    size_t count = 0;
    for (const char *p = env; p;) {
        const char *end = strchr(p, ':');
        collect_names(p, end ? (size_t)(end - p) : strlen(p), names, &count);
        p = end ? end + 1 : NULL;
    }
    collect_names(dir, strlen(dir), names, &count);
    qsort(names, count, sizeof names[0], compare_names);
    size_t used = 0;
    out[0] = '\0';
    for (size_t i = 0; i < count; i++) {
        if (i > 0 && strcmp(names[i], names[i - 1]) == 0) continue;
        const int n = snprintf(out + used, cap - used, "%s%s", used ? ", " : "", names[i]);
        if (n < 0 || (size_t)n >= cap - used) {
            out[used] = '\0';
            if (used + 5 < cap) snprintf(out + used, cap - used, ", ...");
            break;
        }
        used += (size_t)n;
    }
    if (!out[0]) snprintf(out, cap, "(none)");
    for (size_t i = 0; i < count; i++) free(names[i]);
}

/* A model name: 1 .. 255 characters of [A-Za-z0-9._-], not starting with '.'. */
static dpc_status check_name(const char *name) {
    const size_t len = strlen(name);
    if (len == 0 || len > 255 || name[0] == '.')
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                        "model name '%.300s' must be 1 .. 255 characters, not starting with '.'", name);
    const size_t i = bad_character(name, len);
    if (i < len)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                        "model name '%.300s' has character %zu outside [A-Za-z0-9._-] (give a path to "
                        "dpc_model_load_file instead)",
                        name, i);
    return DPC_OK;
}

dpc_status dpc_model_find(const char *name, char *out_path, size_t capacity) {
    dpc_clear_error();
    if (!name || !out_path || capacity == 0)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "name or out_path is NULL, or capacity is 0");
    out_path[0] = '\0';
    dpc_status st = check_name(name);
    if (st != DPC_OK) return st;
    char path[DPC_PATH_MAX];
    int found = 0;
    const char *env = getenv("DPC_MODEL_PATH");
    for (const char *p = env; p && !found;) {
        const char *end = strchr(p, ':');
        const size_t n = end ? (size_t)(end - p) : strlen(p);
        found = named_file(p, n, name, path, sizeof path);
        p = end ? end + 1 : NULL;
    }
    const char *dir = dpc_model_dir();
    if (!found) found = named_file(dir, strlen(dir), name, path, sizeof path);
    if (!found) {
        char names[2048];
        list_names(env, dir, names, sizeof names);
        return dpc_fail(DPC_ERROR_IO,
                        "no model named '%s': no regular file %s.onnx in DPC_MODEL_PATH (%.1000s) or in %.1000s; "
                        "models there: %s",
                        name, name, env ? env : "unset", dir[0] ? dir : "(this build installs no models)", names);
    }
    const size_t len = strlen(path);
    if (len >= capacity)
        return dpc_fail(DPC_ERROR_LIMIT,
                        "the path of model '%s' is %zu bytes, more than out_path's capacity %zu: "
                        "give DPC_PATH_MAX bytes",
                        name, len + 1, capacity);
    memcpy(out_path, path, len + 1);
    return DPC_OK;
}

dpc_status dpc_model_load_named(const char *name, const dpc_load_options *options, dpc_model **out_model) {
    dpc_clear_error();
    if (!out_model) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "out_model is NULL");
    *out_model = NULL;
    if (!name) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "name is NULL");
    char path[DPC_PATH_MAX];
    const dpc_status st = dpc_model_find(name, path, sizeof path);
    return st == DPC_OK ? dpc_model_load_file(path, options, out_model) : st;
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

dpc_status dpc_model_get_balance(const dpc_model *model, uint32_t *out_radius) {
    dpc_clear_error();
    if (!model || !out_radius) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out_radius is NULL");
    *out_radius = model->cascade.balance;
    return DPC_OK;
}

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

dpc_status dpc_model_neighbours(const dpc_model *model, double *out_neighbours) {
    dpc_clear_error();
    if (!model || !out_neighbours) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out_neighbours is NULL");
    *out_neighbours = model->neighbours;
    return DPC_OK;
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

dpc_status dpc_model_metadata_at(const dpc_model *model, size_t index, const char **out_key, const char **out_value) {
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
    dpc_input_uniform(seed, n_points * dims, out);
    return DPC_OK;
}

dpc_status dpc_stratified(uint64_t seed, size_t n_points, size_t dims, float *out) {
    dpc_clear_error();
    dpc_status st = check_input_size(out, n_points, dims);
    if (st != DPC_OK) return st;
    if (n_points > DPC_MAX_POINTS)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points requested, at most %u per set", n_points, DPC_MAX_POINTS);
    dpc_input_stratified(seed, n_points, dims, out);
    return DPC_OK;
}

/* Caller's points for dpc_filter and dpc_balance: every coordinate in [0, 1). */
static dpc_status check_unit_points(const float *points, size_t n_points, size_t dims) {
    for (size_t i = 0; i < n_points * dims; i++)
        if (!(points[i] >= 0.0f && points[i] < 1.0f))
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "point %zu, dimension %zu is %g: points must lie in [0, 1)",
                            i / dims, i % dims, (double)points[i]);
    return DPC_OK;
}

dpc_status dpc_balance(float *points, size_t n_points, size_t dims, uint32_t radius) {
    dpc_clear_error();
    if (!points) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "points is NULL");
    if (n_points == 0 || dims == 0 || dims > DPC_MAX_DIMS)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "n_points must be positive and dims in 1..%u", DPC_MAX_DIMS);
    if (n_points > DPC_MAX_POINTS)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points, at most %u per set", n_points, DPC_MAX_POINTS);
    if (radius > DPC_BALANCE_MAX_K)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "radius is %u, at most %u", radius, DPC_BALANCE_MAX_K);
    const uint32_t k = dpc_balance_radius(radius, n_points, dims);
    if (k && !dpc_balance_frequencies(k, dims)) /* before the scan: LIMIT whatever the points */
        return dpc_fail(DPC_ERROR_LIMIT, "radius %u holds more than %u frequencies in %zu dimensions", k,
                        DPC_BALANCE_MAX_FREQS, dims);
    const dpc_status st = check_unit_points(points, n_points, dims);
    return st == DPC_OK ? dpc_balance_points(points, n_points, dims, k, 0) : st;
}

dpc_status dpc_relax_prefixes(float *points, size_t n_points, uint32_t base, uint32_t steps, uint32_t threads) {
    dpc_clear_error();
    if (!points) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "points is NULL");
    if (base < 2 || n_points < base)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "base is %u and n_points %zu: base >= 2 and n_points >= base", base,
                        n_points);
    if (n_points > DPC_MAX_POINTS)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points, at most %u per set", n_points, DPC_MAX_POINTS);
    if (steps > DPC_RELAX_MAX_STEPS)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "steps is %u, at most %u", steps, DPC_RELAX_MAX_STEPS);
    const dpc_status st = check_unit_points(points, n_points, 2);
    return st == DPC_OK ? dpc_relax_points(points, n_points, base, steps, dpc_threads_resolve(threads), NULL, NULL)
                        : st;
}

dpc_status dpc_order_levels(float *points, size_t n_points, size_t dims, uint32_t base) {
    dpc_clear_error();
    if (!points) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "points is NULL");
    if (n_points == 0 || dims == 0 || dims > DPC_MAX_DIMS || base == 0)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "n_points and base must be positive and dims in 1..%u",
                        DPC_MAX_DIMS);
    if (n_points > DPC_MAX_POINTS)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points, at most %u per set", n_points, DPC_MAX_POINTS);
    const dpc_status st = check_unit_points(points, n_points, dims);
    return st == DPC_OK ? dpc_order_level_points(points, n_points, (uint32_t)dims, base) : st;
}

/* Progress of one dpc_generate_ex call, shared by its worker threads (common/threads.h). */
typedef dpc_progress_state progress;

/* The CPU engine's hook (cpu_cascade.h): before each set and between chunks of points inside a
 * long layer (a poll, so that a cancel is seen within a layer), and after each layer (one unit
 * of progress). */
static dpc_status engine_hook(void *ctx, int layer_done) {
    return dpc_progress_add((progress *)ctx, layer_done ? 1u : 0u);
}

#if defined(DPC_HAVE_VULKAN)
/* Inputs of a Vulkan run: the model's input points (model/input.h, as on the CPU), or the
 * caller's points. */
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
    dpc_input_fill(c, in->model->input, in->seed + set, in->m, x);
}

static dpc_status vk_generate(const dpc_model *model, uint64_t seed, size_t count, size_t m, float *out) {
    vk_inputs in = {model, seed, m, NULL};
    const dpc_cascade *c = &model->cascade;
    dpc_status st = dpc_vk_run(model->vk, c, count, m, vk_fill, &in, out);
    const uint32_t k = dpc_balance_radius(c->balance, m, c->dims); /* the generator's last step, on the host */
    for (size_t s = 0; st == DPC_OK && k && s < count; s++)
        st = dpc_balance_points(out + s * m * c->dims, m, c->dims, k, 0);
    return st;
}
#endif

dpc_status dpc_generate_n(const dpc_model *model, uint64_t seed, size_t n_points, float *out) {
    dpc_clear_error();
    if (!model || !out) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out is NULL");
    dpc_status st = dpc_model_check_count(model, &n_points);
    if (st != DPC_OK) return st;
#if defined(DPC_HAVE_VULKAN)
    if (model->backend == DPC_BACKEND_VULKAN) return vk_generate(model, seed, 1, n_points, out);
#endif
    return dpc_cpu_generate(&model->cascade, model->input, &model->engine, seed, 1, n_points, out, NULL, NULL);
}

dpc_status dpc_generate_density(const dpc_model *model, const float *density, uint32_t width, uint32_t height,
                                uint64_t seed, size_t n_points, float *out) {
    dpc_clear_error();
    if (!model || !out) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out is NULL");
    dpc_status st = dpc_density_check(model, density, width, height);
    if (st != DPC_OK) return st;
    if ((st = dpc_model_check_count(model, &n_points)) != DPC_OK) return st;
    return dpc_density_generate(model, density, width, height, seed, n_points, out);
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

void dpc_generate_options_init(dpc_generate_options *options) {
    if (!options) return;
    memset(options, 0, sizeof *options);
    options->struct_size = (uint32_t)sizeof *options;
}

dpc_status dpc_generate_size(const dpc_model *model, size_t count, size_t n_points, size_t *out_floats) {
    dpc_clear_error();
    if (!model || !out_floats) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out_floats is NULL");
    *out_floats = 0;
    if (count == 0) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "count must be positive");
    dpc_status st = dpc_model_check_count(model, &n_points);
    if (st != DPC_OK) return st;
    const size_t stride = n_points * model->cascade.dims;
    if (count > SIZE_MAX / stride) return dpc_fail(DPC_ERROR_LIMIT, "count * n_points * dims overflows");
    *out_floats = count * stride;
    return DPC_OK;
}

static dpc_status generate_batch(const dpc_model *model, uint64_t seed, size_t count, size_t n_points, progress *p,
                                 float *out) {
    if (!model || !out) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or out is NULL");
    size_t floats;
    dpc_status st = dpc_generate_size(model, count, n_points, &floats);
    if (st != DPC_OK) return st;
    if (!n_points) n_points = model->cascade.n_points;
    if (p) p->total = (uint64_t)count * model->cascade.n_layers * dpc_cpu_filter_runs(&model->cascade, n_points);
#if defined(DPC_HAVE_VULKAN)
    if (model->backend == DPC_BACKEND_VULKAN) { /* many sets per dispatch: progress once, at the end */
        if (dpc_progress_add(p, 0) != DPC_OK)
            return dpc_fail(DPC_ERROR_CANCELLED, "cancelled by the progress callback");
        if ((st = vk_generate(model, seed, count, n_points, out)) != DPC_OK) return st;
        if (dpc_progress_add(p, p ? p->total : 0) != DPC_OK)
            return dpc_fail(DPC_ERROR_CANCELLED, "cancelled by the progress callback");
        return DPC_OK;
    }
#endif
    return dpc_cpu_generate(&model->cascade, model->input, &model->engine, seed, count, n_points, out,
                            p ? engine_hook : NULL, p);
}

dpc_status dpc_generate_batch(const dpc_model *model, uint64_t seed, size_t count, size_t n_points, float *out) {
    dpc_clear_error();
    return generate_batch(model, seed, count, n_points, NULL, out);
}

dpc_status dpc_generate_ex(const dpc_model *model, uint64_t seed, size_t count, size_t n_points,
                           const dpc_generate_options *options, float *out) {
    dpc_clear_error();
    dpc_generate_options opts;
    dpc_generate_options_init(&opts);
    if (options) {
        if (options->struct_size != sizeof opts)
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                            "options.struct_size is %u, expected %u: initialise with dpc_generate_options_init",
                            options->struct_size, (unsigned)sizeof opts);
        opts = *options;
    }
    if (!opts.progress) return generate_batch(model, seed, count, n_points, NULL, out);
    progress p;
    const dpc_status begun = dpc_progress_begin(&p, opts.progress, opts.user);
    if (begun != DPC_OK) return begun;
    const dpc_status st = generate_batch(model, seed, count, n_points, &p, out);
    dpc_progress_end(&p);
    return st;
}

dpc_status dpc_filter(const dpc_model *model, size_t n_points, float *points) {
    dpc_clear_error();
    if (!model || !points) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "model or points is NULL");
    if (n_points == 0) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "n_points must be positive");
    dpc_status st = dpc_model_check_count(model, &n_points);
    if (st != DPC_OK) return st;
    if ((st = check_unit_points(points, n_points, model->cascade.dims)) != DPC_OK) return st;
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
static dpc_status check_layer_call(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                                   const double *x, dpc_train_layer *out) {
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
    if (count == 0 || n_points == 0) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "count and n_points must be positive");
    if (n_points > DPC_MAX_POINTS)
        return dpc_fail(DPC_ERROR_LIMIT, "%zu points per set, at most %u", n_points, DPC_MAX_POINTS);
    if ((unsigned long long)n_points * n > DPC_MAX_FLOATS_PER_SET)
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

void dpc_layer_options_init(dpc_layer_options *options) {
    if (!options) return;
    memset(options, 0, sizeof *options);
    options->struct_size = (uint32_t)sizeof *options;
    options->threads = 1;
    options->isa = DPC_ISA_AUTO;
}

static dpc_status layer_options(const dpc_layer_options *options, dpc_layer_options *out) {
    dpc_layer_options_init(out);
    if (!options) return DPC_OK;
    if (options->struct_size != sizeof *out)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT,
                        "options.struct_size is %u, expected %u: initialise with dpc_layer_options_init",
                        options->struct_size, (unsigned)sizeof *out);
    *out = *options;
    if (out->isa != DPC_ISA_AUTO && out->isa != DPC_ISA_SCALAR && out->isa != DPC_ISA_AVX2 &&
        out->isa != DPC_ISA_AVX512)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "options.isa is %d: use DPC_ISA_AUTO, _SCALAR, _AVX2 or _AVX512",
                        (int)out->isa);
    return DPC_OK;
}

dpc_status dpc_layer_forward_ex(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                                const double *x, double *y, const dpc_layer_options *options) {
    dpc_clear_error();
    dpc_layer_options o;
    dpc_status st = layer_options(options, &o);
    if (st != DPC_OK) return st;
    dpc_train_layer L;
    if ((st = check_layer_call(layer, kernels, count, n_points, x, &L)) != DPC_OK) return st;
    if (!y) return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "y is NULL");
    return dpc_train_forward(&L, count, n_points, x, y, o.threads, o.isa);
}

dpc_status dpc_layer_backward_ex(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                                 const double *x, const double *grad_y, double *grad_x, double *grad_kernels,
                                 const dpc_layer_options *options) {
    dpc_clear_error();
    dpc_layer_options o;
    dpc_status st = layer_options(options, &o);
    if (st != DPC_OK) return st;
    dpc_train_layer L;
    if ((st = check_layer_call(layer, kernels, count, n_points, x, &L)) != DPC_OK) return st;
    if (!grad_y || !grad_x || !grad_kernels)
        return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "grad_y, grad_x or grad_kernels is NULL");
    const size_t total = count * n_points * L.n;
    for (size_t i = 0; i < total; i++)
        if (!isfinite(grad_y[i]))
            return dpc_fail(DPC_ERROR_INVALID_ARGUMENT, "grad_y: set %zu, point %zu, dimension %zu is not finite",
                            i / (n_points * L.n), i / L.n % n_points, i % L.n);
    return dpc_train_backward(&L, count, n_points, x, grad_y, grad_x, grad_kernels, o.threads, o.isa);
}

dpc_status dpc_layer_forward(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                             const double *x, double *y, uint32_t threads) {
    dpc_layer_options o;
    dpc_layer_options_init(&o);
    o.threads = threads;
    return dpc_layer_forward_ex(layer, kernels, count, n_points, x, y, &o);
}

dpc_status dpc_layer_backward(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                              const double *x, const double *grad_y, double *grad_x, double *grad_kernels,
                              uint32_t threads) {
    dpc_layer_options o;
    dpc_layer_options_init(&o);
    o.threads = threads;
    return dpc_layer_backward_ex(layer, kernels, count, n_points, x, grad_y, grad_x, grad_kernels, &o);
}
