/*
 * dpc.h: the one public header of libdpc, the Deep Point Correlation runtime.
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
 *   the cells left over spread at random), in random order. A local filter cascade cannot
 *   remove large-scale density fluctuations, so from uniform input a blue-noise model's power
 *   at the lowest frequencies grows with the point count (bnot-2d, 65,536 points: 1.36, white
 *   noise 1.0); from stratified input it stays near 0. Meant for blue-noise models; patterns
 *   that want low-frequency power (pink, green) lose it. Not for gridded models. */
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
     * model passes at every count (their largest: 201, bnot-2d-wide; bnot-2d: 50); INFINITY
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
 * DPC_ERROR_LIMIT); DPC_ERROR_IO with the folders searched when there is no such file.
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
 * docs/model-format.md), so counts other than the trained one are served; quality away from the
 * trained count is measured in docs/models.md. Gridded models accept only their grid's count.
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
 * of a smooth displacement. A blue-noise set moves by about 0.5 % of its mean spacing: its power at
 * those torus-scale frequencies, which smooth integrands see most, falls from about 1e-4 to float32 rounding.
 * Sequential double arithmetic with its own sin/cos: the same bits on every machine. radius 0:
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
 * and for every thread count. Its cost grows as n_points * steps (docs/progressive.md has the
 * measured times). base >= 2, n_points >= base, steps <= 100,000 (0: nothing changes);
 * DPC_ERROR_OUT_OF_MEMORY leaves the points unchanged. */
DPC_API dpc_status dpc_relax_prefixes(float *points, size_t n_points, uint32_t base, uint32_t steps, uint32_t threads);

/* The order within the levels of a progressive set (docs/model-format.md §6), in place on an
 * ordered set of n_points x dims points in [0, 1): the levels are the first min(n_points, base)
 * points, then blocks that double the count (the last one: what is left); within each, the
 * points are reordered so that each next one fills the emptiest place left among the points
 * before it, so every prefix, not only the level sizes, is spread. Each level keeps its set of
 * points. What the generator of a progressive model does last. Plain double arithmetic
 * (+, -, *, /): the same order on every machine. Its cost per point grows with the points that
 * share a cell of about 8 mean spacings' area (a few for well-spread sets: about 3 % of
 * progressive-2d's generation time; clustered points cost more). base >= 1;
 * DPC_ERROR_OUT_OF_MEMORY leaves the points unchanged. */
DPC_API dpc_status dpc_order_levels(float *points, size_t n_points, size_t dims, uint32_t base);

