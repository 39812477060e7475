"""Can a better mask make the sampler's error blue at 4 spp? A synthetic study, no renderer.

    python -m lab.rendering.mask_study            # about 10 minutes on one core

The sampler shifts one n-point table per dimension pair by a per-pixel mask vector
(docs/rendering.md). Its shipped mask is optimised for 1 spp, where a pixel's error is the
integrand at the mask value. At n spp the error is e(s) = mean_i f(T_i + s) - I, a function of
the shift s with only high frequencies, and the 1-spp mask does not cancel it across pixels.
This study measures, on random toroidal half-plane integrands (the kind the mask optimiser uses)
over a 64 x 64 screen, the error image's low-frequency energy (mean power at
0 < |q| <= 3/16 cycles per pixel over the mean at all q != 0, white noise = 1: bench_rendering's
measure) and the per-pixel MSE, for:
- the shipped mask at n = 1, 2, 4, 8, 16 spp (bnot-2d-stratified tables, stratified projections);
- a mask optimised for 4 spp by the same swap optimiser (lab/rendering/make_sampler_mask.py)
  with the test errors of 4-point tables drawn from the model;
- 2 x 2 blocks of a 64 x 64 mask optimised for 1 spp: pixel p's 4 samples are the 4 values of its
  block (no table), the screen-space ordering of Ahmed and Wonka 2020 in its simplest form;
- a per-pixel choice among 16 tables of 4 points (in the spirit of Heitz et al. 2019, who choose
  per pixel among scramblings of one sequence): the same optimiser swaps (shift, table) pairs
  between pixels, the shipped mask's shifts paired with tables 0 .. 15 in turn;
- white-noise shifts;
- Z-ordered pieces of one sequence (Ahmed and Wonka 2020; pbrt-v4's ZSobol sampler): pixel p's n
  samples are points z(p) n .. z(p) n + n - 1 of one scrambled 2-D Sobol' sequence (scipy's, LMS
  and digital shift, which keep it a (0,2)-sequence), z(p) the pixel's Morton index with each
  base-4 digit permuted by a random permutation chosen per prefix: every pixel gets a (0,m,2)-net
  and every aligned 2^k x 2^k block of pixels a larger one, so neighbours fill each other's gaps
  at every sample count (no table and no mask).
Writes the section `mask_study` of docs/reports/rendering-studies.md.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import time

import numpy as np
from scipy.stats import qmc

import dpc
from lab.common import REPORTS, replace_section
from lab.rendering import make_sampler_mask as M  # the shipped mask's optimiser
from lab.rendering.bench_rendering import low_band_energy  # the renderer bench's measure, the same band

DOC = REPORTS / "rendering-studies.md"

TILE = 32
SCREEN = 64
SEEDS = 48
MODEL = "bnot-2d-stratified"


def table(n: int, seed: int) -> np.ndarray:
    """The sampler's own table of n points (its first slot, the model's set: no net) for that seed."""
    return dpc.Sampler(MODEL, samples_per_pixel=n, dimensions=1, seed=seed, net_dims=0).table(0).astype(np.float64)


def half_planes(rng: np.random.Generator, k: int):
    return rng.random(k) * 2 * np.pi, rng.random((k, 2))


def half_plane(points: np.ndarray, angle: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """(k, ...) indicator of k toroidal half-planes (integral 1/2) at points (..., 2)."""
    shape = (-1,) + (1,) * (points.ndim - 1)
    d = points[None] - origin.reshape(shape + (2,))
    d -= np.rint(d)
    a = angle.reshape(shape)
    return (np.cos(a) * d[..., 0] + np.sin(a) * d[..., 1] > 0).astype(np.float64)


def screen_shifted(mask: np.ndarray, n: int, rng: np.random.Generator, s: int) -> np.ndarray:
    """(SCREEN, SCREEN, n, 2) sample points: the table of seed s shifted by each pixel's mask
    vector, the mask at a random tile offset, plus a random global rotation (as the sampler)."""
    t = table(n, 10_000 + s)
    ox, oy = rng.integers(0, TILE, 2)
    c = rng.random(2)
    yy, xx = np.mgrid[0:SCREEN, 0:SCREEN]
    shift = (mask[(yy + oy) % TILE, (xx + ox) % TILE] + c) % 1.0
    return (t[None, None] + shift[:, :, None, :]) % 1.0


def screen_blocks(mask: np.ndarray, b: int, rng: np.random.Generator) -> np.ndarray:
    """Pixel p's b*b samples: the values of its b x b block of a (b * TILE)-wide mask."""
    size = mask.shape[0]
    ox, oy = rng.integers(0, size, 2)
    c = rng.random(2)
    yy, xx = np.mgrid[0 : SCREEN * b, 0 : SCREEN * b]
    v = (mask[(yy + oy) % size, (xx + ox) % size] + c) % 1.0
    return v.reshape(SCREEN, b, SCREEN, b, 2).transpose(0, 2, 1, 3, 4).reshape(SCREEN, SCREEN, b * b, 2)


