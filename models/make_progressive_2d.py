"""Write models/progressive-2d.onnx: progressive 2-D blue noise (docs/progressive.md).

A hand-designed cascade under the progressive generation rule (dpc.order = "progressive", first
level 16 points, docs/model-format.md §6): 160 layers of a Gaussian repulsion kernel
g(d) = -A exp(-d^2 / (2 sigma^2)) (d, g in mean spacings of the current level; A = 0.3, radius
3.75 sigma), sigma falling geometrically from 2.0 to 0.9 spacings over the layers: wide kernels
first even out the density of the new points over several spacings, narrow ones then settle
each into its hole. Each level's new points are filtered past the earlier levels' points, which
stay in place. Chosen by the sweep of lab/progressive/alternatives.py: the trained set cascades
(bnot-2d-stratified, bnot-2d, repeated 1-8 times) and fine-tuning bnot-2d-stratified on a loss over
the prefixes (training/configs/bnot-2d-progressive-finetune.toml) all left the prefixes more
low-frequency energy than a repulsion, and the falling sigma less than a fixed one (the previous
progressive-2d, sigma = 1.1, is the sweep's row "repulsion sigma 1.1"; docs/progressive.md, "Design").

progressive-2d-balanced is the same cascade with the output balance at radius 8 (dpc.balance,
docs/model-format.md §5.1): each level ends with its own points cancelling the prefix's Fourier
coefficients at 0 < |q| <= min(8, sqrt(n)/4), the held points staying. That removes the
torus-scale power the levels leave (the Gaussian-integrand gap to PMJ02BN) and costs low-band
energy above it: moving only half of the points against the other half leaks power into the
band (docs/progressive.md, "Balanced levels"). Radius 8 is the smallest that keeps every prefix's
Gaussian variance below PMJ02BN's up to 4,096 points in a development sweep on the first,
fixed-sigma cascade (radius 4 missed at 4,096; 16 and 32 cost more low-band energy).

progressive-2d-relaxed is the same cascade followed by the prefix relaxation (dpc.relax = 1600,
docs/model-format.md §6.1): after the levels every point moves at once, 1,600 gradient steps on
the sum over the prefixes of a Gaussian pair energy at each prefix's scale plus a low-frequency
term, so that every prefix and the whole set are as blue as a set made for their size. The first
n points are then no longer the set of n (docs/progressive.md, "Jointly relaxed prefixes").

    python models/make_progressive_2d.py            # writes models/progressive-2d.onnx
    python models/make_progressive_2d.py --balance 8 -o models/progressive-2d-balanced.onnx
    python models/make_progressive_2d.py --relax 1600 -o models/progressive-2d-relaxed.onnx
"""

import argparse
from pathlib import Path

import numpy as np

from dpc.model_file import Layer, ModelSpec, write_model

HERE = Path(__file__).resolve().parent
AMPLITUDE, SIGMA_FIRST, SIGMA_LAST, RHO_PER_SIGMA, BINS, LAYERS, M, BASE = 0.3, 2.0, 0.9, 3.75, 32, 160, 1024, 16


# What makes a cascade progressive (docs/model-format.md §6), with stratified input for each level.
PROGRESSIVE = {"dpc.order": "progressive", "dpc.progressive_base": str(BASE), "dpc.input": "stratified"}


def repulsion_layer(amplitude: float, sigma: float, rho: float) -> Layer:
    d = np.linspace(0.0, rho, BINS)
    kernel = -amplitude * np.exp(-(d**2) / (2 * sigma**2))
    kernel[-1] = 0.0  # continuous at the radius
    return Layer(subspaces=[0b11], radius=[rho], kernels=kernel[None, :].astype(np.float32))


def repulsion_layers(amplitude: float, sigma: float, rho: float, layers: int) -> list[Layer]:
    """One fixed kernel, repeated (the previous progressive-2d: sigma = 1.1, rho = 4.125)."""
    return [repulsion_layer(amplitude, sigma, rho) for _ in range(layers)]


def schedule_layers(
    amplitude: float, first: float, last: float, rho_per_sigma: float, layers: int, rho_max: float = np.inf
) -> list[Layer]:
    """sigma from first to last, geometrically, radius rho_per_sigma * sigma (at most rho_max: an
    alternative of lab/progressive/alternatives.py, not progressive-2d's)."""
    return [repulsion_layer(amplitude, s, min(rho_per_sigma * s, rho_max)) for s in np.geomspace(first, last, layers)]


def progressive_spec(
    amplitude=AMPLITUDE,
    first=SIGMA_FIRST,
    last=SIGMA_LAST,
    layers=LAYERS,
    name="progressive-2d",
    balance=0,
    relax=0,
) -> ModelSpec:
    meta = {**PROGRESSIVE, "dpc.source": "models/make_progressive_2d.py", "dpc.trained": "no"}
    if balance:
        meta.update({"dpc.balance": str(balance), "dpc.source": f"models/make_progressive_2d.py --balance {balance}"})
    if relax:
        meta.update({"dpc.relax": str(relax), "dpc.source": f"models/make_progressive_2d.py --relax {relax}"})
    return ModelSpec(
        dims=2,
        n_points=M,
        layers=schedule_layers(amplitude, first, last, RHO_PER_SIGMA, layers),
        name=name,
        description=(
            (
                "Progressive 2-D blue noise, every prefix of 16 * 2^j points and the whole set relaxed jointly "
                "after the levels (the first n points are not the set of n). "
                if relax
                else "Progressive 2-D blue noise: the first 16 * 2^j points of a set are the set of that size, "
                "each blue noise. "
            )
            + f"{layers} layers of a Gaussian repulsion kernel (A = {amplitude}, sigma from "
            f"{first} to {last} mean spacings, rho = {RHO_PER_SIGMA} sigma) run level by level, the earlier "
            "points held in place. "
            + (
                f"Each level's points then cancel the prefix's power at 0 < |q| <= min({balance}, sqrt(n)/4). "
                if balance
                else ""
            )
            + (f"Then {relax} steps of the prefix relaxation (dpc.relax, format §6.1). " if relax else "")
            + "Not trained."
        ),
        metadata=meta,
    )


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--output", default=None, help="default: models/progressive-2d[-balanced].onnx")
    ap.add_argument("--balance", type=int, default=0, help="output balance radius (dpc.balance; 0: none)")
    ap.add_argument("--relax", type=int, default=0, help="prefix relaxation steps (dpc.relax; 0: none)")
    args = ap.parse_args()
    if args.balance and args.relax:
        ap.error("--balance and --relax exclude each other (the relaxation has its own low-frequency term)")
    name = "progressive-2d-balanced" if args.balance else "progressive-2d-relaxed" if args.relax else "progressive-2d"
    args.output = args.output or str(HERE / f"{name}.onnx")
    write_model(progressive_spec(name=name, balance=args.balance, relax=args.relax), args.output)
    print(f"wrote {args.output} ({Path(args.output).stat().st_size} bytes)")
