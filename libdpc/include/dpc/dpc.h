/*
 * dpc.h: the public header of libdpc, the Deep Point Correlation runtime: the one include a
 * user needs. It declares models and generation and includes, at its end, dpc_sampler.h (the
 * renderer sampler), dpc_mask.h (designed threshold masks) and dpc_layer.h (one layer's
 * forward and backward, for training).
 *
 * libdpc loads a trained point-pattern model (an ONNX file, see docs/model-format.md) and
 * generates point sets with it: uniform random points from a counter-based generator are pushed
 * through the model's cascade of distance-based point filters.
 *
 * Conventions (stated once, they hold for every call):
 * - Every fallible call returns a dpc_status. DPC_OK is 0. On failure a message describing the
 *   problem is kept per thread; dpc_last_error() returns it until the next failing call on that
 *   thread. libdpc never prints, aborts or exits.
 * - Points are float32, row-major (m, n): point i, dimension k is out[i * n + k], in [0, 1).
 * - Handles are opaque. dpc_model_free(NULL) is a no-op. Output buffers belong to the caller.
 * - A loaded model is immutable: any number of threads may call any function on the same model
 *   at the same time. Results are a pure function of (model file, input kind, seed, point
 *   count), the same bits across runs, thread counts, batch splits, ISA paths (scalar, AVX2,
 *   AVX-512) and machines: every CPU path evaluates one canonical order of float32 operations
 *   (docs/model-format.md §3, "Evaluation order"). The Vulkan backend evaluates the same formula
 *   in the GPU's order and rounding: the same bits run to run on one device and driver, and,
 *   since a deep trained cascade amplifies rounding, other points of the same quality than the
 *   CPU; use the CPU backend where every machine must give the same points.
 * - The header is C99 and C++ clean.
 */
#ifndef DPC_DPC_H
#define DPC_DPC_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(DPC_STATIC_DEFINE)
#define DPC_API
#elif defined(_WIN32)
#ifdef DPC_BUILDING
#define DPC_API __declspec(dllexport)
#else
#define DPC_API __declspec(dllimport)
#endif
#else
#define DPC_API __attribute__((visibility("default")))
#endif

/* ---------------------------------------------------------------------------------------------
 * Version
 * ------------------------------------------------------------------------------------------- */

#define DPC_VERSION_MAJOR 0
#define DPC_VERSION_MINOR 1
#define DPC_VERSION_PATCH 0
#define DPC_VERSION_NUMBER (DPC_VERSION_MAJOR * 10000 + DPC_VERSION_MINOR * 100 + DPC_VERSION_PATCH)

/* The model-file format version this build reads (the "ai.dpc" opset version). */
#define DPC_FORMAT_VERSION 1

/* Runtime version: DPC_VERSION_NUMBER of the library actually linked. */
DPC_API unsigned dpc_version_number(void);
/* Runtime version as a static string, e.g. "0.1.0". */
DPC_API const char *dpc_version_string(void);

/* ---------------------------------------------------------------------------------------------
 * Status and errors
 * ------------------------------------------------------------------------------------------- */

/* Values are pinned: they never change meaning between releases. */
typedef enum dpc_status {
    DPC_OK = 0,
    DPC_ERROR_INVALID_ARGUMENT = 1, /* NULL pointer, zero or out-of-range count, bad option */
    DPC_ERROR_IO = 2,               /* file could not be opened or read */
    DPC_ERROR_FORMAT = 3,           /* file is not a valid dpc model (malformed, truncated, hostile) */
    DPC_ERROR_UNSUPPORTED = 4,      /* valid file or request this build cannot serve (version, ISA) */
    DPC_ERROR_OUT_OF_MEMORY = 5,    /* an allocation failed */
    DPC_ERROR_LIMIT = 6,            /* request exceeds a documented limit (e.g. point count) */
    DPC_ERROR_INTERNAL = 7,         /* a bug in libdpc: please report it */
    DPC_ERROR_CANCELLED = 8         /* a progress callback asked to stop (dpc_generate_ex, sampler, mask) */
} dpc_status;

/* Detail of the most recent failure on the calling thread. Every fallible call clears it when it
 * starts, so after a successful call it is "". The string stays valid until the next libdpc call
 * on this thread. */
