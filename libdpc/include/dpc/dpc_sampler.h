/*
 * dpc_sampler.h: the sampler, values for (pixel, sample index, dimension) for a renderer.
 * dpc.h includes it (include dpc.h); on its own it includes dpc.h for the common types and
 * conventions. docs/rendering.md defines every step and gives the reasoning and measurements.
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
 * A sampler holds, for each of its D dimension slots, a table of spp points, generated once
 * when it is created on the CPU backend (so the tables are the same on every machine). A lookup
 * for pixel (x, y), sample index i and dimension d reads table d mod D at point i mod spp,
 * rotated by a per-pixel offset, and shifts it toroidally by the pixel's entry of a 32 x 32
 * screen-space mask (dpc_sampler_mask), rotated per dimension and moved per 32 x 32 tile.
 *
 * - Values are in [0, 1); each value, over seeds, is uniformly distributed on a grid of 2^-24.
 *   Every value is a pure function of (the models' files, their input kinds, spp, D, fold_from,
 *   net_dims, seed, x, y, i, d): the same bits across runs, threads and machines.
 * - Any pixel: x and y are taken modulo 2^32 (negative coordinates cast to uint32_t tile
 *   seamlessly). Any dimension: d >= D reuses table d mod D with its own index rotation and
 *   shift. Any index: indices i >= n (n = spp * F, the table's points) continue in passes of n
 *   samples, each a shifted copy of the table (use spp * F >= the samples you take).
 * - Progressive models (metadata dpc.order = "progressive"; all of the sampler's models or none,
 *   else DPC_ERROR_INVALID_ARGUMENT): tables are read in order, not rotated per pixel, so a
 *   pixel's first 2^k samples (k >= 4) are a blue-noise set of their own, and net slots' first
 *   2^k samples a (0,k,2)-net (docs/progressive.md).
 * - Frames (options.frames = F > 1, for renderers that take spp samples per frame and average
 *   F frames): frame f takes sample indices f * spp .. f * spp + spp - 1. The tables hold spp * F
 *   points, ordered so that early frames spread over the table, and are read in order, not
 *   rotated per pixel: at 1 spp per frame each frame's values, across pixels, are the mask's
 *   blue noise shifted by one common vector, and each pixel's F frames together are one
 *   toroidally shifted blue-noise set of spp * F points. No net slots. Frames from F on are
 *   later passes (below): a new shift, so a period of F frames repeats nothing.
 * - get_1d draws from the stratified lattice (j + u) / spp (one value per stratum, u the pixel's
 *   mask value, turned by a quarter per quarter of the strata for even spp, so that the values
 *   shifted by 0, 1/4, 1/2, 3/4, as hero-wavelength spectral sampling reads them, fill 4 spp
 *   strata once each; a net slot's 1-D value keeps its point's stratum and takes such a place
 *   in it, or after a net slot forms one (1,m,3)-net per pixel with that slot's 2-D values),
 *   get_2d from the table; dimension d of get_1d and of get_2d share their index
 *   rotation and shift (hence rule 1). With frames the lattice j / (spp * F) is shifted as a
 *   whole by u, so that one frame's values spread over [0, 1) across pixels.
 * - Net slots: when spp = 2^m >= 2, slots t < N hold (0,m,2)-nets instead of the models' sets:
 *   every elementary interval of a pixel's samples holds one sample. N = min(options.net_dims,
 *   D). Screen-ordered (options.net_layout; the default below 64 spp) the samples of each
 *   aligned 2 x 2, 4 x 4, ... group of pixels in a 32 x 32 tile are a finer net too, and each
 *   power-of-two prefix of a pixel's samples a (0,k,2)-net; per pixel, each pixel's net is one
 *   net digitally shifted. dpc_sampler_get_info reports N and the layout.
 * - Threads: a created sampler is immutable: lookups take no lock, allocate nothing and may run
 *   on any number of threads. It does not keep the models: they may be freed after
 *   dpc_sampler_create. Lookups leave the thread's error message alone unless they fail (the one
 *   exception to the convention of dpc.h).
 * - Memory (n = spp * F points per table): sizeof(dpc_sampler) + D * (8 * n + 8) + min(D, 64) * 12,288 + N * 4 * n bytes,
 *   screen-ordered nets 4,096 more, plus a 12 KiB mask shared by all samplers.
 */
