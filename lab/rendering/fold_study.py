"""What folding (the baker's transform) does to a pixel's estimate. A synthetic study, no renderer.

    python -m lab.rendering.fold_study            # about a minute

A sampler pixel estimates the integral of f over [0,1)^2 with its table shifted toroidally
(docs/rendering.md). Folded dimensions (fold_from) return fold(v) = 1 - |2v - 1| of each value
instead. Net slots (net_dims, the default for dimension 0 at power-of-two counts) are measured
too: a blue-noise (0,m,2)-net, digitally shifted, unfolded, and the same values put through
the fold (which the sampler never applies to a net slot: this column is why). For three kinds of integrand on the
unit square, none of them periodic, this measures the per-pixel mean squared error of the
sampler's 2-D values (one pixel, the sampler's seed varied) with and without folding, next to
PMJ02BN (dpc.baselines.pmj02 with 10 candidates) and Owen-scrambled Sobol' (scipy.stats.qmc),
the sequences renderers use for such integrands:
- smooth lobes: Gaussians exp(-|p - c|^2 / 2w^2), c uniform in the square, w in 0.1 .. 0.4
  (a light's falloff, a BSDF lobe);
- half-planes through the square (an occluder's edge);
- lobe x half-plane: a Gaussian lobe times a half-plane through the square (a penumbra pixel;
  in a soft-shadow scene most pixels see no edge).
Writes the section `fold_study` of docs/reports/rendering-studies.md.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.stats import qmc

import dpc
from dpc import baselines
from lab.common import REPORTS, replace_section

DOC = REPORTS / "rendering-studies.md"
MODEL = "bnot-2d-stratified"
SEEDS = 64
COUNTS = (4, 16, 64, 256)
K = 48  # integrands of each kind
GRID = 1000  # midpoint rule for the exact integrals


def integrands(rng: np.random.Generator):
    """Each kind: a function (..., 2) -> (K, ...) of K random integrands."""
    c, w = rng.uniform(0, 1, (K, 2)), rng.uniform(0.1, 0.4, K)
    angle, origin = rng.uniform(0, 2 * np.pi, K), rng.uniform(0.2, 0.8, (K, 2))
    c2, w2 = rng.uniform(0, 1, (K, 2)), rng.uniform(0.1, 0.4, K)
    angle2, origin2 = rng.uniform(0, 2 * np.pi, K), rng.uniform(0.2, 0.8, (K, 2))

    def shape(p):
        return (-1,) + (1,) * (p.ndim - 1)

    def lobe(p, c, w):
        s = shape(p)
        return np.exp(-((p[None] - c.reshape(s + (2,))) ** 2).sum(-1) / (2 * w.reshape(s) ** 2))

    def edge(p, angle, origin):
        s = shape(p)
        d = p[None] - origin.reshape(s + (2,))
        a = angle.reshape(s)
        return (np.cos(a) * d[..., 0] + np.sin(a) * d[..., 1] > 0).astype(np.float64)

    return {
        "smooth lobes": lambda p: lobe(p, c, w),
        "half-planes": lambda p: edge(p, angle, origin),
        "lobe x half-plane": lambda p: lobe(p, c2, w2) * edge(p, angle2, origin2),
    }


def tent(v: np.ndarray) -> np.ndarray:
    """The baker's transform as the sampler's fold (docs/rendering.md, "Definition"), applied to
    values the sampler does not fold: what folding would do to a net slot (it never folds one)."""
    v = v.astype(np.float32)
    hi = np.float32(2) * (np.float32(1) - v) - np.float32(2.0**-24)
    return np.where(v < 0.5, np.float32(2) * v, hi).astype(np.float64)


def point_sets(n: int, seeds: int) -> dict[str, np.ndarray]:
    """(seeds, n, 2) point sets of each sampler compared here, seed s for realisation s: one pixel
    of dpc.Sampler (dimension 0: the shifted set unfolded and folded, and the net slot, also with the
    fold applied), PMJ02BN
    and Owen-scrambled Sobol'."""

    def pixel(seed, fold_from, net_dims):
        s = dpc.Sampler(MODEL, samples_per_pixel=n, dimensions=1, seed=seed, fold_from=fold_from, net_dims=net_dims)
        return s.get_2d(0, 0, np.arange(n), 0).astype(np.float64)

    net = np.stack([pixel(s, None, 1) for s in range(seeds)])
    return {
        "dpc set": np.stack([pixel(s, None, 0) for s in range(seeds)]),
        "dpc set, folded": np.stack([pixel(s, 0, 0) for s in range(seeds)]),
        "dpc net": net,
        "dpc net, folded": tent(net),
        "PMJ02BN": np.stack([baselines.pmj02(n, np.random.default_rng(s), candidates=10) for s in range(seeds)]),
        "Sobol' (Owen)": np.stack([qmc.Sobol(2, scramble=True, seed=s).random(n) for s in range(seeds)]),
    }


def main() -> None:
    t0 = time.time()
    kinds = integrands(np.random.default_rng(7))
    g = (np.arange(GRID) + 0.5) / GRID
    grid = np.stack(np.meshgrid(g, g), -1)
    exact = {name: f(grid).mean(axis=(1, 2)) for name, f in kinds.items()}

    results = {}  # (kind, sampler) -> [mse per count]
    for n in COUNTS:
        for sampler, pts in point_sets(n, SEEDS).items():
            for name, f in kinds.items():
                est = f(pts).mean(-1)  # (K, SEEDS)
                mse = float(((est - exact[name][:, None]) ** 2).mean())
                results.setdefault((name, sampler), []).append(mse)
        print(f"n = {n} done ({time.time() - t0:.0f} s)", flush=True)
    samplers = ["dpc set", "dpc set, folded", "dpc net", "dpc net, folded", "PMJ02BN", "Sobol' (Owen)"]
    lines = [
        f"Measured by `python -m lab.rendering.fold_study` (one pixel of `dpc.Sampler` with {MODEL}, "
        f"{SEEDS} seeds, {K} random integrands of each kind; mean squared error of the pixel's estimate; "
        f"{time.time() - t0:.0f} s):",
        "",
    ]
    for name in kinds:
        lines += [
            f"**{name}**",
            "",
            "| spp | " + " | ".join(samplers) + " | set: folded / unfolded |",
            "|---:|" + "---:|" * (len(samplers) + 1),
        ]
        for i, n in enumerate(COUNTS):
            v = [results[(name, s)][i] for s in samplers]
            lines.append(f"| {n} | " + " | ".join(f"{x:.2e}" for x in v) + f" | {v[1] / v[0]:.2f} |")
        lines.append("")
    body = "\n".join(lines).rstrip()
    print(body)
    replace_section(DOC, "fold_study", body)
    print(f"wrote {DOC} (fold_study)")


if __name__ == "__main__":
    main()
