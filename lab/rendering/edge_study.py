"""Edges by slope: why the sampler trails (0,2)-nets on a pixel footprint. A synthetic study.

    python -m lab.rendering.edge_study            # about half a minute

A pixel's footprint integrand is dominated by geometry edges, and in a rendered scene many run
nearly along the pixel axes (walls, a light's rim, a box's sides). For straight edges through
the unit square at a given angle to the x axis (offsets uniform in 0.2 .. 0.8), this measures
the mean squared error of the estimate of the covered area by: one pixel of `dpc.Sampler`
(dimension 0, unfolded) as a net slot (net_dims=1, the default: a blue-noise (0,m,2)-net,
digitally shifted) and as the shifted set (net_dims=0: bnot-2d-stratified with stratified 1-D
projections), PMJ02BN (dpc.baselines.pmj02, 10 candidates) and Owen-scrambled Sobol'
(scipy.stats.qmc), over seeds. (0,2)-nets stratify every elementary interval (2 x n/2,
4 x n/4, ...), dpc's sets only the 1 x n and n x 1 ones and, by being blue noise, roughly the
square ones.
Writes the section `edge_study` of docs/reports/rendering-studies.md.
"""

from __future__ import annotations

import time

import numpy as np

from lab.common import REPORTS, replace_section
from lab.rendering.fold_study import point_sets  # the same pixel, PMJ02BN and Sobol' sets

DOC = REPORTS / "rendering-studies.md"
SEEDS = 256
EDGES = 64
COUNTS = (16, 64)
ANGLES = (0.0, 0.05, 0.2, 0.5, np.pi / 4)
GRID = 800


def main() -> None:
    t0 = time.time()
    rng = np.random.default_rng(3)
    g = (np.arange(GRID) + 0.5) / GRID
    grid = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    samplers = ["dpc net", "dpc set", "PMJ02BN", "Sobol' (Owen)"]
    lines = [
        f"Measured by `python -m lab.rendering.edge_study` ({SEEDS} seeds, {EDGES} edges per angle; mean "
        f"squared error of the covered fraction; {{seconds}} s):",
        "",
        "| spp | edge angle (rad) | " + " | ".join(samplers) + " | net / PMJ02BN | set / PMJ02BN |",
        "|---:|---:|" + "---:|" * (len(samplers) + 2),
    ]
    for n in COUNTS:
        every = point_sets(n, SEEDS)
        sets = [every[name] for name in samplers]
        for angle in ANGLES:
            origin = np.stack([np.full(EDGES, 0.5), rng.uniform(0.2, 0.8, EDGES)], -1)
            normal = np.array([np.sin(angle), np.cos(angle)])
            exact = ((grid[None] - origin[:, None]) @ normal > 0).mean(-1)
            mse = []
            for pts in sets:
                est = ((pts[None] - origin[:, None, None]) @ normal > 0).mean(-1)  # (EDGES, SEEDS)
                mse.append(float(((est - exact[:, None]) ** 2).mean()))
            lines.append(
                f"| {n} | {angle:.2f} | "
                + " | ".join(f"{v:.2e}" for v in mse)
                + f" | {mse[0] / mse[2]:.2f} | {mse[1] / mse[2]:.2f} |"
            )
    body = "\n".join(lines).replace("{seconds}", f"{time.time() - t0:.0f}")
    print(body)
    replace_section(DOC, "edge_study", body)
    print(f"wrote {DOC} (edge_study)")


if __name__ == "__main__":
    main()