#ifndef DPC_DPC_SAMPLER_H
#define DPC_DPC_SAMPLER_H

#include "dpc.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct dpc_sampler dpc_sampler;

#define DPC_SAMPLER_MAX_SPP (1u << 16)
#define DPC_SAMPLER_MAX_DIMENSIONS 4096u

typedef struct dpc_sampler_options {
    uint32_t struct_size; /* sizeof(dpc_sampler_options), set by dpc_sampler_options_init */
    /* Point models the tables come from: no grid axes, dims >= 2 each. A model of n dims fills
     * n / 2 consecutive slots from one set (its dimensions 0-1, 2-3, ...; each slot keeps its
     * pair's 2-D structure, structure across pairs only for progressive models); the models are
     * used in turn, starting over after the last, until D slots are filled. */
    const dpc_model *const *models;
    uint32_t n_models;          /* >= 1 */
    uint32_t samples_per_pixel; /* spp: points per table, 1 .. DPC_SAMPLER_MAX_SPP (default 16) */
    uint32_t dimensions;        /* D: tables, 1 .. DPC_SAMPLER_MAX_DIMENSIONS (default 16); spp * D <= 2^24 */
    /* Dimensions d >= fold_from return their value v folded by the baker's (tent) transform
     * 1 - |2v - 1| (on the 2^-24 grid: 2v below 1/2, 2(1 - v) - 2^-24 from 1/2 on, a bijection
     * of the grid, so values stay uniform), which makes every continuous integrand periodic over
     * the table. Net slots are never folded. Default DPC_SAMPLER_NO_FOLD (none: a renderer that
     * importance-samples turns smooth integrands into edges, which the fold doubles); 1 for all
     * but the film position, 0 for all set slots. */
    uint32_t fold_from;
    /* Slots t < net_dims hold (0,m,2)-nets instead of the models' sets when spp = 2^m >= 2 (see
     * "Net slots" above). Default DPC_SAMPLER_NET_DIMS_AUTO: every slot for set models (so at
     * every power-of-two spp from DPC_SAMPLER_AUTO_NETS_SPP on; the sets serve 1 spp and the
     * other counts), 1 for progressive models (dimension 0, the film position); 0 for none. */
    uint32_t net_dims;
    uint64_t seed; /* default 0 */
    /* NULL (default): none. Called with done / total = sets made / sets to make (the tables'
     * point sets), after each batch of sets and with the same `done` inside each set's work (a
     * poll), so a nonzero return stops creation promptly with DPC_ERROR_CANCELLED. Calls never
     * overlap but may come from libdpc's worker threads (see dpc_progress_fn). Added after
     * `seed`: a struct_size of offsetof(dpc_sampler_options, progress) is still accepted, as
     * none. */
    dpc_progress_fn progress;
    void *user; /* passed to progress */
    /* How net slots are randomised across pixels. DPC_SAMPLER_NETS_PER_PIXEL: one optimised net
     * per slot, digitally shifted per pixel (errors white across pixels). DPC_SAMPLER_NETS_SCREEN:
     * a 32 x 32 tile of pixels shares one Owen-scrambled 2-D Sobol' sequence, each pixel the block
     * at its randomised Morton code, so each pixel's samples are a net and neighbouring pixels'
     * together a finer one (errors blue across pixels). Default DPC_SAMPLER_NETS_AUTO: screen
     * below DPC_SAMPLER_SCREEN_NETS_BELOW spp, per pixel from there on. Added after `user`: older
     * struct sizes are still accepted, as the default. */
    uint32_t net_layout;
    /* F: frames of samples_per_pixel samples each that a pixel's samples span (see "Frames"
     * above): 1 (default; 0 reads as 1) for one image of spp samples; 2 .. DPC_SAMPLER_MAX_SPP /
     * spp for real-time use, where frame f takes sample indices f * spp .. f * spp + spp - 1.
     * Needs net_dims 0 or DPC_SAMPLER_NET_DIMS_AUTO (resolved to 0), and spp * F * D <= 2^24.
     * Added after `net_layout` in its padding: older callers' zeroed structs read as 1. */
    uint32_t frames;
} dpc_sampler_options;