DPC_API const char *dpc_last_error(void);
/* Static, human-readable name of a status code ("DPC_ERROR_FORMAT", ...). */
DPC_API const char *dpc_status_string(dpc_status status);

/* ---------------------------------------------------------------------------------------------
 * Loading a model
 * ------------------------------------------------------------------------------------------- */

typedef struct dpc_model dpc_model;

/* Which CPU code path runs the filters. AUTO picks the best the CPU supports (cpuid), unless the
 * environment variable DPC_ISA is "scalar", "avx2" or "avx512". Asking for a path the CPU lacks
 * gives DPC_ERROR_UNSUPPORTED. */
typedef enum dpc_isa {
    DPC_ISA_AUTO = 0,
    DPC_ISA_SCALAR = 1, /* portable reference path */
    DPC_ISA_AVX2 = 2,   /* x86-64 AVX2 + FMA */
    DPC_ISA_AVX512 = 3  /* x86-64 AVX-512F */
} dpc_isa;

/* 1 if this build and this CPU can run isa's path (DPC_ISA_AUTO and DPC_ISA_SCALAR: always),
 * else 0. Every path gives the same bits; they differ in speed only. */
DPC_API int dpc_isa_supported(dpc_isa isa);

/* What runs the cascade.
 * - AUTO: a GPU through Vulkan when this libdpc was built with the Vulkan backend (CMake option
 *   DPC_VULKAN) and the machine has a hardware GPU with a Vulkan driver (looked up once per
 *   process); otherwise the CPU. AUTO never fails for want of a GPU, and never picks a software
 *   Vulkan driver (e.g. lavapipe), which is slower than the CPU backend.
 * - CPU: the CPU backend (isa and threads below).
 * - VULKAN: the Vulkan backend on the best device present, software drivers included. Without a
 *   usable device, or in a build without the Vulkan backend, loading fails with
 *   DPC_ERROR_UNSUPPORTED and a message saying why. The Vulkan loader (libvulkan.so.1) is opened
 *   at run time, so a build with the backend still loads where Vulkan is missing. The first
 *   Vulkan model makes one Vulkan instance for the process and it is kept (drivers can fail
 *   after many load / unload cycles): the loader's environment (VK_DRIVER_FILES, ...) is read
 *   then, once. A failed attempt is not kept; the next load tries again.
 * Every model on the Vulkan backend owns its device queue, command buffer and work buffers (kept
 * at the size of its largest call until the model is freed), guarded by one mutex per model:
 * concurrent calls on one model are safe and wait for each other; different models run
 * concurrently. Vulkan failures are statuses with the VkResult named in dpc_last_error().
 * dpc_model_info's isa and threads describe the CPU backend, which a Vulkan-backed model does not
 * use for filtering. */
typedef enum dpc_backend { DPC_BACKEND_AUTO = 0, DPC_BACKEND_CPU = 1, DPC_BACKEND_VULKAN = 2 } dpc_backend;

/* The input points a model filters (docs/model-format.md §5).
 * - AUTO (default): the kind the model was trained on, from its metadata "dpc.input" ("uniform"
 *   or "stratified"), uniform when the file has no such key (files from before the key). Of the
 *   bundled models, bnot-2d-stratified says "stratified"; the others were trained on uniform
 *   points.
 * - UNIFORM: independent uniform points.
 * - STRATIFIED: the same uniform numbers placed one point per cell of a g^n grid (g^n <= m,
 *   the cells left over spread at random), in random order. It keeps a blue-noise model's power at
 *   the lowest frequencies near 0 at every point count (docs/model-format.md §5). Meant for
 *   blue-noise models; patterns that want low-frequency power (pink, green) lose it. Not for
 *   gridded models. */
typedef enum dpc_input { DPC_INPUT_AUTO = 0, DPC_INPUT_UNIFORM = 1, DPC_INPUT_STRATIFIED = 2 } dpc_input;

