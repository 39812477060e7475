"""Threshold masks designed by simulated annealing of their spectra (docs/masks.md, "Annealed masks").

    >>> from dpc.masks import design
    >>> m = design.anneal_mask(64, seed=0)               # (64, 64), about 11 s on one core
    >>> st = design.anneal_mask(32, frames=16, seed=0)   # (16, 32, 32), blue in space and time
    >>> v = design.anneal_mask(64, seed=0, channels=2)   # (64, 64, 2), blue per channel and jointly

The paper's cascades are "not the best fit" for masks, and it expects specialised optimisers to
do better (Leimkühler et al. 2019, Sec. 7); dpc's gridded mask models indeed stay far above
void-and-cluster (docs/masks.md). This is that specialised optimiser, libdpc's
``dpc_mask_design`` (libdpc/src/mask/mask_design.c), so C programs make the same masks. It
starts from void-and-cluster masks (one per frame or channel) and swaps pairs of ranks within a
frame (or channel) under a Metropolis rule on the energy

    E = mean over frames [λ_m Σ_q w(q) P_mask(q) + Σ_L Σ_q w(q) P_L(q) / #levels] / Σ_q w(q)
        + λ_t mean over pixels Σ_L Σ_k w_t(k) P_pixel,L(k) / (#levels Σ_k w_t(k))
        + λ_j Σ_ab Σ_q w(q) P_ab(q) / (#boxes Σ_q w(q)),

every P normalised so that white noise scores 1 at every frequency: P_mask the rank-normalised
mask's power, P_L that of its thresholded pattern [mask < L] at the 63 levels L = 1/64 … 63/64;
for spatiotemporal masks P_pixel,L, that of a pixel's sequence [value_t < L] − L along time, k = 0
included (each pixel should fall below each level its share of the frames); for 2-value masks
P_ab, that of the box pattern [u < a][v < b], a, b = 1/8 … 7/8. w(q) = exp(−|q|²/2σ_q²) over the
half plane of integer frequencies with |q| ≤ 4σ_q, σ_q = 6·N/64 cycles per tile (a spatial
Gaussian of about 1.7 pixels, near void-and-cluster's 1.5); w_t(k) = exp(−k²/2σ_t²),
σ_t = T/8, with k = 0 weighted 2 like each ±k pair. λ_m = 0.5, λ_t = 2, λ_j = 0.1. Half the
proposed swaps pair a random pixel with one at most 8 pixels away, half with the pixel of a
nearby rank (± N²/64); the temperature falls geometrically from 0.003 to 0.0001 of the mean
energy increase of random swaps, over 600 proposals per pixel. A step costs O(frequencies),
because pattern spectra are kept as prefix sums over levels. Everything is plain double
arithmetic in a fixed order with libdpc's own exp, sin and cos, so a design is the same bits on
every machine.

Cost: O(N⁴) (N² pixels × 600 proposals × O(N²) frequencies): about 11 s for 64 × 64 on one core,
3 minutes at 128 × 128 (`python models/mask_report.py cost` prints the times). The bundled masks
(``dpc.masks.mask("annealed", ...)`` at the sizes and seeds in :data:`BUNDLED`) are this
function's output, so they load instantly.
"""

from __future__ import annotations

import queue
import threading
from pathlib import Path

import numpy as np

from .. import _args, _core
from ..errors import InvalidArgumentError, LimitError
from .baselines import check_pixels, pixel_limit

STEPS_PER_PIXEL = _core.MASK_STEPS_PER_PIXEL  # libdpc's default (dpc_mask_options_init): 600
#: Largest steps_per_pixel anneal_mask takes (100 times the default: hours at 64 x 64).
MAX_STEPS_PER_PIXEL = 100 * STEPS_PER_PIXEL
# Bundled designs: (size, frames or None, channels or None) -> seeds, stored as uint16 ranks in
# dpc/data/masks (made by `python models/make_annealed_masks.py`).
BUNDLED = {
    (64, None, None): range(8),
    (128, None, None): range(2),
    (64, 16, None): range(2),
    (64, None, 2): range(8),
}
DATA_DIR = Path(__file__).resolve().parents[1] / "data" / "masks"


def bundled_path(size: int, frames: int | None, seed: int, channels: int | None = None) -> Path:
    shape = f"{size}x{size}" if frames is None else f"{frames}x{size}x{size}"
    if channels is not None:
        shape += f"x{channels}"
    return DATA_DIR / f"annealed-{shape}-seed{seed}.npy"


