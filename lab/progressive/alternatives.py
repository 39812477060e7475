"""The design study behind progressive dpc (docs/progressive.md, "Design"): prefix quality of
the alternatives measured before progressive-2d was chosen.

    python -m lab.progressive.alternatives            # 16 sets of 1,024 points, prints a table

For each alternative and prefix n = 16 ... 1,024: E_low nu<0.5 of the prefixes over that of a
bnot-2d-stratified set made for n points (the progressive-dpc issue's goal: <= 3), and delta_min.
* reorder: a finished bnot-2d-stratified set, ordered by greedy sample elimination (Yuksel 2015,
  weights (1 - d / 2r)^8 with r the hexagonal-packing radius of the target count): halve the set,
  keep the survivors as the prefix, repeat on them. The full set stays a dpc set; each prefix
  is a subset of it.
* levels: the progressive rule (docs/model-format.md §6: each level's new points filtered past
  the earlier levels' points, which stay in place) with trained set cascades (bnot-2d-stratified
  and bnot-2d, their 40 layers repeated 1 or 4 times) and with Gaussian repulsion kernels (160
  layers, A = 0.3, sigma 0.85, 1.1 (the first progressive-2d), 1.5 mean spacings, radius 3.75
  sigma), and sigma falling from 2.0 to 0.9 or 2.5 to 0.9 over the 160 layers, or from 2.0 to 0.9
  over 320, or with the radius capped at 4.25 spacings over 160 or 200 layers (progressive-2d: from
  2.0 to 0.9 over 160, uncapped). Last column: the anisotropy of the full sets (mean over
  0.5 <= nu <= 4 of the ring's variance over its mean squared, dB; lower is more isotropic), as
  on the model cards.
"""

from __future__ import annotations

import argparse
import heapq
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

import dpc
from dpc.analysis.pcf import min_distance
from dpc.analysis.spectrum import low_frequency_energy, radial_spectrum
from dpc.model_file import ModelSpec, read_model, write_model
from models.make_progressive_2d import PROGRESSIVE, repulsion_layers, schedule_layers


def eliminate(points: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """Yuksel's weighted sample elimination of points down to target: (kept indices, removed
    indices, last removed first)."""
    n = len(points)
    r2 = 2.0 * np.sqrt(1.0 / (2.0 * np.sqrt(3.0) * target))
    pairs = cKDTree(points, boxsize=1.0).query_pairs(r2, output_type="ndarray")
    d = points[pairs[:, 0]] - points[pairs[:, 1]]
    d -= np.round(d)
    w = (1.0 - np.linalg.norm(d, axis=1) / r2) ** 8
    weight = np.zeros(n)
    np.add.at(weight, pairs[:, 0], w)
    np.add.at(weight, pairs[:, 1], w)
    neighbours: list[list[tuple[int, float]]] = [[] for _ in range(n)]
    for (a, b), v in zip(pairs.tolist(), w.tolist()):
        neighbours[a].append((b, v))
        neighbours[b].append((a, v))
    alive = np.ones(n, bool)
    heap = [(-weight[i], i) for i in range(n)]
    heapq.heapify(heap)
    removed = []
    while len(removed) < n - target:
        neg, i = heapq.heappop(heap)
        if not alive[i] or -neg != weight[i]:
            continue  # a stale entry
        alive[i] = False
        removed.append(i)
        for j, v in neighbours[i]:
            if alive[j]:
                weight[j] -= v
                heapq.heappush(heap, (-weight[j], j))
    return np.flatnonzero(alive), np.array(removed[::-1], dtype=np.int64)


def elimination_order(points: np.ndarray) -> np.ndarray:
    idx, tail = np.arange(len(points)), []
    while len(idx) > 1:
        half = 1 << ((len(idx) - 1).bit_length() - 1)
        kept, removed = eliminate(points[idx], half)
        tail.append(idx[removed])
        idx = idx[kept]
    return np.concatenate([idx] + tail[::-1])


def levels_model(layers: list, path: Path, **load) -> dpc.Model:
    """A progressive model of these layers, written to path and loaded on the CPU (``load``: more
    dpc.load options)."""
    write_model(ModelSpec(dims=2, n_points=1024, layers=layers, name=path.stem, metadata=PROGRESSIVE), path)
    return dpc.load(path, backend="cpu", **load)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", type=int, default=16)
    ap.add_argument("--points", type=int, default=1024)
    args = ap.parse_args()
    s, m = args.sets, args.points
    plain = dpc.load("bnot-2d-stratified", backend="cpu")
    full = plain.generate_batch(s, 0, m).astype(np.float64)
    samplers = {"reorder (elimination)": np.stack([p[elimination_order(p)] for p in full])}
    trained = {n: read_model(dpc.model_path(n)).layers for n in ("bnot-2d-stratified", "bnot-2d")}
    variants = {
        "levels, bnot-2d-stratified x1": trained["bnot-2d-stratified"],
        "levels, bnot-2d-stratified x4": trained["bnot-2d-stratified"] * 4,
        "levels, bnot-2d x4": trained["bnot-2d"] * 4,
    }
    for sigma in (0.85, 1.1, 1.5):
        variants[f"levels, repulsion sigma {sigma}"] = repulsion_layers(0.3, sigma, 3.75 * sigma, 160)
    for first, last, layers in ((2.0, 0.9, 160), (2.5, 0.9, 160), (2.0, 0.9, 320)):
        variants[f"levels, sigma {first}-{last}, {layers}"] = schedule_layers(0.3, first, last, 3.75, layers)
    for layers in (160, 200):
        variants[f"levels, sigma 2.0-0.9, rho<=4.25, {layers}"] = schedule_layers(0.3, 2.0, 0.9, 3.75, layers, 4.25)
    with tempfile.TemporaryDirectory() as tmp:
        for i, (name, layers) in enumerate(variants.items()):
            model = levels_model(list(layers), Path(tmp) / f"v{i}.onnx")
            samplers[name] = model.generate_batch(s, 0, m).astype(np.float64)
    ns = [1 << k for k in range(4, m.bit_length()) if 1 << k <= m]
    ref = {n: low_frequency_energy(plain.generate_batch(s, 1000, n).astype(np.float64), 0.5) for n in ns}
    print(f"{s} sets of {m} points: E_low nu<0.5 of each prefix / a dpc set's of that size (delta_min)")
    print(f"{'alternative':40s} " + " ".join(f"{n:>12d}" for n in ns) + "  anisotropy")
    for name, x in samplers.items():
        cells = [
            f"{low_frequency_energy(x[:, :n], 0.5) / ref[n]:6.2f} ({min_distance(x[:, :n]).mean_ratio:.2f})" for n in ns
        ]
        r = radial_spectrum(x, nu_max=4.0)
        band = (r.nu >= 0.5) & (r.nu <= 4.0) & (r.samples > 0)
        print(f"{name:40s} " + " ".join(f"{c:>12s}" for c in cells) + f"  {np.mean(r.anisotropy_db[band]):6.2f} dB")


if __name__ == "__main__":
    main()