/* ---------------------------------------------------------------------------------------------
 * Sampler: values for (pixel, sample index, dimension), for a renderer
 *
 * The rules a renderer follows:
 * 1. A "dimension" is one 2-D slot: take either one value (dpc_sampler_get_1d) or one pair
 *    (dpc_sampler_get_2d) from each dimension, never both from the same one, and number the
 *    dimensions 0, 1, 2, ... in the order the renderer consumes them, the same for every sample.
 * 2. Dimension 0 is the film position (the sample's place in the pixel): give it to the camera.
 *    By default it is not folded (options.fold_from) and, for spp a power of two, it is a net.
 * 3. Pass the pixel's integer coordinates (x, y) and the sample index 0 .. spp - 1; set spp
 *    (options.samples_per_pixel) to the samples you take per pixel.
 * 4. Create the sampler once, before rendering: lookups are then lock-free on any thread, and
 *    the models may be freed.
 * 5. options.models points to const model pointers: `const dpc_model *models[] = {model};
 *    o.models = models;` (in C, the address of a `dpc_model *` variable does not convert).
 *
 * A sampler holds, for each of its D dimension slots, a dpc point set of spp points (spp =
 * samples per pixel), generated once when it is created on the CPU backend (whose ISA paths all
 * give the same bits; up to 16 sets at once, on the first model's threads, one thread per set),
 * so the tables are the same on every machine. A lookup for pixel (x, y), sample index i and
 * dimension d reads table d mod D at point (i mod spp) rotated by a per-pixel offset, and shifts
 * it toroidally by the pixel's entry of a 32 x 32 screen-space mask (rotated per dimension and
 * moved per dimension and 32 x 32 tile, so no two tiles repeat each other's samples): each
 * pixel gets the model's blue-noise set, and neighbouring pixels get shifts chosen so that
 * their errors cancel at low screen frequencies (blue-noise error in screen space at low
 * sample counts). docs/rendering.md defines every step and the reasoning.
 *
 * - Values are in [0, 1). Every value is a pure function of (the models' files, their input
 *   kinds, spp, D, fold_from, net_dims, seed, x, y, i, d), the same bits across runs, threads and
 *   machines (IEEE-754 float arithmetic in a fixed order; no FMA contraction).
 * - Any pixel: x and y are taken modulo 2^32 (negative coordinates cast to uint32_t tile
 *   seamlessly). Any dimension: d >= D reuses table d mod D with its own index rotation and
 *   shift. Any index: indices i >= spp continue in passes of spp samples, pass i / spp rotated
 *   by its own shift (each pass is a shifted copy of the table: use spp >= the samples you take).
 * - Progressive models (dpc.order = "progressive", e.g. progressive-2d; all of the
 *   sampler's models or none): tables are read in order, not rotated per pixel, so a pixel's
 *   first 2^k samples (k >= 4) are a blue-noise set of their own and an adaptive renderer may
 *   stop at any of them, or between them (each level's points come in the order that fills the
 *   emptiest place first: dpc_order_levels; with dpc.relax, e.g. progressive-2d-relaxed, each
 *   prefix is better blue noise, and creation takes far longer: see options.progress);
 *   get_1d then uses the stratum of point i's x rank (docs/progressive.md). Net slots are then
 *   read in order (the first in the net's Sobol' order, later ones shuffled within each octave
 *   [2^(k-1), 2^k)), so their first 2^k samples are a (0,k,2)-net.
 * - Each value, over seeds, is uniformly distributed on a grid of 2^-24: estimates are unbiased.
 * - get_1d draws from the stratified lattice (j + u) / spp (one value per stratum, u the pixel's
 *   mask value), get_2d from the model's set; dimension d of get_1d and of get_2d share their
 *   index rotation and shift (hence rule 1).
 * - Dimensions from options.fold_from on (default 1: all but the pixel position, dimension 0)
 *   are folded by the baker's transform, which makes smooth integrands periodic over the table;
 *   net slots (options.net_dims) are never folded.
 * - A created sampler is immutable: lookups take no lock, allocate nothing and may run on any
 *   number of threads. It does not keep the models: they may be freed after dpc_sampler_create.
 *   To stay cheap, lookups leave the thread's error message alone unless they fail (the one
 *   exception to the convention at the top of this header).
 * - Memory: sizeof(dpc_sampler) + D * (8 * spp + 8) + min(D, 64) * 12,288 bytes, plus
 *   N * 4 * spp for the nets, N the net slots (below) (64 spp, 16 dimensions, the default's 16
 *   nets: 204.7 KiB; the third term holds each of the first 64 dimensions' mask with its
 *   rotation added, so that a lookup reads it instead of computing it), plus a 12 KiB mask
 *   shared by all samplers.
 * - Net slots: when spp = 2^m >= 2, slots t < N hold blue-noise (0,m,2)-nets instead of the
 *   models' sets, each pixel's digitally shifted rather than toroidally: every elementary
 *   interval of a pixel's samples holds one sample. N = min(options.net_dims, D); the default,
 *   DPC_SAMPLER_NET_DIMS_AUTO, is N = D (every slot) from DPC_SAMPLER_AUTO_NETS_SPP = 32 spp on
 *   for set models and N = 1 (dimension 0, the pixel position) otherwise.
 * ------------------------------------------------------------------------------------------- */