def morton_ordered(rng: np.random.Generator) -> np.ndarray:
    """(SCREEN, SCREEN) distinct indices: each pixel's Morton index, its base-4 digits from the
    top permuted by a random permutation of 4 per prefix (ZSobol's randomised Z order)."""
    perms = np.array(list(itertools.permutations(range(4))))
    yy, xx = np.mgrid[0:SCREEN, 0:SCREEN]
    levels = SCREEN.bit_length() - 1
    code = np.zeros_like(xx)
    for b in range(levels):
        code |= ((xx >> b) & 1) << (2 * b) | ((yy >> b) & 1) << (2 * b + 1)
    out = np.zeros_like(code)
    for k in range(levels - 1, -1, -1):
        prefix, digit = code >> (2 * k + 2), (code >> (2 * k)) & 3
        out |= perms[rng.integers(0, len(perms), 4 ** (levels - 1 - k))[prefix], digit] << (2 * k)
    return out


def screen_zordered(n: int, rng: np.random.Generator) -> np.ndarray:
    """Pixel p's n samples: points z(p) n .. z(p) n + n - 1 of one scrambled Sobol' sequence."""
    seq = qmc.Sobol(2, scramble=True, seed=rng).random(SCREEN * SCREEN * n).reshape(SCREEN * SCREEN, n, 2)
    return seq[morton_ordered(rng)]


def measure(make) -> tuple[float, float]:
    rng = np.random.default_rng(123)
    lows, mses = [], []
    for s in range(SEEDS):
        pts = make(rng, s)
        angle, origin = half_planes(rng, 1)
        e = half_plane(pts, angle, origin)[0].mean(-1) - 0.5
        lows.append(low_band_energy(e))
        mses.append(float((e**2).mean()))
    return float(np.mean(lows)), float(np.mean(mses))


def optimise_for_tables(values: np.ndarray, n: int) -> np.ndarray:
    """make_sampler_mask's swap optimiser, its test errors those of n-point tables (one drawn
    from the model per test integrand) shifted by each candidate value."""
    rng = np.random.default_rng(0)
    angle, origin = half_planes(rng, M.TESTS)
    tables = [table(n, s) for s in range(64)]
    e = np.empty((M.TESTS, len(values)))
    for k in range(M.TESTS):
        pts = (tables[k % len(tables)][None] + values[:, None, :]) % 1.0
        e[k] = half_plane(pts, angle[k : k + 1], origin[k : k + 1])[0].mean(-1) - 0.5
    with optimiser(N=TILE, ITERATIONS=3000, BATCH=256, test_errors=lambda v, r: e):
        return M.assign_shifts(values, log=None)


POOL = 16  # tables a pixel chooses among


@functools.cache
def pool_tables(n: int) -> np.ndarray:
    """(POOL, n, 2): the tables a pixel chooses among."""
    return np.stack([table(n, s) for s in range(POOL)])