#define DPC_SAMPLER_NETS_PER_PIXEL 0u
#define DPC_SAMPLER_NETS_SCREEN 1u
#define DPC_SAMPLER_NETS_AUTO 0xFFFFFFFFu
#define DPC_SAMPLER_SCREEN_NETS_BELOW 64u

#define DPC_SAMPLER_NO_FOLD 0xFFFFFFFFu
/* options.net_dims: every slot from DPC_SAMPLER_AUTO_NETS_SPP samples per pixel on (set
 * models; 2, so every power of two that has a net), else 1 (dimension 0). */
#define DPC_SAMPLER_NET_DIMS_AUTO 0xFFFFFFFFu
#define DPC_SAMPLER_AUTO_NETS_SPP 2u

/* Fill *options with the defaults (no models: set models and n_models). */
DPC_API void dpc_sampler_options_init(dpc_sampler_options *options);

/* Build a sampler: the tables' point sets through the models' cascades, on the CPU backend with
 * up to 16 sets at once on the first model's threads. On failure *out_sampler is NULL. */
DPC_API dpc_status dpc_sampler_create(const dpc_sampler_options *options, dpc_sampler **out_sampler);
/* Release a sampler. NULL is a no-op. */
DPC_API void dpc_sampler_free(dpc_sampler *sampler);

/* One value in [0, 1) for pixel (x, y), sample index, dimension. */
DPC_API dpc_status dpc_sampler_get_1d(const dpc_sampler *sampler, uint32_t x, uint32_t y, uint32_t index,
                                      uint32_t dimension, float *out);
/* Two values in [0, 1): out[0], out[1]. */
DPC_API dpc_status dpc_sampler_get_2d(const dpc_sampler *sampler, uint32_t x, uint32_t y, uint32_t index,
                                      uint32_t dimension, float *out);

/* What a created sampler is, its options resolved as libdpc applies them. */
typedef struct dpc_sampler_info {
    /* The caller sets it to sizeof(dpc_sampler_info) before the call (else
     * DPC_ERROR_INVALID_ARGUMENT); libdpc fills the rest. */
    uint32_t struct_size;
    uint32_t samples_per_pixel; /* spp */
    uint32_t dimensions;        /* D */
    uint32_t fold_from;         /* dimensions >= fold_from are folded (DPC_SAMPLER_NO_FOLD: none) */
    /* N: slots t < N hold nets (options.net_dims resolved: DPC_SAMPLER_NET_DIMS_AUTO applied,
     * at most D, 0 when spp is not a power of two >= 2) */
    uint32_t net_slots;
    uint32_t progressive; /* 1: progressive models, tables read in order; 0: set models */
    uint64_t seed;
    /* options.net_layout resolved (DPC_SAMPLER_NETS_PER_PIXEL or _SCREEN; PER_PIXEL when there
     * are no net slots). Added after `seed`: a struct_size of offsetof(dpc_sampler_info,
     * net_layout) is still accepted and leaves it out. */
    uint32_t net_layout;
    uint32_t frames; /* F (options.frames, 0 resolved to 1); tables hold spp * F points */
} dpc_sampler_info;

/* Fill *out_info (its struct_size set by the caller, see above). */
DPC_API dpc_status dpc_sampler_get_info(const dpc_sampler *sampler, dpc_sampler_info *out_info);

/* The sampler's tables: table t (0 <= t < D) is spp * F points of 2 floats, row-major (a net slot's
 * table holds its per-pixel net's cell centres, which screen-ordered lookups do not read); *out_table stays valid while the sampler lives. For
 * inspection and for reimplementing lookups elsewhere (e.g. on a GPU) from docs/rendering.md. */
DPC_API dpc_status dpc_sampler_table(const dpc_sampler *sampler, uint32_t t, const float **out_table);
/* The 32 x 32 screen-space mask shared by all samplers: 3072 floats, pixel (x, y) at
 * (y * 32 + x) * 3: its 2-D shift, then its 1-D offset. Static storage. */
DPC_API const float *dpc_sampler_mask(void);

#ifdef __cplusplus
}
#endif

#endif /* DPC_DPC_SAMPLER_H */