typedef struct dpc_sampler dpc_sampler;

#define DPC_SAMPLER_MAX_SPP (1u << 16)
#define DPC_SAMPLER_MAX_DIMENSIONS 4096u

typedef struct dpc_sampler_options {
    uint32_t struct_size; /* sizeof(dpc_sampler_options), set by dpc_sampler_options_init */
    /* Point models the tables come from, without grid axes, dims >= 2 each. A model of n dims
     * fills n / 2 consecutive slots from one set (its dimensions 0-1, 2-3, ...: each slot keeps
     * that pair's 2-D structure; the pixel's index rotation differs per slot, so structure
     * across pairs, e.g. dimensions 0-2, is not kept unless the models are progressive); the
     * models are used in turn, starting over after the last, until D slots are filled. */
    const dpc_model *const *models;
    uint32_t n_models;          /* >= 1 */
    uint32_t samples_per_pixel; /* spp: points per table, 1 .. DPC_SAMPLER_MAX_SPP (default 16) */
    uint32_t dimensions;        /* D: tables, 1 .. DPC_SAMPLER_MAX_DIMENSIONS (default 16) */
    /* Dimensions d >= fold_from return their value v folded by the baker's (tent) transform
     * 1 - |2v - 1| (on the 2^-24 grid: 2v below 1/2, 2(1 - v) - 2^-24 from 1/2 on, a bijection
     * of the grid, so values stay uniform). A shifted table wraps around the unit square, where
     * a renderer's integrands (a light's area, a BSDF lobe) are not periodic: the wrap is a jump
     * the points must integrate. Folded, every continuous integrand is periodic (on the
     * soft-shadow scene of docs/rendering.md the MSE halves from 16 spp on); the cost is twice
     * the length of the integrand's own discontinuities, which is why dimension 0, the pixel
     * position (geometry edges), is left as it is. Net slots (net_dims) are never folded: the
     * tent map would undo their stratification. Default 1; DPC_SAMPLER_NO_FOLD for none, 0
     * for all set slots. */
    uint32_t fold_from;
    /* Slots t < net_dims hold (0,m,2)-nets instead of the models' sets when spp = 2^m >= 2
     * (docs/rendering.md, "Net dimensions"): every elementary interval of the pixel's samples
     * (1 x n, 2 x n/2, ... boxes) holds one sample, as in a scrambled Sobol' net, and the net is
     * blue noise on average over its randomisation. A pixel's samples are the net XORed by a
     * digital shift of its own (the mask's toroidal shift would undo the intervals), plus a
     * uniform offset inside each sample's cell. For dimension 0, the pixel position: geometry
     * edges nearly along the pixel axes (a light's rim) are integrated like a (0,2)-sequence's,
     * where the sets' 1 x n strata alone trail it. In the other dimensions nets beat the folded
     * sets on a renderer's per-pixel error from 32 spp on, and the sets keep the mask's
     * screen-space structure below (docs/rendering.md, "Nets in every slot"). Default
     * DPC_SAMPLER_NET_DIMS_AUTO: every slot from DPC_SAMPLER_AUTO_NETS_SPP on (set models;
     * progressive samplers keep 1: more were not measured in a renderer), else 1; 0 for none. */
    uint32_t net_dims;
    uint64_t seed; /* default 0 */
    /* NULL (default): none. Called with done / total = sets made / sets to make (the tables'
     * point sets), after each batch of sets and with the same `done` inside each set's work (a
     * poll: between the cascade's chunks and layers, before every step of a progressive model's
     * relaxation), so a nonzero return stops creation promptly with DPC_ERROR_CANCELLED. Calls
     * never overlap but may come from libdpc's worker threads (see dpc_progress_fn). Added after
     * `seed`: a struct_size of offsetof(dpc_sampler_options, progress) is still accepted, as
     * none. */
    dpc_progress_fn progress;
    void *user; /* passed to progress */
} dpc_sampler_options;

