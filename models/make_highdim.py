"""Write the hand-designed projective and high-dimensional models.

Each is a cascade of Gaussian repulsion kernels g(d) = -A exp(-d^2 / (2 sigma^2)) (d, g in mean
spacings of the subspace, table ending at 0 at the radius), run on stratified input points, with
a schedule over depth instead of training:

- projective-3d: four subspace filters in every layer (xy, xz, yz and xyz; the normalised sum
  divides each axis's move by 3). 20 layers of 3-D repulsion spread the points in 3-D; 240 layers
  of all four (projections A = 0.5, sigma = 1.1, radius 4; 3-D A = 0.33, sigma = 1.0, radius 3.5)
  make every projection and the 3-D set blue together; a tail of 80 layers fades the 3-D term out
  (0.2, 0.13, 0.07, 0; projections at A = 0.6), trading a little 3-D quality for the projections.
- projective-4d: the six 2-D projection filters only (A = 0.375 for 240 layers, 0.45 for 40;
  sigma = 1.1, radius 4). Every 4-D term tried made the projections worse (a 4-D phase first and
  a joint phase: projections 0.145 where these give 0.035, 32 sets); the 4-D set stays white.
- blue-10d: 80 layers of 10-D repulsion (A = 0.25, sigma = 0.85, radius 1.5 spacings), for
  m = 8,192. At that m the radius is capped at half the torus (1.5 h = 0.61 > 0.5), so the table
  spans 0 ... 0.5 and the kernel is effectively sigma = 0.70 h; at other point counts the cap
  differs, so the file is for m near 8,192.

The schedules were chosen by development sweeps over 32 sets (these runs are not in the repo);
the numbers measured with the files are in docs/reports/high-dimensions.md (python
lab/models/highdim_report.py). Amplitudes near the ones here are close to instability: projective-3d's
tail at A = 0.75, projective-4d's at A = 0.6 (c = 3) and blue-10d at sigma = 1.0 diverge.

    python models/make_highdim.py                 # writes the three files
    python models/make_highdim.py projective-3d   # one of them
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path

import numpy as np

from dpc.model_file import Layer, ModelSpec, write_model

HERE = Path(__file__).resolve().parent
BINS = 32
STRATIFIED = {"dpc.input": "stratified", "dpc.source": "models/make_highdim.py", "dpc.trained": "no"}


def kernel(amplitude: float, sigma: float, rho: float) -> np.ndarray:
    d = np.linspace(0.0, rho, BINS)
    k = -amplitude * np.exp(-(d**2) / (2 * sigma**2))
    k[-1] = 0.0  # continuous at the radius
    return k


def pairs(dims: int) -> list[int]:
    return [(1 << a) | (1 << b) for a, b in itertools.combinations(range(dims), 2)]


def stages(plan, subspaces: list[int], radius: list[float]) -> list[Layer]:
    """plan: (layers, [(A, sigma) per subspace]) stages, in order."""
    out = []
    for count, params in plan:
        k = np.stack([kernel(a, s, r) for (a, s), r in zip(params, radius)])
        out += [Layer(subspaces=subspaces, radius=radius, kernels=k) for _ in range(count)]
    return out


def projective_3d() -> ModelSpec:
    subs, radius = pairs(3) + [0b111], [4.0, 4.0, 4.0, 3.5]

    def p(a_proj: float, a_full: float, s_full: float = 1.0):
        return [(a_proj, 1.1)] * 3 + [(a_full, s_full)]

    plan = [(20, p(0.0, 0.9, 0.85)), (240, p(0.5, 0.33))] + [(20, p(0.6, a)) for a in (0.2, 0.13, 0.07, 0.0)]
    return ModelSpec(
        dims=3,
        n_points=1024,
        layers=stages(plan, subs, radius),
        name="projective-3d",
        description=(
            "3-D point set blue in its xy, xz and yz projections and in 3-D: 340 layers of Gaussian repulsion "
            "in the three projections and in 3-D on a schedule (models/make_highdim.py), stratified input. "
            "Not trained."
        ),
        metadata=STRATIFIED,
    )


def projective_4d() -> ModelSpec:
    subs = pairs(4)
    plan = [(240, [(0.375, 1.1)] * 6), (40, [(0.45, 1.1)] * 6)]
    return ModelSpec(
        dims=4,
        n_points=1024,
        layers=stages(plan, subs, [4.0] * 6),
        name="projective-4d",
        description=(
            "4-D point set blue in all six 2-D projections: 280 layers of Gaussian repulsion in each "
            "projection (models/make_highdim.py), stratified input; the 4-D set itself is not blue. Not trained."
        ),
        metadata=STRATIFIED,
    )


def blue_10d() -> ModelSpec:
    plan = [(80, [(0.25, 0.85)])]
    return ModelSpec(
        dims=10,
        n_points=8192,
        layers=stages(plan, [(1 << 10) - 1], [1.5]),
        name="blue-10d",
        description=(
            "10-D blue noise at m = 8,192 (frequencies below nu = 0.75 exist from about this m on): 80 layers "
            "of 10-D Gaussian repulsion (models/make_highdim.py), stratified input. Not trained."
        ),
        metadata=STRATIFIED,
    )


MODELS = {"projective-3d": projective_3d, "projective-4d": projective_4d, "blue-10d": blue_10d}

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("names", nargs="*", help="default: all of " + ", ".join(MODELS))
    args = ap.parse_args()
    unknown = [n for n in args.names if n not in MODELS]
    if unknown:
        ap.error(f"unknown: {unknown}; choose from {list(MODELS)}")
    for name in args.names or MODELS:
        out = HERE / f"{name}.onnx"
        write_model(MODELS[name](), out)
        print(f"wrote {out} ({out.stat().st_size:,} bytes)")
