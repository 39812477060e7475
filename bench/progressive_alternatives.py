"""The design study behind progressive dpc (docs/progressive.md, "Design"): prefix quality of
the alternatives that were measured before bnot-2d-progressive was trained.

    python bench/progressive_alternatives.py            # 16 sets of 1,024 points, prints a table

* reorder: a finished bnot-2d-stratified set, ordered by greedy sample elimination (Yuksel 2015,
  weights (1 - d / 2r)^8 with r the hexagonal-packing radius of the target count): halve the set,
  keep the survivors as the prefix, repeat on them. The full set stays a dpc set; each prefix
  is a subset of it.
* levels, untrained: bnot-2d-stratified's cascade run level by level with the earlier points held
  in place (docs/model-format.md §6), i.e. the progressive generation rule with a cascade that
  was trained for whole sets.
* levels, trained: bnot-2d-progressive (the same rule, a cascade fine-tuned for it).
Reference: a bnot-2d-stratified set made for each prefix size.
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
from dpc.analysis.spectrum import low_frequency_energy
from dpc.model_file import read_model, write_model


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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", type=int, default=16)
    ap.add_argument("--points", type=int, default=1024)
    args = ap.parse_args()
    s, m = args.sets, args.points
    plain = dpc.load("bnot-2d-stratified", backend="cpu")
    with tempfile.TemporaryDirectory() as tmp:
        spec = read_model(dpc.model_path("bnot-2d-stratified"))
        spec.metadata.update({"dpc.order": "progressive", "dpc.progressive_base": "16"})
        write_model(spec, Path(tmp) / "untrained.onnx")
        untrained = dpc.load(Path(tmp) / "untrained.onnx", backend="cpu").generate_batch(s, 0, m)
    full = plain.generate_batch(s, 0, m).astype(np.float64)
    samplers = {
        "reorder (elimination)": np.stack([p[elimination_order(p)] for p in full]),
        "levels, untrained": untrained.astype(np.float64),
        "levels, trained": dpc.load("bnot-2d-progressive", backend="cpu").generate_batch(s, 0, m).astype(np.float64),
    }
    print(f"{s} sets of {m} points; E_low nu<0.5 (delta_min) of each prefix; white noise: E_low 1")
    print("prefix | dpc set | " + " | ".join(samplers))
    n = 16
    while n <= m:
        ref = plain.generate_batch(s, 1000, n).astype(np.float64)
        cells = [f"{low_frequency_energy(ref, 0.5):.4f} ({min_distance(ref).mean_ratio:.2f})"]
        cells += [
            f"{low_frequency_energy(x[:, :n], 0.5):.4f} ({min_distance(x[:, :n]).mean_ratio:.2f})"
            for x in samplers.values()
        ]
        print(f"{n:6d} | " + " | ".join(cells))
        n *= 2


if __name__ == "__main__":
    main()