#define DPC_SAMPLER_NO_FOLD 0xFFFFFFFFu
/* options.net_dims: every slot from DPC_SAMPLER_AUTO_NETS_SPP samples per pixel on (set
 * models), else 1 (dimension 0). */
#define DPC_SAMPLER_NET_DIMS_AUTO 0xFFFFFFFFu
#define DPC_SAMPLER_AUTO_NETS_SPP 32u

/* Fill *options with the defaults (no models: set models and n_models). */
DPC_API void dpc_sampler_options_init(dpc_sampler_options *options);

/* Build a sampler: D sets of spp points through the models' cascades (bench/bench_sampler.c
 * measures it). On failure *out_sampler is NULL. */
DPC_API dpc_status dpc_sampler_create(const dpc_sampler_options *options, dpc_sampler **out_sampler);
/* Release a sampler. NULL is a no-op. */
DPC_API void dpc_sampler_free(dpc_sampler *sampler);

/* One value in [0, 1) for pixel (x, y), sample index, dimension. */
DPC_API dpc_status dpc_sampler_get_1d(const dpc_sampler *sampler, uint32_t x, uint32_t y, uint32_t index,
                                      uint32_t dimension, float *out);
/* Two values in [0, 1): out[0], out[1]. */
DPC_API dpc_status dpc_sampler_get_2d(const dpc_sampler *sampler, uint32_t x, uint32_t y, uint32_t index,
                                      uint32_t dimension, float *out);

/* The sampler's tables: table t (0 <= t < D) is spp points of 2 floats, row-major; *out_table
 * stays valid while the sampler lives. For inspection and for reimplementing lookups elsewhere
 * (e.g. on a GPU) from docs/rendering.md. */
DPC_API dpc_status dpc_sampler_table(const dpc_sampler *sampler, uint32_t t, const float **out_table);
/* The 32 x 32 screen-space mask shared by all samplers: 3072 floats, pixel (x, y) at
 * (y * 32 + x) * 3: its 2-D shift, then its 1-D offset. Static storage. */
DPC_API const float *dpc_sampler_mask(void);

/* ---------------------------------------------------------------------------------------------
 * Threshold masks (docs/masks.md)
 *
 * dpc_mask_design makes dpc's `annealed` blue-noise masks, the ones dpc.masks serves: Ulichney's
 * void-and-cluster (1993; Gaussian filter sigma = 1.5 pixels on the torus) per frame or channel,
 * then simulated annealing of rank swaps on a Gaussian-weighted spectral energy of the mask and
 * of its thresholded patterns at the 63 levels k / 64; for a spatiotemporal mask also of each
 * pixel's values along time, for a vector mask also of the joint box patterns (docs/masks.md,
 * "Annealed masks", states the energy and its constants).
 * - Masks tile (toroidal) and are rank-exact: each frame (or channel) holds every rank
 *   0 ... N*N - 1 once. The threshold value of rank r is (r + 1/2) / (N*N).
 * - out_ranks[((f * N + y) * N + x) * C + c]: frame f, pixel (x, y), channel c (C = channels).
 * - Deterministic: the same ranks for the same options and seed on every machine and compiler
 *   (plain double operations in a fixed order; no libm call).
 * - Cost: O(N^4) time, one thread: 64 x 64 about 11 s, 128 x 128 about 3 minutes, 32 x 32 x 16
 *   about 14 s (`python models/mask_report.py cost`); steps_per_pixel = 0 gives the
 *   void-and-cluster start alone (under a second at 64 x 64). Memory: the spectra the annealer
 *   keeps, at most DPC_MASK_MAX_STATE bytes (else DPC_ERROR_LIMIT before any allocation):
 *   16 * 64 * (T * C * F + N * N * (T / 2 + 1 if T > 1)) bytes, F about 0.22 N^2 frequencies:
 *   64 x 64 0.9 MiB, 128 x 128 3.5 MiB, 64 x 64 x 16 50 MiB.
 * Engines that bake masks at load time call it once per mask and keep the result; dpc ships the
 * common designs precomputed (python/dpc/data/masks/, made by this function).
 * ------------------------------------------------------------------------------------------- */