/* Options fixed at load time. Initialise with dpc_load_options_init(). */
typedef struct dpc_load_options {
    uint32_t struct_size; /* sizeof(dpc_load_options), set by dpc_load_options_init */
    dpc_isa isa;          /* default DPC_ISA_AUTO */
    /* Worker threads one generate call may use: 1 (default) runs on the calling thread only;
     * 0 means one per online CPU. Output bits do not depend on this. CPU backend only. (The one
     * default of libdpc: also dpc_layer_options, and the Python package, its CLI and training.)
     * The workers come from a pool libdpc keeps for the process (started on first use; an idle
     * worker spins for up to about 0.1 ms, then sleeps; joined when the library is unloaded);
     * a call made while another thread's call holds the pool starts threads of its own. */
    uint32_t threads;
    /* Default DPC_BACKEND_AUTO. The field was added after the first release: a struct_size of
     * the struct without it (offsetof(dpc_load_options, backend)) is still accepted, as AUTO. */
    dpc_backend backend;
    /* Default DPC_INPUT_AUTO. Added after `backend`: a struct_size of
     * offsetof(dpc_load_options, input) is still accepted, as AUTO. */
    dpc_input input;
    /* Bound on the work a model may ask for, so that a host can load files it does not trust:
     * the expected neighbours per point of every layer and subspace, min(m - 1, V_k rho^k)
     * (V_k the volume of the unit k-ball, k the subspace's dimensions, rho its radius in mean
     * spacings, m the requested point count), must not exceed it, else a generate or filter call
     * fails with DPC_ERROR_LIMIT before any work (a file with radius 1e6 would otherwise make
     * every layer all pairs, O(m^2)). Default DPC_DEFAULT_MAX_NEIGHBOURS, which every bundled
     * model passes at every count; INFINITY
     * removes the bound. Must be > 0 (NaN is refused). dpc_model_neighbours() tells a model's
     * value. Added after `input`: a struct_size of offsetof(dpc_load_options, max_neighbours)
     * is still accepted, with the default. */
    double max_neighbours;
} dpc_load_options;

/* The default of dpc_load_options.max_neighbours. */
#define DPC_DEFAULT_MAX_NEIGHBOURS 4096.0

/* Fill *options with the defaults. */
DPC_API void dpc_load_options_init(dpc_load_options *options);

/* Load a model file. options may be NULL (defaults). On success *out_model is a new handle; on
 * failure it is set to NULL. */
DPC_API dpc_status dpc_model_load_file(const char *path, const dpc_load_options *options, dpc_model **out_model);
/* Load a model from memory. The bytes are parsed and not retained after the call returns. */
DPC_API dpc_status dpc_model_load_memory(const void *data, size_t size, const dpc_load_options *options,
                                         dpc_model **out_model);
/* Release a model. NULL is a no-op. No call may use the model during or after this one. */
DPC_API void dpc_model_free(dpc_model *model);

/* Load a model by name, e.g. "bnot-2d": the file dpc_model_find names, then as
 * dpc_model_load_file. */
DPC_API dpc_status dpc_model_load_named(const char *name, const dpc_load_options *options, dpc_model **out_model);
/* The model search, without loading: the first regular file NAME.onnx in the folders of the
 * environment variable DPC_MODEL_PATH (separated by ':'), then in dpc_model_dir(); anything
 * else of that name (a FIFO, a folder, a device) is skipped, never opened. A name is 1 .. 255
 * characters of [A-Za-z0-9._-], not starting with '.' (so it never names a path), else
 * DPC_ERROR_INVALID_ARGUMENT. On success out_path holds the file's path (capacity bytes, the
 * terminating NUL included: DPC_PATH_MAX always suffices; less than the path needs gives
 * DPC_ERROR_LIMIT); DPC_ERROR_IO when there is no such file, its message naming the folders
 * searched and the models they hold (the names this search finds, sorted; the first 256 read).
 * out_path is "" on failure. The Python package (dpc.load) and its Mitsuba plugin use this
 * search. */
DPC_API dpc_status dpc_model_find(const char *name, char *out_path, size_t capacity);
#define DPC_PATH_MAX 4096
/* The folder `cmake --install` put the bundled models in: <prefix>/share/dpc/models found
 * beside the shared library (so a prefix given at install time, or a moved install, still
 * works), else the folder configured at build time (CMAKE_INSTALL_PREFIX: all a static libdpc
 * knows); in the Python package, its own models folder (dpc/models, beside the extension and
 * dpc/lib); "" for a build that installs none. Canonical path; static string. DPC_MODEL_PATH
 * serves any other place. */
