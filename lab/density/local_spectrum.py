"""A local spectrum of density-following point sets: differential domain analysis (Wei and Wang
2011, "Differential domain analysis for non-uniform sampling"), the measure the density study's
CDF-mapped spectrum stands in for. Writes docs/reports/density-local-spectrum.md.

    python -m lab.density.local_spectrum [--quick]

Each point i's differentials to its neighbours are scaled to the uniform spacing by the local
density, d'_ij = (x_j - x_i) sqrt(rho(x_i)) (rho of mean 1), and the radially averaged spectrum is

    P(nu) = 1 + (1/|Q|) sum_{i in Q} sum_j g(|d'_ij|) J0(2 pi nu sqrt(m) |d'_ij|) - m G(nu),

g a Gaussian window of sigma = SIGMA mean spacings (pairs within 3.5 sigma), G its Hankel
transform (the window's own response to a constant density), nu in units of sqrt(m) (the
uniform set's spacing frequency), Q the points farther than the window from the square's sides
and from any density edge (the photograph has queries at 65,536 points only: at 4,096 every
point's window holds an edge). White noise gives about 1 at every nu; E_low is the mean of P over
NU_MIN <= nu < 0.5 (the window resolves little below NU_MIN).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree
from scipy.special import j0

import dpc
from lab.common import report_header
from lab.density import anchors
from lab.density.field import Field, bump, photo, ramp, step

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "reports" / "density-local-spectrum.md"
MODEL = "bnot-2d-stratified"
SIGMA = 3.0  # window, mean spacings
REACH = 3.5  # pairs within REACH * SIGMA
NU_MIN, NU_LOW = 0.1, 0.5
NUS = np.linspace(0.02, 1.5, 75)
MAX_QUERIES = 4096


def local_spectrum(field: Field, p: np.ndarray, m: int) -> tuple[np.ndarray, float]:
    """P(nu) at NUS (see the module's docstring) and the share of the points that are queries."""
    rho = field.rho(p)
    h = 1.0 / np.sqrt(m * rho)  # local mean spacing
    reach = REACH * SIGMA * h
    side = np.minimum(p.min(axis=1), (1.0 - p).min(axis=1))
    q = np.nonzero((side > reach) & (field.edge_distance(p) > reach))[0]
    share = len(q) / len(p)
    if not len(q):
        return np.full(len(NUS), np.nan), share
    if len(q) > MAX_QUERIES:
        q = q[np.linspace(0, len(q) - 1, MAX_QUERIES).astype(np.int64)]
    tree = cKDTree(p)
    sig = SIGMA / np.sqrt(m)  # the window in the uniform-spacing units of d'
    acc = np.zeros(len(NUS))
    for i in q:
        nb = np.asarray(tree.query_ball_point(p[i], reach[i]), dtype=np.int64)
        nb = nb[nb != i]
        r = np.hypot(*(p[nb] - p[i]).T) * np.sqrt(rho[i])
        w = np.exp(-0.5 * (r / sig) ** 2)
        acc += (w[None, :] * j0(2.0 * np.pi * NUS[:, None] * np.sqrt(m) * r[None, :])).sum(axis=1)
    hankel = 2.0 * np.pi * sig**2 * np.exp(-2.0 * np.pi**2 * sig**2 * (NUS * np.sqrt(m)) ** 2)
    return 1.0 + acc / len(q) - m * hankel, share


def e_low(spectrum: np.ndarray) -> float:
    band = (NUS >= NU_MIN) & (NUS < NU_LOW)
    return float(spectrum[band].mean())


def sets_for(model, field: Field, m: int, seeds, lloyd: bool) -> dict[str, list[np.ndarray]]:
    grid = field.float32()
    out: dict[str, list[np.ndarray]] = {"dpc": [], "warp": [], "WSE": [], "dart": [], "white": []}
    if lloyd:
        out["Lloyd"] = []
    for s in seeds:
        rng = np.random.default_rng(1000 + s)
        out["dpc"].append(model.generate_density(grid, m, s).astype(np.float64))
        out["warp"].append(anchors.warp(field, model.generate(s, m).astype(np.float64)))
        out["WSE"].append(anchors.sample_elimination(field, m, rng))
        out["dart"].append(anchors.dart_throwing(field, m, rng)[0])
        out["white"].append(field.sample(m, rng))
        if lloyd:
            out["Lloyd"].append(anchors.lloyd(field, m, rng, max_iter=500)[0])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="4,096 points, one seed, print only")
    args = ap.parse_args()
    t0 = time.time()
    model = dpc.load(MODEL)
    counts = [4096] if args.quick else [4096, 65536]
    seeds = {4096: [0] if args.quick else [0, 1, 2, 3], 65536: [0, 1]}
    flat = Field(np.ones((8, 8)), "uniform")
    rows = []
    for m in counts:
        got = [local_spectrum(flat, model.generate(s, m).astype(np.float64), m) for s in seeds[m]]
        uni = [e_low(sp) for sp, _ in got]
        base = float(np.mean(uni))
        rows.append((m, "uniform set (no density)", "dpc", uni, base, np.mean([sh for _, sh in got])))
        print(m, "uniform", uni, flush=True)
        for field in (ramp(), bump(), step(), photo()):
            sets = sets_for(model, field, m, seeds[m], lloyd=m <= 4096)
            for method, ps in sets.items():
                got = [local_spectrum(field, p, m) for p in ps]
                v = [e_low(sp) for sp, _ in got]
                rows.append((m, field.name, method, v, base, np.mean([sh for _, sh in got])))
                print(m, field.name, method, v, flush=True)
    if args.quick:
        return
    lines = [
        "# Density-following sets: a local spectrum (differential domain analysis)",
        "",
        *report_header("python -m lab.density.local_spectrum"),
        f"What it measures: {__doc__.split('Writes')[0].strip()} "
        f"Here sigma = {SIGMA:g} mean spacings, NU_MIN = {NU_MIN:g}, 4 seeds per cell at 4,096 points and 2 at "
        "65,536 (queries: at most 4,096 per set), "
        f"model {MODEL}; the densities and the anchors are those of [the density study](density.md) "
        "(lab/density/field.py, lab/density/anchors.py; Lloyd at 4,096 points only, up to 500 iterations).",
        "",
        "Queries: the points whose window reaches neither a side nor an edge (a cell whose density differs from "
        "a neighbour's by more than 2x); their share of the points is in the last column (at most 4,096 of them "
        "are used per set; none: not measured).",
        "",
        "E_low (white = 1; the local spectrum's mean over NU_MIN <= nu < 0.5) ± its standard error over the "
        "seeds; an estimate, so near zero it can come out negative. Goal: within 2x the uniform model's own "
        "set of the same m measured the same way; *yes* when the mean less two standard errors is below "
        "twice the uniform set's (at this resolution the two are indistinguishable or the goal is met).",
        "",
        "| m | density | method | E_low | ± | within 2x of the uniform set's | queries |",
        "|---:|---|---|---:|---:|---|---:|",
    ]
    for m, name, method, v, base, share in rows:
        if not share:
            lines.append(f"| {m:,} | {name} | {method} | not measured | | | 0% |")
            continue
        mean, se = float(np.mean(v)), float(np.std(v, ddof=1) / np.sqrt(len(v))) if len(v) > 1 else 0.0
        ok = "yes" if mean - 2.0 * se <= 2.0 * base else "**no**"
        lines.append(f"| {m:,} | {name} | {method} | {mean:.4f} | {se:.4f} | {ok} | {share:.0%} |")
    lines += ["", f"Run time: {(time.time() - t0) / 60:.1f} min.", ""]
    PAGE.write_text("\n".join(lines))
    print(f"wrote {PAGE.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