#define DPC_MASK_MAX_SIZE 1024u
#define DPC_MASK_MAX_FRAMES 1024u
#define DPC_MASK_MAX_STATE (8ull << 30)

typedef struct dpc_mask_options {
    uint32_t struct_size;     /* sizeof(dpc_mask_options), set by dpc_mask_options_init */
    uint32_t size;            /* N: N x N pixels, 8 .. DPC_MASK_MAX_SIZE (default 64) */
    uint32_t frames;          /* T: 1 (default), or 2 .. DPC_MASK_MAX_FRAMES for a spatiotemporal mask */
    uint32_t channels;        /* 1 (default), or 2 for a vector mask, blue per channel and jointly (frames 1) */
    uint32_t steps_per_pixel; /* annealing proposals per pixel and frame or channel (default 600) */
    /* NULL (default): none. Called with done / total = proposals made / steps_per_pixel * N*N * T*C,
     * every 65,536 proposals and at the end; before the first proposal (the void-and-cluster
     * start, the first spectra) with done = 0 every few million inner steps, as a poll (total
     * then at least 1, also when steps_per_pixel is 0). Nonzero stops with DPC_ERROR_CANCELLED. */
    dpc_progress_fn progress;
    void *user; /* passed to progress */
} dpc_mask_options;

/* Energies of the design, for diagnostics: at the void-and-cluster start, at the end, and the
 * number of swaps the annealer accepted. */
typedef struct dpc_mask_stats {
    double energy_start, energy_end;
    uint64_t accepted;
} dpc_mask_stats;

/* Fill *options with the defaults (a 64 x 64 scalar mask, 600 proposals per pixel). */
DPC_API void dpc_mask_options_init(dpc_mask_options *options);
/* *out_count = frames * size * size * channels, the uint32 values dpc_mask_design writes. */
DPC_API dpc_status dpc_mask_count(const dpc_mask_options *options, size_t *out_count);
/* Design a mask (see above) into out_ranks (dpc_mask_count values); out_stats may be NULL. On
 * failure out_ranks is left unspecified. */
DPC_API dpc_status dpc_mask_design(const dpc_mask_options *options, uint64_t seed, uint32_t *out_ranks,
                                   dpc_mask_stats *out_stats);

/* ---------------------------------------------------------------------------------------------
 * Training support: one filter layer in float64
 *
 * The forward and backward passes of one PointFilter layer (docs/model-format.md section 3) for a
 * training framework. Everything is float64 (h_t, distances, sums): results match the float64
 * reference of the format to rounding, not the float32 cascade of dpc_generate bit for bit.
 * Work is O(m * neighbours) per set (toroidal cell grid, or all pairs where a grid does not
 * pay), memory O(m * n + cells); never O(m^2). Outputs are bit-identical for every thread count.
 * The kernels run on the ISA path of dpc_layer_options.isa (DPC_ISA_AUTO, the default and what
 * dpc_layer_forward / _backward use: the path the inference engine would pick, i.e. the
 * environment variable DPC_ISA, else the best the CPU has; a bad DPC_ISA or a path the CPU lacks
 * fails the call the same way); paths differ by rounding only. Each path on its own gives the
 * same bits on every machine that has it.
 *
 * Backward, per set, with G = dL/dy (m x n). The wrap y - floor(y) is treated as the identity.
 * For subspace t with dimension set D_t and an ordered pair (i, j) with e_t < d < r_t:
 *   delta = x_j (-) x_i over D_t (toroidal), d = |delta|, nh = delta / d,
 *   u = d (b-1) / r_t, q = min(floor(u), b-2), f = u - q, g = w[q] + f (w[q+1] - w[q]),
 *   g' = (w[q+1] - w[q]) (b-1) / r_t, and v_i[k] = h_t G_i[k] / c_k for moving k in D_t, 0 for
 *   fixed k. Then
 *   dL/dx_i   = G_i + sum_t sum_j J(delta_ij) (v_j - v_i),
 *               J(delta) = g' nh nh^T + (g / d) (I - nh nh^T)    (the Jacobian of g(d) delta/d)
 *   dL/dw_t[q]   += (1 - f) (nh . v_i),   dL/dw_t[q+1] += f (nh . v_i)
 * summed over every ordered pair of every set. J is even in delta, so each point only gathers
 * from its own neighbours. Gradients flow into fixed coordinates too (they shape distances).
 * Pairs exactly at d = e_t or d = r_t, and distances exactly on a bin edge, are kinks where this
 * is a one-sided derivative.
 * ------------------------------------------------------------------------------------------- */