DPC_API const char *dpc_model_dir(void);

/* ---------------------------------------------------------------------------------------------
 * Model information
 * ------------------------------------------------------------------------------------------- */

#define DPC_MAX_DIMS 64

typedef struct dpc_model_info {
    uint32_t dims;      /* n: dimensions of each point */
    uint32_t n_points;  /* m the model was trained for (dpc_generate's count) */
    uint32_t layers;    /* filter layers in the cascade */
    uint32_t grid_dims; /* number of gridded (fixed) dimensions, 0 if none */
    /* For each gridded dimension g < grid_dims: its index and cell count. A gridded model always
     * generates exactly the product of grid_shape points. */
    uint32_t grid_axis[DPC_MAX_DIMS];
    uint32_t grid_shape[DPC_MAX_DIMS];
    dpc_isa isa;      /* the ISA path this handle runs (never DPC_ISA_AUTO) */
    uint32_t threads; /* worker threads this handle uses (0 resolved to the CPU count) */
} dpc_model_info;

DPC_API dpc_status dpc_model_get_info(const dpc_model *model, dpc_model_info *out_info);

/* The backend this handle runs on: DPC_BACKEND_CPU or DPC_BACKEND_VULKAN, never AUTO. */
DPC_API dpc_status dpc_model_get_backend(const dpc_model *model, dpc_backend *out_backend);
/* The input points this handle filters: DPC_INPUT_UNIFORM or DPC_INPUT_STRATIFIED, never AUTO. */
DPC_API dpc_status dpc_model_get_input(const dpc_model *model, dpc_input *out_input);
/* The output balance radius K of the model's generator (metadata "dpc.balance"; 0: none): after
 * the cascade, dpc_generate* cancel each set's Fourier coefficients at the integer frequencies
 * 0 < |q| <= K (see dpc_balance; a progressive model balances each level with the level's own
 * points, format §6). dpc_filter runs the cascade alone and does not balance. */
DPC_API dpc_status dpc_model_get_balance(const dpc_model *model, uint32_t *out_radius);
/* What runs the cascade, for people: "cpu", or the Vulkan device's name (e.g. "NVIDIA H100 PCIe",
 * "llvmpipe (LLVM 15.0.6, 256 bits)"). "" for NULL. Valid while the model lives. */
DPC_API const char *dpc_model_device(const dpc_model *model);

/* The largest expected neighbour count per point of any layer and subspace of the model, V_k
 * rho^k (see dpc_load_options.max_neighbours; not yet capped at m - 1). */
DPC_API dpc_status dpc_model_neighbours(const dpc_model *model, double *out_neighbours);

/* Model name (metadata "dpc.name"), or "" when the file has none. Valid while the model lives. */
DPC_API const char *dpc_model_name(const dpc_model *model);
/* Metadata value for key, or NULL if absent. Valid while the model lives. */
DPC_API const char *dpc_model_metadata(const dpc_model *model, const char *key);
/* Number of metadata entries, and entry i (0 <= i < count) by key and value. */
DPC_API size_t dpc_model_metadata_count(const dpc_model *model);
DPC_API dpc_status dpc_model_metadata_at(const dpc_model *model, size_t index, const char **out_key,
                                         const char **out_value);

/* ---------------------------------------------------------------------------------------------
 * Generating point sets
 * ------------------------------------------------------------------------------------------- */

/* Largest point count one set may have. */
#define DPC_MAX_POINTS (1u << 26)

/* Floats needed for count sets of n_points points (count * n_points * dims; n_points = 0 means
 * the trained count); 0 on overflow or a NULL model. */
DPC_API size_t dpc_output_size(const dpc_model *model, size_t count, size_t n_points);

/* Generate the model's trained point count (info.n_points) from seed: out holds n_points * dims
 * floats. Any seed, 0 included, is valid. */
DPC_API dpc_status dpc_generate(const dpc_model *model, uint64_t seed, float *out);

/* Generate n_points points (0 = the trained count). Radii scale with the point count (see
 * docs/model-format.md), so counts other than the trained one are served. Gridded models accept only their grid's count.
 * A progressive model (metadata dpc.order = "progressive", e.g. progressive-2d) returns its
 * points in order: for the same seed, the first n points of a set of m are the set of n for
 * every n = dpc.progressive_base * 2^j <= m (docs/model-format.md §6); it runs on the CPU. */