def anneal_mask(
    size: int,
    frames: int | None = None,
    seed: int = 0,
    steps_per_pixel: int = STEPS_PER_PIXEL,
    channels: int | None = None,
    progress=None,
    max_pixels: int | None = None,
) -> np.ndarray:
    """A rank-normalised (size, size) mask; (frames, size, size) when ``frames`` is given;
    (size, size, 2) for ``channels=2`` (blue per channel and in the joint box patterns).
    Designed by libdpc as the module doc says: the same values for a seed on every machine.
    ``progress(done, total)`` is called on this thread about every 65,536 swap proposals; an
    exception it raises stops the design and propagates. The design runs on a worker thread
    while this one waits, so Ctrl-C raises KeyboardInterrupt at once (the worker stops at its
    next progress poll). ``max_pixels``: the largest frames × size² × channels (default 65,536
    or $DPC_MAX_DESIGN_PIXELS, see :func:`dpc.masks.mask`), and ``steps_per_pixel`` at most
    :data:`MAX_STEPS_PER_PIXEL`; both checked before any work (LimitError)."""
    n = _args.size(size, "size", 8)
    t = 1 if frames is None else _args.size(frames, "frames", 1)
    s = _args.integer(seed, "seed", 0, _args.SEED_MAX, whole_floats=True)  # libdpc's uint64
    if channels not in (None, 1, 2):
        raise InvalidArgumentError(f"channels must be 1 or 2, got {channels!r}")
    c = 2 if channels == 2 else 1
    if c == 2 and frames is not None:
        raise InvalidArgumentError("give channels or frames, not both")
    steps = _args.size(steps_per_pixel, "steps_per_pixel", 0) if steps_per_pixel else 0
    if steps > MAX_STEPS_PER_PIXEL:
        raise LimitError(f"steps_per_pixel must be at most {MAX_STEPS_PER_PIXEL:,}, got {steps:,}")
    what = f"annealed {n} x {n}" + (f", {t} frames" if frames is not None else "") + (", 2 channels" if c > 1 else "")
    check_pixels(t * n * n * c, what, max_pixels, design=True)
    ranks, _stats = _run_cancellable(lambda poll: _core.mask_design(n, t, c, steps, s, poll), progress)
    values = (ranks.astype(np.float64) + 0.5) / (n * n)  # ranks: (frames, n, n, channels) uint32
    if c == 2:
        return values[0]
    return values[0, ..., 0] if frames is None else values[..., 0]


class _Stop(Exception):
    """Raised inside libdpc's progress poll to stop the design (never leaves this module)."""


def _run_cancellable(call, progress=None):
    """``call(poll)`` on a worker thread, ``poll(done, total)`` being libdpc's progress callback;
    this thread waits in short sleeps, so Python handles Ctrl-C (only the main thread sees
    signals) and ``progress`` runs here. On KeyboardInterrupt, or an exception from
    ``progress``, the poll stops libdpc at its next call and the exception propagates at once."""
    reports: queue.SimpleQueue = queue.SimpleQueue()
    state = {"result": None, "error": None}
    stop, done = threading.Event(), threading.Event()

    def poll(count, total):
        if stop.is_set():
            raise _Stop
        reports.put((count, total))

    def work():
        try:
            state["result"] = call(poll)
        except BaseException as e:  # noqa: BLE001 - handed to the waiting thread
            state["error"] = e
        finally:
            done.set()

    def forward():
        while progress is not None and not reports.empty():
            progress(*reports.get())

    # Not a daemon: the interpreter waits for it at exit (it stops at libdpc's next poll), so
    # no thread is inside libdpc while Python shuts down.
    worker = threading.Thread(target=work, name="dpc-mask-design")
    worker.start()
    try:
        # Event.wait, not Thread.join: a Ctrl-C inside join(timeout) can leave the thread marked
        # as finished while it runs (Python 3.11), and the interpreter would then exit without
        # waiting for it.
        while not done.wait(0.05):
            forward()
        forward()
    except BaseException:
        stop.set()  # the worker stops at libdpc's next poll; the exception goes on at once
        raise
    if state["error"] is not None:
        raise state["error"]
    return state["result"]


def mask(
    size: int = 64,
    frames: int | None = None,
    seed: int = 0,
    channels: int | None = None,
    progress=None,
    max_pixels: int | None = None,
) -> np.ndarray:
    """The bundled design for (size, frames, seed, channels) when there is one, else
    :func:`anneal_mask` (``progress``, ``max_pixels`` as there)."""
    channels = None if channels == 1 else channels
    pixel_limit(max_pixels, design=True)  # a bad max_pixels is said even for a bundled mask
    try:
        bundled = seed in BUNDLED.get((size, frames, channels), ())
    except TypeError:  # an unhashable argument: anneal_mask says what is wrong with it
        bundled = False
    if bundled:
        ranks = np.load(bundled_path(size, frames, seed, channels))
        return (ranks.astype(np.float64) + 0.5) / (size * size)
    return anneal_mask(size, frames, seed, channels=channels, progress=progress, max_pixels=max_pixels)
