"""Threshold-mask baselines, to compare with dpc's masks (docs/masks.md): void-and-cluster
(Ulichney 1993), its vector and spatiotemporal (STBN, after Wolfe et al. 2022) variants, white
noise and the Bayer matrix; and the pixel limits every mask and image function checks. Also
reachable as ``dpc.baselines.<name>``, beside the point-set baselines."""

from __future__ import annotations

import math
import os

import numpy as np

from .. import _args
from ..errors import InvalidArgumentError, LimitError


def _rng(seed: int) -> np.random.Generator:
    return np.random.default_rng(int(seed))


# Masks (threshold maps) for dithering and real-time rendering, to compare with dpc's gridded
# mask models (docs/masks.md). A mask is float64 with values (rank + ½) / size, each value exactly
# once: scalar (N, N); vector (N, N, 2); spatiotemporal (T, N, N) (slice t = frame t).
# Every mask here is toroidal (it tiles without a seam): the energies below wrap around.


# Limits checked before any work (LimitError names the limit and how to raise it). Every mask
# or image function takes ``max_pixels=``: None means the environment variable, else the default.
#: Largest mask or image, in pixels (frames x size^2 x channels): 8192 x 8192, 512 MiB as
#: float64; DPC_MAX_PIXELS raises it.
DEFAULT_MAX_PIXELS = 1 << 26
#: Largest mask made by a design whose time grows with the square of its pixels
#: (void-and-cluster, stbn, annealed): 256 x 256 (void-and-cluster: about a minute);
#: DPC_MAX_DESIGN_PIXELS raises it.
DEFAULT_MAX_DESIGN_PIXELS = 1 << 16


def pixel_limit(max_pixels=None, design: bool = False) -> int:
    """The pixel limit of one call: ``max_pixels`` (``math.inf``: none), else
    $DPC_MAX_DESIGN_PIXELS (``design``) or $DPC_MAX_PIXELS, else the default above."""
    env = "DPC_MAX_DESIGN_PIXELS" if design else "DPC_MAX_PIXELS"
    if max_pixels is None:
        text = os.environ.get(env, "").strip()
        if not text:
            return DEFAULT_MAX_DESIGN_PIXELS if design else DEFAULT_MAX_PIXELS
        try:
            return _args.size(float(text), env, 1)
        except ValueError:
            raise InvalidArgumentError(f"{env} must be a pixel count >= 1, got {text!r}") from None
    if max_pixels == math.inf:
        return max_pixels  # no limit
    return _args.size(max_pixels, "max_pixels", 1)


def check_pixels(pixels: int, what: str, max_pixels=None, design: bool = False) -> None:
    """LimitError when ``what`` (``pixels`` pixels) is over the pixel limit (see pixel_limit)."""
    limit = pixel_limit(max_pixels, design)
    if pixels > limit:
        env = "DPC_MAX_DESIGN_PIXELS" if design else "DPC_MAX_PIXELS"
        why = " for a design whose time grows with the square of its pixels" if design else ""
        raise LimitError(
            f"{what} has {pixels:,} pixels, over the limit of {limit:,}{why}; raise it with "
            f"max_pixels= (dpc mask, dpc dither: --max-pixels) or the environment variable {env}"
        )


def _ranks_to_mask(ranks: np.ndarray) -> np.ndarray:
    return (ranks.astype(np.float64) + 0.5) / ranks.size


def _gaussian_1d_torus(n: int, sigma: float) -> np.ndarray:
    """exp(−d²/2σ²) at toroidal offsets d = 0 … n−1 (every periodic image summed)."""
    d = np.arange(n, dtype=np.float64)
    images = np.arange(-3, 4)[:, None] * n
    return np.exp(-((d[None, :] + images) ** 2) / (2.0 * sigma * sigma)).sum(axis=0)