DPC_API dpc_status dpc_generate_n(const dpc_model *model, uint64_t seed, size_t n_points, float *out);

/* Generate count independent sets into out (count * n_points * dims floats): set c is exactly
 * dpc_generate_n(model, seed + c, n_points, ...) (seed arithmetic wraps modulo 2^64). */
DPC_API dpc_status dpc_generate_batch(const dpc_model *model, uint64_t seed, size_t count, size_t n_points, float *out);

/* Check a request as dpc_generate_batch(model, seed, count, n_points, out) would, without doing
 * it: the same status and message for a bad count (DPC_ERROR_LIMIT beyond DPC_MAX_POINTS, 2^28
 * floats per set, the model's max_neighbours or size_t; DPC_ERROR_INVALID_ARGUMENT for a
 * gridded model's wrong count or count = 0), and on success the floats out needs,
 * count * n_points * dims. For hosts that allocate out themselves (the Python binding). */
DPC_API dpc_status dpc_generate_size(const dpc_model *model, size_t count, size_t n_points, size_t *out_floats);

/* Blue noise that follows a density: n_points points (0 = the trained count) in [0,1)^2 whose
 * local count follows `density`, a width x height grid of cells, piecewise constant: cell
 * (cx, cy) = [cx/width, (cx+1)/width) x [cy/height, (cy+1)/height) has the value
 * density[cy * width + cx] (row cy along the second coordinate). Values are finite and >= 0,
 * not all zero, at most DPC_DENSITY_MAX_CELLS cells; only their ratios matter. The model must be
 * a 2-D set model whose layers filter the plane as a whole (bnot-2d, bnot-2d-stratified,
 * blue-2d, ...; others: DPC_ERROR_UNSUPPORTED). The model's input points are mapped through the
 * density's inverse CDF and every layer runs in units of the local spacing (h_ij, the harmonic
 * mean of the pair's spacings 1/sqrt(n_points * density), or the smaller one where they differ
 * more than 2 times). The square's sides are glide mirrors: across a side a point sees its side's
 * points mirrored and shifted along it by a few mean spacings (no row of points along the sides).
 * Walls, the cell boundaries where the density changes more than 4 times or to zero, are mirrors
 * too (glide mirrors where they run straight; no seam along strong edges), and no step crosses one
 * (so strong edges keep their counts): no point ever lies in a zero-density cell. The output
 * balance of a uniform model is not applied. A pure function of (model file, input kind, density,
 * seed, n_points): the same bits on every CPU ISA and thread count; it runs on the CPU whatever
 * the model's backend. docs/density.md states the definition and its measurements. */
#define DPC_DENSITY_MAX_CELLS (1u << 24)
DPC_API dpc_status dpc_generate_density(const dpc_model *model, const float *density, uint32_t width, uint32_t height,
                                        uint64_t seed, size_t n_points, float *out);

/* Progress and cancellation of a long call. libdpc calls progress(user, done, total) as work
 * goes on: total = count * layers units, one per layer of each set. It is called before and
 * after every set, after every layer where the backend reports layers, and possibly again with
 * the same `done` inside long work (a poll); calls never overlap (libdpc serialises them), but
 * they may come from libdpc's worker threads. Returning nonzero asks libdpc to stop: the call
 * returns DPC_ERROR_CANCELLED at the next such call site (on the CPU backend: within a set, or
 * a layer where the engine polls inside layers; on Vulkan: after the batch), and the contents
 * of out are unspecified. The callback must be cheap and must not call libdpc on that model. */
typedef int (*dpc_progress_fn)(void *user, uint64_t done, uint64_t total);

typedef struct dpc_generate_options {
    uint32_t struct_size;     /* sizeof(dpc_generate_options), set by dpc_generate_options_init */
    dpc_progress_fn progress; /* NULL (default): no callback, never cancelled */
    void *user;               /* passed to progress */
} dpc_generate_options;

/* Fill *options with the defaults. */
DPC_API void dpc_generate_options_init(dpc_generate_options *options);

