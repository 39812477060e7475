"""Quality of threshold masks: scalar (N, N), vector (N, N, C) and spatiotemporal (T, N, N).

Conventions (docs/masks.md): power is normalised so that a white-noise mask scores 1 at every
frequency; "low band" is 0 < |q| ≤ q_max (q_max = 6 cycles per tile by default, as in
:func:`dpc.analysis.dither.mask_quality`, whose scalar numbers these reuse).

* scalar: the rank-normalised mask's low-band power (``mask_elow``) and that of the binary patterns
  it gives for constant greys 1/8 … 7/8 (mean ``levels_elow_mean`` and worst
  ``levels_elow_max``).
* vector: the scalar numbers of each channel, and joint patterns: the pixels whose value pair
  (u, v) lies in the box [0, a) × [0, b) for a, b ∈ {1/4, 1/2, 3/4}, normalised by p(1 − p) with p
  their fraction (``joint_elow_mean`` / ``joint_elow_max``). Two independent blue-noise channels
  are blue one by one but not jointly: such a box pattern is the product of two unrelated blue
  patterns, whose low band is far above either's.
* spatiotemporal: the scalar numbers of every frame (mean over frames, and the worst frame);
  per pixel, the power spectrum of its T values along time, |DFT_t(v − ½)|² / (T/12), averaged
  over pixels (``temporal_spectrum``; ``temporal_elow``: mean over 0 < k ≤ T/4); and the error of
  temporally accumulated one-sample estimates: pixel p after n frames estimates ∫ f by
  (1/n) Σ_{t<n} f(v_t(p)), for the step integrands f_c(u) = [u < c], c = 1/16 … 15/16, and the
  RMS error over pixels and c is reported for n = 1 … T (``accumulated_rmse``), as well as the
  low-band power of the error image after n frames (is the remaining error blue in space?).
* tiling: :func:`seam_ratio` compares Hann-windowed low-band power of the thresholded patterns
  in a window centred on the tile corner (where copies of the tile meet) with a window centred
  inside the tile. A toroidal mask gives ≈ 1; a mask whose opposite edges do not fit gives more.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidArgumentError
from .dither import LEVELS, _low_band, mask_quality, rank_normalise

BOX_LEVELS = (0.25, 0.5, 0.75)
STEP_LEVELS = tuple(k / 16 for k in range(1, 16))


def _as_stack(masks, ndim: int, what: str) -> np.ndarray:
    a = np.asarray(masks, dtype=np.float64)
    if a.ndim == ndim:
        a = a[None]
    if a.ndim != ndim + 1:
        raise InvalidArgumentError(f"{what}: expected {ndim}-D mask(s), got shape {np.shape(masks)}")
    if not np.all(np.isfinite(a)):
        raise InvalidArgumentError(f"{what}: the mask has non-finite values")
    return a


def scalar_quality(masks, q_max: float = 6.0, levels=LEVELS) -> dict:
    """:func:`dpc.analysis.dither.mask_quality` of (count, N, N) masks or one (N, N) mask."""
    return mask_quality(masks, q_max=q_max, levels=levels)


def _pattern_elow(b: np.ndarray, low: np.ndarray) -> float:
    """Low-band power of binary patterns (count, N, N), each normalised by p(1 − p)."""
    n2 = b.shape[1] * b.shape[2]
    p = b.mean(axis=(1, 2), keepdims=True)
    var = np.maximum(p * (1 - p), 1.0 / n2)
    pw = np.abs(np.fft.fft2(b - p)) ** 2 / (n2 * var)
    return float(pw[:, low].mean())


def vector_quality(masks, q_max: float = 6.0, box_levels=BOX_LEVELS) -> dict:
    """Quality of (count, N, N, C) or one (N, N, C) vector mask (C ≥ 2): per-channel scalar
    numbers and joint box patterns of channels 0 and 1 (see the module doc)."""
    ms = _as_stack(masks, 3, "vector_quality")
    if ms.shape[1] != ms.shape[2] or ms.shape[1] < 4 or ms.shape[3] < 2:
        raise InvalidArgumentError(f"vector masks must be (count, N, N, C), N >= 4, C >= 2; got {np.shape(masks)}")
    n, c = ms.shape[1], ms.shape[3]
    r = np.stack([np.stack([rank_normalise(m[..., k]) for k in range(c)], axis=-1) for m in ms])
    per = [mask_quality(r[..., k], q_max=q_max) for k in range(c)]
    low = _low_band(n, q_max)
    joint = {}
    for a in box_levels:
        for b in box_levels:
            pat = ((r[..., 0] < a) & (r[..., 1] < b)).astype(np.float64)
            joint[f"{a:g},{b:g}"] = _pattern_elow(pat, low)
    vals = list(joint.values())
    return {
        "channels": per,
        "mask_elow_max": max(p["mask_elow"] for p in per),
        "levels_elow_mean_max": max(p["levels_elow_mean"] for p in per),
        "levels_elow_max": max(p["levels_elow_max"] for p in per),
        "joint_elow": joint,
        "joint_elow_mean": float(np.mean(vals)),
        "joint_elow_max": float(np.max(vals)),
    }


def temporal_spectrum(volume) -> np.ndarray:
    """Mean over pixels of |DFT_t(v − ½)|² / (T/12) at k = 0 … T−1 for a (T, N, N) volume of
    values in [0, 1] (white noise: 1 at every k ≠ 0)."""
    v = _as_stack(volume, 3, "temporal_spectrum")
    t = v.shape[1]
    p = np.abs(np.fft.fft(v - 0.5, axis=1)) ** 2 / (t / 12.0)
    return p.mean(axis=(0, 2, 3))


def accumulated_error(volume, steps=STEP_LEVELS, q_max: float = 6.0) -> dict:
    """Errors of accumulated 1-spp estimates over frames (see the module doc): for n = 1 … T,
    the RMS error over pixels and step integrands, and the low-band power of the error image
    (normalised so that independent white-noise values score 1)."""
    v = _as_stack(volume, 3, "accumulated_error")
    t, n = v.shape[1], v.shape[2]
    low = _low_band(n, q_max)
    rmse, elow = [], []
    cs = np.asarray(steps, dtype=np.float64)
    for k in range(1, t + 1):
        err2, lows = [], []
        for c in cs:
            est = (v[:, :k] < c).mean(axis=1)  # (cnt, N, N)
            e = est - c
            err2.append(float((e**2).mean()))
            # white noise: var of the estimate = c(1 − c)/k per pixel, independent pixels
            var_white = c * (1 - c) / k
            pw = np.abs(np.fft.fft2(e - e.mean(axis=(1, 2), keepdims=True))) ** 2 / (n * n * var_white)
            lows.append(float(pw[:, low].mean()))
        rmse.append(float(np.sqrt(np.mean(err2))))
        elow.append(float(np.mean(lows)))
    return {"frames": list(range(1, t + 1)), "rmse": rmse, "error_elow": elow}


def spatiotemporal_quality(volumes, q_max: float = 6.0) -> dict:
    """Quality of (count, T, N, N) or one (T, N, N) spatiotemporal mask (see the module doc)."""
    vs = _as_stack(volumes, 3, "spatiotemporal_quality")
    if vs.shape[2] != vs.shape[3] or vs.shape[2] < 4 or vs.shape[1] < 2:
        raise InvalidArgumentError(
            f"spatiotemporal masks must be (count, T, N, N), T >= 2, N >= 4; got {np.shape(volumes)}"
        )
    t = vs.shape[1]
    r = np.stack([np.stack([rank_normalise(f) for f in vol]) for vol in vs])
    frames = [mask_quality(r[:, k], q_max=q_max) for k in range(t)]
    ts = temporal_spectrum(r)
    kmax = max(1, t // 4)
    acc = accumulated_error(r)
    return {
        "frames": t,
        "mask_elow_mean": float(np.mean([f["mask_elow"] for f in frames])),
        "mask_elow_max": float(np.max([f["mask_elow"] for f in frames])),
        "levels_elow_mean": float(np.mean([f["levels_elow_mean"] for f in frames])),
        "levels_elow_max": float(np.max([f["levels_elow_max"] for f in frames])),
        "temporal_spectrum": [float(x) for x in ts],
        "temporal_elow": float(ts[1 : kmax + 1].mean()),
        "accumulated_rmse": acc["rmse"],
        "accumulated_error_elow": acc["error_elow"],
    }


def seam_ratio(masks, q_max: float = 6.0, levels=LEVELS) -> float:
    """Windowed low-band power of the thresholded patterns across the tile corner divided by the
    same inside the tile (mean over masks and levels). ≈ 1 for a mask that tiles seamlessly."""
    ms = _as_stack(masks, 2, "seam_ratio")
    n = ms.shape[1]
    if ms.shape[1] != ms.shape[2] or n < 8:
        raise InvalidArgumentError(f"masks must be (count, N, N), N >= 8, got {np.shape(masks)}")
    w = np.hanning(n + 2)[1:-1]
    win = np.outer(w, w)
    low = _low_band(n, q_max)
    norm = (win**2).sum()

    def band(m: np.ndarray) -> float:
        out = []
        for lv in levels:
            b = (m < lv).astype(np.float64) - lv
            out.append((np.abs(np.fft.fft2(b * win)) ** 2)[low].mean() / (norm * lv * (1 - lv)))
        return float(np.mean(out))

    inside = np.mean([band(rank_normalise(m)) for m in ms])
    across = np.mean([band(np.roll(rank_normalise(m), (n // 2, n // 2), axis=(0, 1))) for m in ms])
    return float(across / inside)