class _ToroidalEnergy:
    """Ulichney's filtered binary pattern on a 2-D torus: E = b ⊛ G with the Gaussian
    G(dx, dy) = exp(−(dx² + dy²)/2σ²) (all periodic images). Toggling one pixel adds or removes
    the kernel rolled to that pixel: O(N²) per toggle, via a view into a 2 × 2 tiled kernel."""

    def __init__(self, pattern: np.ndarray, sigma: float):
        n = pattern.shape[0]
        g = _gaussian_1d_torus(n, sigma)
        self.kernel = np.outer(g, g)
        self.tiled = np.tile(self.kernel, (2, 2))
        self.n = n
        self.b = pattern.astype(bool).copy()
        # Initial energy by FFT (circular convolution), then exact incremental updates.
        self.e = np.real(np.fft.ifft2(np.fft.fft2(self.b.astype(np.float64)) * np.fft.fft2(self.kernel)))

    def toggle(self, flat: int, on: bool) -> None:
        n = self.n
        i, j = divmod(int(flat), n)
        view = self.tiled[n - i : 2 * n - i, n - j : 2 * n - j]  # kernel rolled to (i, j)
        if on:
            self.e += view
        else:
            self.e -= view
        self.b.flat[flat] = on

    def tightest_cluster(self) -> int:
        """The 1-pixel with the highest energy."""
        return int(np.argmax(np.where(self.b, self.e, -np.inf)))

    def largest_void(self) -> int:
        """The 0-pixel with the lowest energy."""
        return int(np.argmin(np.where(self.b, np.inf, self.e)))