/* dpc_generate_batch with options (NULL: defaults): the same points, bit for bit, plus progress
 * and cancellation. */
DPC_API dpc_status dpc_generate_ex(const dpc_model *model, uint64_t seed, size_t count, size_t n_points,
                                   const dpc_generate_options *options, float *out);

/* Run the model's cascade on caller-provided points (in place): points holds n_points * dims
 * floats, each in [0, 1) (else DPC_ERROR_INVALID_ARGUMENT); gridded dimensions are left as given. */
DPC_API dpc_status dpc_filter(const dpc_model *model, size_t n_points, float *points);

/* ---------------------------------------------------------------------------------------------
 * The input generator (documented in docs/model-format.md, "Input points")
 * ------------------------------------------------------------------------------------------- */

/* Fill out[0 .. n_points * dims) with the uniform input points of seed: value c (row-major index)
 * is (splitmix64 output number c of the stream seeded by seed) >> 40, times 2^-24. */
DPC_API dpc_status dpc_uniform(uint64_t seed, size_t n_points, size_t dims, float *out);

/* Fill out[0 .. n_points * dims) with the stratified input points of seed (DPC_INPUT_STRATIFIED;
 * docs/model-format.md §5). Needs no memory beyond out. */
DPC_API dpc_status dpc_stratified(uint64_t seed, size_t n_points, size_t dims, float *out);

/* The output balance (docs/model-format.md §5.1), in place on any n_points x dims set of points
 * in [0, 1): cancel its Fourier coefficients sum_j exp(-2 pi i q.x_j) at every integer frequency
 * 0 < |q| <= K, K = min(radius, the largest j with (4 j)^dims <= n_points), by three Newton steps
 * of a smooth displacement. Sequential double arithmetic with its own sin/cos: the same bits on every machine. radius 0:
 * nothing changes. DPC_ERROR_LIMIT when the radius holds more than 4,096 frequencies. */
DPC_API dpc_status dpc_balance(float *points, size_t n_points, size_t dims, uint32_t radius);

/* The prefix relaxation (docs/model-format.md §6.1), in place on an ordered set of n_points 2-D
 * points in [0, 1) (n_points x 2 floats): steps gradient steps move every point at once so that
 * every prefix of base * 2^j points and the whole set are blue noise at their own scale
 * (docs/progressive.md, "Jointly relaxed prefixes"); the first n points are then no longer the
 * caller's first n. What the generator of a model with metadata dpc.relax = steps does after its
 * levels (e.g. progressive-2d-relaxed: base 16, 1,600 steps). Sequential double arithmetic in a
 * fixed order, with its own exp, sin and cos, its work cut into fixed parts that `threads`
 * threads share (0: one per online CPU; from 2,048 points on): the same bits on every machine
 * and for every thread count. Its cost grows as n_points * steps. base >= 2, n_points >= base, steps <= 100,000 (0: nothing changes);
 * DPC_ERROR_OUT_OF_MEMORY leaves the points unchanged. */
DPC_API dpc_status dpc_relax_prefixes(float *points, size_t n_points, uint32_t base, uint32_t steps, uint32_t threads);

/* The order within the levels of a progressive set (docs/model-format.md §6), in place on an
 * ordered set of n_points x dims points in [0, 1): the levels are the first min(n_points, base)
 * points, then blocks that double the count (the last one: what is left); within each, the
 * points are reordered so that each next one fills the emptiest place left among the points
 * before it, so every prefix, not only the level sizes, is spread. Each level keeps its set of
 * points. What the generator of a progressive model does last. Plain double arithmetic
 * (+, -, *, /): the same order on every machine. Its cost per point grows with the points that
 * share a cell of about 8 mean spacings' area (clustered points cost more). base >= 1;
 * DPC_ERROR_OUT_OF_MEMORY leaves the points unchanged. */
DPC_API dpc_status dpc_order_levels(float *points, size_t n_points, size_t dims, uint32_t base);

#ifdef __cplusplus
}
#endif

/* The products on top of models, one header each (each includes this one for the types above):
 * the sampler for renderers, threshold masks, and one filter layer for training frameworks. */
#include "dpc_layer.h"
#include "dpc_mask.h"
#include "dpc_sampler.h"

#endif /* DPC_DPC_H */