/* One PointFilter layer, as in a model file. */
typedef struct dpc_layer_desc {
    uint32_t dims;             /* n: 1 .. DPC_MAX_DIMS */
    uint32_t n_subspaces;      /* s: 1 .. 64 */
    uint32_t bins;             /* b: 2 .. 65536 */
    const uint64_t *subspaces; /* s bitmasks: nonzero, only bits < n, pairwise distinct */
    const double *radius;      /* s values rho_t in units of h_t: finite, 0 < rho_t <= 1e6 */
    double eps;                /* cutoff in units of h_t: finite, >= 0 */
    uint64_t fixed;            /* dimensions the layer never moves: only bits < n */
} dpc_layer_desc;

/* How a layer call runs. Initialise with dpc_layer_options_init(). */
typedef struct dpc_layer_options {
    uint32_t struct_size; /* sizeof(dpc_layer_options), set by dpc_layer_options_init */
    uint32_t threads;     /* worker threads: 1 (default), 0 = one per online CPU; bits do not depend on it */
    dpc_isa isa;          /* the pair loop's ISA path; default DPC_ISA_AUTO (see above) */
} dpc_layer_options;

/* Fill *options with the defaults. */
DPC_API void dpc_layer_options_init(dpc_layer_options *options);

/* y = layer(x) for count sets of n_points points each: x and y hold count * n_points * dims
 * doubles (set c at offset c * n_points * dims), x finite and in [0, 1). kernels: s * b finite
 * values, row t = subspace t (in units of h_t). y may be x (in place); otherwise the buffers must
 * not overlap. options may be NULL (defaults). */
DPC_API dpc_status dpc_layer_forward_ex(const dpc_layer_desc *layer, const double *kernels, size_t count,
                                        size_t n_points, const double *x, double *y, const dpc_layer_options *options);

/* Gradients of a scalar loss L given grad_y = dL/dy (same shape as x, finite): grad_x = dL/dx
 * (same shape; may be grad_y) and grad_kernels = dL/dkernels (s * b, overwritten, summed over the
 * count sets in set order). Other outputs must not overlap the inputs. options may be NULL. */
DPC_API dpc_status dpc_layer_backward_ex(const dpc_layer_desc *layer, const double *kernels, size_t count,
                                         size_t n_points, const double *x, const double *grad_y, double *grad_x,
                                         double *grad_kernels, const dpc_layer_options *options);

/* dpc_layer_forward_ex / _backward_ex with options {threads, DPC_ISA_AUTO}. */
DPC_API dpc_status dpc_layer_forward(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                                     const double *x, double *y, uint32_t threads);
DPC_API dpc_status dpc_layer_backward(const dpc_layer_desc *layer, const double *kernels, size_t count, size_t n_points,
                                      const double *x, const double *grad_y, double *grad_x, double *grad_kernels,
                                      uint32_t threads);

#ifdef __cplusplus
}
#endif

#endif /* DPC_DPC_H */
