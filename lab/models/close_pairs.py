"""Count the sets of a model that keep two points closer than a fraction of the mean spacing.

    python -m lab.models.close_pairs bnot-10d                 # seeds 0 ... 9,999 at m = 1,024
    python -m lab.models.close_pairs bnot-10d --seeds 1000 --below 0.05

A pair closer than eps * h (the filter's cutoff, 1e-4 spacings) is invisible to every later layer,
so a cascade that makes one keeps it (docs/training.md §2, max_attraction). Prints the count, the
seeds and their closest distance in spacings h = m^(-1/n); nearest neighbours on the torus by
scipy's periodic k-d tree.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.spatial import cKDTree

import dpc


def closest_in_spacings(points: np.ndarray) -> float:
    """The smallest toroidal pair distance of one set, over the mean spacing m^(-1/n)."""
    m, n = points.shape
    x = np.mod(points.astype(np.float64), 1.0)
    d, _ = cKDTree(x, boxsize=1.0).query(x, k=2)
    return float(d[:, 1].min() * m ** (1.0 / n))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model", help="bundled name or .onnx file")
    ap.add_argument("--seeds", type=int, default=10_000, help="seeds 0 ... SEEDS - 1 (default 10,000)")
    ap.add_argument("--points", type=int, default=1024)
    ap.add_argument("--below", type=float, default=0.01, help="count pairs closer than this many spacings")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    model = dpc.load(args.model, threads=args.threads)
    start, found = time.perf_counter(), []
    for s0 in range(0, args.seeds, 100):
        sets = model.generate_batch(min(100, args.seeds - s0), seed=s0, n_points=args.points)
        found += [(s0 + i, d) for i, d in enumerate(map(closest_in_spacings, sets)) if d < args.below]
    print(
        f"{args.model}: {len(found)} of {args.seeds:,} sets (m = {args.points:,}) keep a pair closer than "
        f"{args.below} spacings"
        + (": " + ", ".join(f"seed {s} ({d:.1e})" for s, d in found) if found else "")
        + f" [{time.perf_counter() - start:.0f} s]"
    )


if __name__ == "__main__":
    main()
