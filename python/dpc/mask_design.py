"""Threshold masks designed by simulated annealing of their spectra (docs/masks.md, "Annealed masks").

    >>> from dpc import mask_design
    >>> m = mask_design.anneal_mask(64, seed=0)               # (64, 64), about 15 s on one core
    >>> st = mask_design.anneal_mask(32, frames=16, seed=0)   # (16, 32, 32), blue in space and time
    >>> v = mask_design.anneal_mask(64, seed=0, channels=2)   # (64, 64, 2), blue per channel and jointly

The paper's cascades are "not the best fit" for masks, and it expects specialised optimisers to
do better (Leimkühler et al. 2019, Sec. 7); dpc's gridded mask models indeed stay far above
void-and-cluster (docs/masks.md). This is that specialised optimiser. It starts from
void-and-cluster masks (one per frame or channel) and swaps pairs of ranks within a frame (or
channel) under a Metropolis rule on the energy

    E = mean over frames [λ_m Σ_q w(q) P_mask(q) + Σ_L Σ_q w(q) P_L(q) / #levels] / Σ_q w(q)
        + λ_t mean over pixels Σ_L Σ_k w_t(k) P_pixel,L(k) / (#levels Σ_k w_t(k))
        + λ_j Σ_ab Σ_q w(q) P_ab(q) / (#boxes Σ_q w(q)),

every P normalised so that white noise scores 1 at every frequency: P_mask the rank-normalised
mask's power, P_L that of its thresholded pattern [mask < L] at the 63 levels L = 1/64 … 63/64;
for spatiotemporal masks P_pixel,L, that of a pixel's sequence [value_t < L] − L along time, k = 0
included (each pixel should fall below each level its share of the frames); for 2-value masks
P_ab, that of the box pattern [u < a][v < b], a, b = 1/8 … 7/8. w(q) = exp(−|q|²/2σ_q²) with
σ_q = 6·N/64 cycles per tile (a spatial Gaussian of about 1.7 pixels, near void-and-cluster's
1.5); w_t(k) = exp(−k²/2σ_t²), σ_t = T/8, with k = 0 weighted 2 like each ±k pair. Half the proposed swaps pair
a random pixel with one at most 8 pixels away, half with the pixel of a nearby rank (± N²/64);
the temperature falls geometrically from 0.003 to 0.0001 of the mean energy increase of random
swaps, over 600 proposals per pixel. The inner loop is C++ (dpc._mask_anneal): a step costs
O(frequencies), because pattern spectra are kept as prefix sums over levels.

Cost: O(N⁴) (N² pixels × 600 proposals × O(N²) frequencies): about 15 s for 64 × 64 on one core,
4 minutes at 128 × 128 (`python models/mask_report.py cost` prints the times). The bundled masks
(``dpc.masks.mask("annealed", ...)`` at the sizes and seeds in :data:`BUNDLED`) are this
function's output, so they load instantly.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import baselines as _bl
from .errors import InvalidArgumentError

SIGMA_Q_AT_64 = 6.0  # Gaussian frequency weight, cycles per tile at N = 64 (scales with N)
MASK_WEIGHT = 0.5  # λ_m: the rank-normalised mask's own spectrum against the levels'
TIME_WEIGHT = 2.0  # λ_t: each pixel's values along time against the frames' spectra
TIME_SIGMA = 0.125  # σ_t of the temporal weight, as a fraction of the frame count
TIME_DC_WEIGHT = 2.0  # extra weight of k = 0 (a pixel's share of frames below each level)
JOINT_WEIGHT = 0.1  # λ_j: a vector mask's joint box patterns against its channels' spectra
JOINT_LEVELS = 8  # box corners (a, b), a, b = k / JOINT_LEVELS, k = 1 … JOINT_LEVELS − 1
LEVELS = 64  # thresholds L = k / LEVELS, k = 1 … LEVELS − 1
MAX_STATE_BYTES = 8 << 30  # the annealer's spectra (prefix sums) must fit in this
STEPS_PER_PIXEL = 600
REACH = 8  # pixels, for the spatial half of the proposals
T_START, T_END = 0.003, 0.0001
# Bundled designs: (size, frames or None, channels or None) -> seeds, stored as uint16 ranks in
# dpc/data/masks (made by `python models/make_annealed_masks.py`).
BUNDLED = {
    (64, None, None): range(8),
    (128, None, None): range(2),
    (64, 16, None): range(2),
    (64, None, 2): range(8),
}
DATA_DIR = Path(__file__).resolve().parent / "data" / "masks"


def bundled_path(size: int, frames: int | None, seed: int, channels: int | None = None) -> Path:
    shape = f"{size}x{size}" if frames is None else f"{frames}x{size}x{size}"
    if channels is not None:
        shape += f"x{channels}"
    return DATA_DIR / f"annealed-{shape}-seed{seed}.npy"


def _frequencies(n: int, sigma_q: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Half-plane integer frequencies (one of each ±q pair) with a weight above e^-8."""
    f = np.arange(-(n // 2) + 1, n // 2 + 1)
    qy, qx = (a.ravel() for a in np.meshgrid(f, f, indexing="ij"))
    r = np.hypot(qx, qy)
    keep = ((qy > 0) | ((qy == 0) & (qx > 0))) & (r <= 4.0 * sigma_q)
    return qx[keep].astype(np.int32), qy[keep].astype(np.int32), np.exp(-0.5 * (r[keep] / sigma_q) ** 2)


def energy_terms(n: int, frames: int, joint: bool = False) -> dict:
    """The arrays dpc._mask_anneal.anneal takes, for an n × n mask of ``frames`` frames (with
    ``joint``: the two channels of a vector mask, and the joint term)."""
    s = n * n
    qx, qy, w = _frequencies(n, SIGMA_Q_AT_64 * n / 64.0)
    var_rank = (s * s - 1) / 12.0  # ranks 0 … S−1: white noise has E|DFT|² = S · var at q ≠ 0
    spatial = 1.0 / (w.sum() * frames)
    levels = np.arange(1, LEVELS) / LEVELS
    thresholds = np.round(levels * s).astype(np.int32)
    if np.any(np.diff(thresholds) <= 0):
        raise InvalidArgumentError(f"a {n} x {n} mask is too small for {LEVELS} threshold levels")
    kappa = spatial / (s * levels * (1 - levels) * len(levels))
    w_time, kappa_time = np.zeros(0), np.zeros(0)
    if frames > 1 and not joint:
        k = np.arange(frames // 2 + 1)
        w_time = np.exp(-0.5 * (k / (TIME_SIGMA * frames)) ** 2)
        twice = (k > 0) & (2 * k != frames)  # the half spectrum stands for k and T - k
        w_time[twice] *= 2.0
        w_time[0] *= TIME_DC_WEIGHT
        # white noise: E|C(k)|^2 = T L (1 - L) for each pixel, level and k (k = 0 included)
        kappa_time = TIME_WEIGHT / (w_time.sum() * s * frames * levels * (1 - levels) * len(levels))
    joint_thresholds, joint_kappa, w_joint = np.zeros(0, np.int32), np.zeros((0, 0)), np.zeros(0)
    if joint:
        corners = np.arange(1, JOINT_LEVELS) / JOINT_LEVELS
        joint_thresholds = np.round(corners * s).astype(np.int32)
        share = np.outer(corners, corners)  # white noise: E|D(q)|^2 = S ab (1 - ab)
        joint_kappa = JOINT_WEIGHT / (w.sum() * s * share * (1 - share) * share.size)
        w_joint = w
    return {
        "joint_thresholds": joint_thresholds,
        "joint_kappa": joint_kappa,
        "w_joint": w_joint,
        "qx": qx,
        "qy": qy,
        "w_mask": MASK_WEIGHT * spatial * w / (s * var_rank),
        "w_level": w[None, :],
        "thresholds": thresholds,
        "kappa": kappa[None, :],
        "w_time": w_time,
        "kappa_time": kappa_time,
    }


def anneal_mask(
    size: int,
    frames: int | None = None,
    seed: int = 0,
    steps_per_pixel: int = STEPS_PER_PIXEL,
    channels: int | None = None,
) -> np.ndarray:
    """A rank-normalised (size, size) mask; (frames, size, size) when ``frames`` is given;
    (size, size, 2) for ``channels=2`` (blue per channel and in the joint box patterns).
    Designed as the module doc says; deterministic for a given seed on a given machine."""
    from . import _mask_anneal

    n = _bl._check_mask_size(size, "size", 8)
    t = 1 if frames is None else _bl._check_mask_size(frames, "frames", 1)
    s = _bl._check_seed(seed)
    if channels not in (None, 1, 2):
        raise InvalidArgumentError(f"channels must be 1 or 2, got {channels!r}")
    joint = channels == 2
    if joint and frames is not None:
        raise InvalidArgumentError("give channels or frames, not both")
    if joint:
        t = 2
    steps = _bl._check_mask_size(steps_per_pixel, "steps_per_pixel", 0) if steps_per_pixel else 0
    terms = energy_terms(n, t, joint)
    state = 16 * LEVELS * (t * len(terms["qx"]) + n * n * len(terms["w_time"]))  # complex float64
    if state > MAX_STATE_BYTES:
        raise InvalidArgumentError(
            f"a {n} x {n} x {t} design needs {state / 2**30:.1f} GiB of spectra (limit "
            f"{MAX_STATE_BYTES / 2**30:.0f} GiB): use fewer frames or a smaller size"
        )
    start = [_bl.void_and_cluster(n, s + 1_000_003 * k) for k in range(t)]
    ranks = np.rint(np.stack(start) * (n * n) - 0.5)  # void-and-cluster's values are (rank + ½)/S
    out, _accepted, _e0, _e1 = _mask_anneal.anneal(
        ranks.astype(np.int32),
        steps=steps * n * n * t,
        reach=REACH,
        rank_reach=max(1, n * n // 64),
        t_start=T_START,
        t_end=T_END,
        seed=s,
        **terms,
    )
    values = (out.astype(np.float64) + 0.5) / (n * n)
    if joint:
        return np.moveaxis(values, 0, -1)
    return values[0] if frames is None else values


def mask(size: int = 64, frames: int | None = None, seed: int = 0, channels: int | None = None) -> np.ndarray:
    """The bundled design for (size, frames, seed, channels) when there is one, else
    :func:`anneal_mask`."""
    channels = None if channels == 1 else channels
    if seed in BUNDLED.get((size, frames, channels), ()):
        ranks = np.load(bundled_path(size, frames, seed, channels))
        return (ranks.astype(np.float64) + 0.5) / (size * size)
    return anneal_mask(size, frames, seed, channels=channels)
