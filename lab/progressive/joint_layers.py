"""Learned joint layers: the relaxed rule (docs/model-format.md §6.1, every prefix moving at its own
scale) as a short learned cascade instead of 1,600 gradient steps.

    python -m lab.progressive.joint_layers                 # 300 steps; docs/reports/progressive.md
    python -m lab.progressive.joint_layers --steps 50 --quick   # prints only

After progressive-2d's levels, K layers run on the ordered set; each adds up, over every prefix P
of 16 * 2^j points and the whole set, the filter of P's points at P's scale (scale-aware radius:
P's mean spacing), then moves every point by the sum, as the relaxation's step does with its
Gaussian force. The layers' tables (K = 24 from 6 unique kernels, radius 3 spacings, starting
from a Gaussian repulsion of width 0.85 spacings, amplitude 0.1) are trained on the relaxation's
own energy: per prefix, the potential of its force, s_P^2 G(d) + G(R_P) d^2 / 2 inside its support
R_P (constant beyond), plus the low-frequency term, on batches of 4 progressive-2d sets of 1,024
(dpc_train's filter, libdpc's C kernels, float64, Adam 1e-3 falling to 1e-4). Measured like
lab.progressive.trained_levels: 32 sets of 1,024 from other seeds, each prefix's E_low nu<0.5
over that of bnot-2d-stratified sets of its size, the full set's E_low nu<0.75, delta_min;
progressive-2d (the input), the relaxation itself with 50, 100 and 400 steps
(dpc.stratify.relax_prefixes) and progressive-2d-relaxed (1,600 steps) beside.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import torch

import dpc
from lab.common import cpu_name
from lab.progressive.trained_levels import PREFIXES, SETS, M, publish, quality, references

BATCH = 4
RELAX_STEPS = (50, 100, 400)


def low_frequencies() -> torch.Tensor:
    """The integer q of a half-plane with 0 < |q| <= 8 (format §6.1's low-frequency term)."""
    qs = [(a, b) for a in range(-8, 9) for b in range(9) if b > 0 or a > 0]
    return torch.tensor(qs, dtype=torch.float64)


def relaxed_energy(x: torch.Tensor, sizes: list[int], qs: torch.Tensor) -> torch.Tensor:
    """The energy whose gradient is the relaxation's force, summed over every prefix, per set."""
    m = x.shape[1]
    d = x[:, :, None, :] - x[:, None, :, :]
    d = d - torch.round(d)
    d2 = (d * d).sum(-1)
    total = x.new_zeros(())
    for n in sizes:
        s = (0.85 if n < m else 0.60) / math.sqrt(n)
        support = min(3.5 * s, 0.5)
        cut = math.exp(-(support**2) / (2 * s * s))
        p = d2[:, :n, :n]
        phi = torch.where(
            p < support**2, s * s * torch.exp(-p / (2 * s * s)) + cut * p / 2, s * s * cut + cut * support**2 / 2
        )
        total = total + (phi.sum() - torch.diagonal(phi, dim1=1, dim2=2).sum()) / 2
        q = qs[(qs * qs).sum(1) <= min(8.0, math.sqrt(n) / 4) ** 2]
        if len(q):
            ph = 2 * math.pi * torch.einsum("bnk,qk->bnq", x[:, :n], q)
            power = torch.cos(ph).sum(1) ** 2 + torch.sin(ph).sum(1) ** 2
            total = total + 0.05 * (power / ((q * q).sum(1) * n)).sum() / math.pi
    return total / x.shape[0]


def main() -> None:
    from dpc_train.cascade import Cascade, CascadeSpec, progressive_levels
    from dpc_train.filter import _wrap_points, filter_layer  # the filter's own wrap into [0, 1)

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--quick", action="store_true", help="prints, does not write docs/")
    a = ap.parse_args()
    torch.manual_seed(0)
    torch.set_num_threads(1)
    spec = CascadeSpec(
        dims=2, n_points=M, layers=24, unique_kernels=6, subspaces=["xy"], radius=[3.0],
        init="repulsion", init_sigma=0.85, init_amplitude=0.1,
    )  # fmt: skip
    cascade = Cascade(spec)
    sizes = [s + c for s, c in progressive_levels(M, 16)]
    qs = low_frequencies()
    base = dpc.load("progressive-2d", backend="cpu")

    def joint(x: torch.Tensor, tables: torch.Tensor) -> torch.Tensor:
        for table in tables:
            step = torch.zeros_like(x)
            for n in sizes:
                moved = filter_layer(x[:, :n], table, spec.masks, spec.radius, spec.eps, 0, impl="c") - x[:, :n]
                step[:, :n] += moved - torch.round(moved)  # the toroidal step
            x = _wrap_points(x + step)
        return x

    optimiser = torch.optim.Adam(cascade.parameters(), lr=1e-3)
    rng = np.random.default_rng(0)
    start = time.perf_counter()
    for step in range(a.steps):
        for group in optimiser.param_groups:
            group["lr"] = 1e-3 * 0.1 ** (step / a.steps)
        x = torch.from_numpy(base.generate_batch(BATCH, int(rng.integers(1 << 40)), M).astype(np.float64))
        loss = relaxed_energy(joint(x, cascade.tables().double()), sizes, qs)
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        if step % 50 == 0:
            print(f"step {step}: energy {loss.item():.6f}", flush=True)
    seconds = time.perf_counter() - start

    reference, reference75 = references()
    inputs = base.generate_batch(SETS, 0, M).astype(np.float64)
    with torch.no_grad():
        learned = joint(torch.from_numpy(inputs), cascade.tables().double()).numpy()
    relaxed = dpc.load("progressive-2d-relaxed", backend="cpu").generate_batch(SETS, 0, M).astype(np.float64)
    rows = [("progressive-2d (the input)", inputs), (f"+ 24 learned joint layers (trained {seconds:.0f} s)", learned)]
    for steps in RELAX_STEPS:  # the relaxation itself, shorter (its step size falls over the steps it is given)
        rows.append(
            (
                f"+ the relaxation, {steps} steps",
                np.stack(
                    [
                        dpc.stratify.order_levels(dpc.stratify.relax_prefixes(x.astype(np.float32), steps))
                        for x in inputs
                    ]
                ),
            )
        )
    rows.append(("progressive-2d-relaxed (1,600 steps)", relaxed))
    lines = [
        f"Measured by `python -m lab.progressive.joint_layers --steps {a.steps}` on {cpu_name()}: {SETS} sets of {M:,}"
        " points; each prefix's E_low ν<0.5 over that of bnot-2d-stratified sets of its size, the full set's E_low"
        " ν<0.75 over theirs, δ_min.",
        "",
        "| sets | " + " | ".join(f"{n:,}" for n in PREFIXES) + " | full ν<0.75 | δ_min |",
        "|---" + "|---:" * (len(PREFIXES) + 2) + "|",
    ]
    for name, sets in rows:
        q = quality(sets, reference, reference75)
        ratios = " | ".join(f"{v:.2f}" for v in q["ratios"])
        lines.append(f"| {name} | {ratios} | {q['full75']:.2f} | {q['dmin']:.3f} |")
    publish(lines, "joint_layers", a.quick)


if __name__ == "__main__":
    main()