def optimise_pool(values: np.ndarray, n: int) -> np.ndarray:
    """The swap optimiser over (shift, table) pairs: value i carries table i mod POOL, so a swap
    moves a shift and its table together. Returns (TILE, TILE) indices into values."""
    rng = np.random.default_rng(0)
    angle, origin = half_planes(rng, M.TESTS)
    tables = pool_tables(n)
    e = np.empty((M.TESTS, len(values)))
    for t in range(POOL):
        idx = np.arange(t, len(values), POOL)
        for k in range(M.TESTS):
            pts = (tables[t][None] + values[idx][:, None, :]) % 1.0
            e[k, idx] = half_plane(pts, angle[k : k + 1], origin[k : k + 1])[0].mean(-1) - 0.5
    with optimiser(N=TILE, ITERATIONS=3000, BATCH=256, test_errors=lambda v, r: e):
        placed = M.assign_shifts(values, log=None).reshape(-1, 2)
    where = {tuple(v): i for i, v in enumerate(values)}
    return np.array([where[tuple(v)] for v in placed]).reshape(TILE, TILE)


def screen_pool(values: np.ndarray, chosen: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Pixel p's samples: table chosen[p] mod POOL shifted by values[chosen[p]] (the mask at a
    random tile offset, plus a random global rotation, as the sampler)."""
    tables = pool_tables(n)
    ox, oy = rng.integers(0, TILE, 2)
    c = rng.random(2)
    yy, xx = np.mgrid[0:SCREEN, 0:SCREEN]
    i = chosen[(yy + oy) % TILE, (xx + ox) % TILE]
    return (tables[i % POOL] + ((values[i] + c) % 1.0)[:, :, None, :]) % 1.0


def optimise_wide(size: int) -> np.ndarray:
    """A size x size mask for 1 spp by the shipped optimiser (values: a bnot-2d-stratified set)."""
    values = dpc.load(MODEL, isa="scalar").generate(seed=7, n_points=size * size).astype(np.float64)
    with optimiser(N=size, ITERATIONS=1200, BATCH=1024):
        return M.assign_shifts(values, log=None)


@contextlib.contextmanager
def optimiser(**settings):
    """make_sampler_mask with other module settings (it reads them as globals), restored after."""
    saved = {k: getattr(M, k) for k in settings}
    vars(M).update(settings)
    try:
        yield
    finally:
        vars(M).update(saved)


def main() -> None:
    t0 = time.time()
    shipped = dpc.Sampler.mask()[:, :, :2].astype(np.float64)
    white = np.random.default_rng(5).random((TILE, TILE, 2))
    rows = []

    def row(name, n, make):
        low, mse = measure(make)
        rows.append(f"| {name} | {n} | {low:.3f} | {mse:.2e} |")
        print(rows[-1], f"({time.time() - t0:.0f} s)", flush=True)

    for n in (1, 2, 4, 8, 16):
        row("shipped mask (optimised for 1 spp)", n, lambda r, s, n=n: screen_shifted(shipped, n, r, s))
    for n in (1, 4):
        row("white-noise shifts", n, lambda r, s, n=n: screen_shifted(white, n, r, s))
    for n in (1, 4, 16):
        row("Z-ordered pieces of one Sobol' sequence (ZSobol; no table)", n, lambda r, s, n=n: screen_zordered(n, r))
    opt4 = optimise_for_tables(shipped.reshape(-1, 2), 4)
    for n in (1, 4, 8):
        row("mask optimised for 4-spp tables", n, lambda r, s, n=n: screen_shifted(opt4, n, r, s))
    flat = shipped.reshape(-1, 2)
    chosen = optimise_pool(flat, 4)
    row(f"per-pixel choice among {POOL} tables (optimised for 4 spp)", 4, lambda r, s: screen_pool(flat, chosen, 4, r))
    wide = optimise_wide(2 * TILE)
    row("2 x 2 blocks of a 64 x 64 mask for 1 spp (no table)", 4, lambda r, s: screen_blocks(wide, 2, r))
    body = "\n".join(
        [
            f"Measured by `python -m lab.rendering.mask_study` ({SEEDS} screens of {SCREEN} x {SCREEN} "
            "pixels, one random toroidal half-plane integrand each, tables from bnot-2d-stratified; "
            f"{time.time() - t0:.0f} s):",
            "",
            "| per-pixel samples | spp | low-frequency error energy (white = 1) | per-pixel MSE |",
            "|---|---:|---:|---:|",
            *rows,
        ]
    )
    replace_section(DOC, "mask_study", body)
    print(f"wrote {DOC} (mask_study)")


if __name__ == "__main__":
    main()