def void_and_cluster(
    size: int, seed: int = 0, sigma: float = 1.5, density: float = 0.1, max_pixels: int | None = None
) -> np.ndarray:
    """A size × size blue-noise threshold mask by Ulichney's void-and-cluster method
    (R. Ulichney, "The void-and-cluster method for dither array generation", SPIE 1913, 1993),
    on the torus, so the mask tiles.

    1. Initial binary pattern: ``density`` · size² ones at random pixels (``seed``), relaxed by
       moving the tightest cluster (the 1 with the highest Gaussian-filtered value) into the
       largest void (the 0 with the lowest) until the pixel removed is the one refilled.
    2. Phase 1: from that pattern, remove tightest clusters one by one; ranks ones−1 … 0.
    3. Phase 2: from that pattern, insert into largest voids up to half the pixels.
    4. Phase 3: the remaining pixels, each time the tightest cluster of 0s, i.e. the 0 with the
       highest filtered value of the 0s. That value is (sum of the kernel) − (filtered value of
       the 1s), so it is the 0 with the lowest filtered value of the 1s: the same choice as
       phase 2 (the paper's phase 3 inverts the pattern only to reuse the cluster search).

    Returns float64 (size, size) with values (rank + ½)/size². The filter is the Gaussian
    exp(−r²/2σ²) (σ = 1.5 pixels, as in the paper), evaluated in full on the torus: each step
    costs O(size²), the whole mask O(size⁴) (measured in docs/masks.md: 64 × 64 about 0.4 s,
    128 × 128 a few seconds, 256 × 256 about a minute on one core). ``max_pixels``: the
    largest size² allowed (default DEFAULT_MAX_DESIGN_PIXELS or $DPC_MAX_DESIGN_PIXELS); a larger
    mask raises LimitError before any work."""
    n = _args.size(size)
    s = _args.numpy_seed(seed)
    check_pixels(n * n, f"void-and-cluster {n} x {n}", max_pixels, design=True)
    if not (np.isfinite(sigma) and sigma > 0):
        raise InvalidArgumentError(f"sigma must be positive, got {sigma}")
    if not 0.0 < density < 0.5:
        raise InvalidArgumentError(f"density must be in (0, 0.5), got {density}")
    total = n * n
    ones = min(max(1, int(round(density * total))), total // 2)
    rng = _rng(s)
    init = np.zeros(total, dtype=bool)
    init[rng.choice(total, size=ones, replace=False)] = True
    en = _ToroidalEnergy(init.reshape(n, n), sigma)
    # Initial binary pattern: swap tightest cluster -> largest void until stable.
    for _ in range(50 * total):
        c = en.tightest_cluster()
        en.toggle(c, False)
        v = en.largest_void()
        en.toggle(v, True)
        if v == c:
            break
    prototype_b, prototype_e = en.b.copy(), en.e.copy()
    ranks = np.empty(total, dtype=np.int64)
    # Phase 1.
    for rank in range(ones - 1, -1, -1):
        c = en.tightest_cluster()
        en.toggle(c, False)
        ranks[c] = rank
    # Phases 2 and 3.
    en.b, en.e = prototype_b, prototype_e
    for rank in range(ones, total):
        v = en.largest_void()
        en.toggle(v, True)
        ranks[v] = rank
    return _ranks_to_mask(ranks.reshape(n, n))


def white_mask(shape, seed: int = 0, max_pixels: int | None = None) -> np.ndarray:
    """A white-noise mask: uniform random values, rank-normalised. ``shape`` (N, N) is a scalar
    mask; (N, N, C) a vector mask, each of its C channels ranked on its own. ``max_pixels``:
    the largest N²·C allowed (default DEFAULT_MAX_PIXELS or $DPC_MAX_PIXELS; LimitError
    before allocating)."""
    if isinstance(shape, (str, bytes)) or not np.iterable(shape):
        raise InvalidArgumentError(f"white_mask shape must be (N, N) or (N, N, C), got {shape!r}")
    shp = tuple(_args.size(k, "shape entry", 1) for k in shape)
    if len(shp) not in (2, 3):
        raise InvalidArgumentError(f"white_mask shape must be (N, N) or (N, N, C), got {shape}")
    check_pixels(math.prod(shp), f"white mask {' x '.join(map(str, shp))}", max_pixels)
    rng = _rng(_args.numpy_seed(seed))
    return _rank_per_channel(rng.random(shp), vector=len(shp) == 3)


def _rank_per_channel(a: np.ndarray, vector: bool) -> np.ndarray:
    if vector:
        return np.stack([_rank_per_channel(a[..., c], False) for c in range(a.shape[-1])], axis=-1)
    r = np.empty(a.size, dtype=np.int64)
    r[np.argsort(a, axis=None, kind="stable")] = np.arange(a.size)
    return _ranks_to_mask(r.reshape(a.shape))


def bayer_mask(size: int, max_pixels: int | None = None) -> np.ndarray:
    """The size × size Bayer (ordered-dither) matrix, size a power of two, as (rank + ½)/size².
    ``max_pixels``: as for :func:`white_mask`."""
    from ..analysis.dither import bayer

    n = _args.size(size, low=1)
    check_pixels(n * n, f"Bayer mask {n} x {n}", max_pixels)
    return bayer(n)


def vector_void_and_cluster(size: int, seed: int = 0, sigma: float = 1.5, max_pixels: int | None = None) -> np.ndarray:
    """A 2-value (size, size, 2) mask from two independent void-and-cluster masks (seeds
    ``seed`` and ``seed + 1_000_003``): blue in each value, but not jointly — the pixels whose
    value pair falls in a box of the unit square need not form a blue-noise pattern."""
    n = _args.size(size)
    s = _args.numpy_seed(seed)
    check_pixels(2 * n * n, f"vector void-and-cluster {n} x {n} x 2", max_pixels, design=True)
    big = math.inf  # checked above for both masks
    return np.stack(
        [void_and_cluster(n, s, sigma, max_pixels=big), void_and_cluster(n, s + 1_000_003, sigma, max_pixels=big)],
        axis=-1,
    )


def _normalised_gaussian_1d(n: int, sigma: float) -> np.ndarray:
    """Toroidal 1-D Gaussian weights at offsets 0 … n−1 with weight 1 at offset 0 and the other
    offsets scaled to sum to 1 (the kernel normalisation of the STBN reference code)."""
    g = _gaussian_1d_torus(n, sigma)
    if n > 1:
        g[1:] /= g[1:].sum()
    g[0] = 1.0
    return g


def stbn_scalar(
    size: int,
    frames: int,
    seed: int = 0,
    sigma_space: float = 1.9,
    sigma_time: float = 1.9,
    density: float = 0.1,
    max_pixels: int | None = None,
) -> np.ndarray:
    """A (frames, size, size) scalar spatiotemporal blue-noise mask after Wolfe et al.,
    "Spatiotemporal Blue Noise Masks" (EGSR 2022): void-and-cluster over the whole volume with
    the energy of a pixel split into a spatial part (a 2-D Gaussian over the pixels of its own
    frame) and a temporal part (a 1-D Gaussian over the same pixel in the other frames, on the
    torus in time), so every frame is a blue-noise mask and each pixel's values over time are
    blue noise too. σ = 1.9 in space and time; each 1-D Gaussian has weight 1 at offset 0 and the
    other offsets summing to 1 (as in NVIDIA's reference code; the paper does not fix this).
    Cost: O(frames · size²) per step, O((frames · size²)²) in all (64 × 64 × 16: about a
    minute on one core). ``max_pixels``: the largest frames·size² allowed (as for
    :func:`void_and_cluster`; LimitError before any work)."""
    n = _args.size(size)
    t = _args.size(frames, "frames", 1)
    s = _args.numpy_seed(seed)
    check_pixels(t * n * n, f"stbn {n} x {n} x {t} frames", max_pixels, design=True)
    for name, v in (("sigma_space", sigma_space), ("sigma_time", sigma_time)):
        if not (np.isfinite(v) and v > 0):
            raise InvalidArgumentError(f"{name} must be positive, got {v}")
    if not 0.0 < density < 0.5:
        raise InvalidArgumentError(f"density must be in (0, 0.5), got {density}")
    gs = _normalised_gaussian_1d(n, sigma_space)
    space = np.tile(np.outer(gs, gs), (2, 2))  # rolled by slicing
    time = np.tile(_normalised_gaussian_1d(t, sigma_time), 2)
    total = t * n * n
    e = np.zeros((t, n, n))
    b = np.zeros((t, n, n), dtype=bool)

    def toggle(flat: int, on: bool) -> None:
        k, rem = divmod(int(flat), n * n)
        i, j = divmod(rem, n)
        sign = 1.0 if on else -1.0
        e[k] += sign * space[n - i : 2 * n - i, n - j : 2 * n - j]
        col = time[t - k : 2 * t - k].copy()  # g((k' − k) mod frames)
        col[k] = 0.0  # the pixel itself: counted in space
        e[:, i, j] += sign * col
        b.flat[flat] = on

    def cluster() -> int:
        return int(np.argmax(np.where(b, e, -np.inf)))

    def void() -> int:
        return int(np.argmin(np.where(b, np.inf, e)))

    ones = min(max(1, int(round(density * total))), total // 2)
    rng = _rng(s)
    for f in rng.choice(total, size=ones, replace=False):
        toggle(int(f), True)
    for _ in range(50 * total):
        c = cluster()
        toggle(c, False)
        v = void()
        toggle(v, True)
        if v == c:
            break
    proto_b, proto_e = b.copy(), e.copy()
    ranks = np.empty(total, dtype=np.int64)
    for rank in range(ones - 1, -1, -1):
        c = cluster()
        toggle(c, False)
        ranks[c] = rank
    b[...], e[...] = proto_b, proto_e
    for rank in range(ones, total):
        v = void()
        toggle(v, True)
        ranks[v] = rank
    # Ranks over the whole volume; each frame is then ranked on its own (a threshold map per
    # frame), as the volume's ranks are uniform over frames only on average.
    vol = ranks.reshape(t, n, n)
    return np.stack([_rank_per_channel(vol[k], False) for k in range(t)])
