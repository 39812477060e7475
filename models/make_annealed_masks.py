"""Make the bundled annealed masks (dpc.mask_design.BUNDLED) in python/dpc/data/masks/.

    python models/make_annealed_masks.py            # every bundled design, one process per core
    python models/make_annealed_masks.py --check    # remake them and compare with the files

Each file is one design of dpc.mask_design.anneal_mask (libdpc's dpc_mask_design), stored as its
uint16 ranks (value = (rank + 1/2) / N²). A design is the same bits for a seed on every machine
(float64 in a fixed order, libdpc's own exp, sin and cos, no threads); --check remakes the files
and compares.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from dpc import mask_design

# The source tree's copy (the installed package's is replaced by the next `pip install .`).
DATA_DIR = Path(__file__).resolve().parents[1] / "python" / "dpc" / "data" / "masks"


def design(job: tuple[int, int | None, int | None, int]) -> tuple[tuple, np.ndarray, float]:
    size, frames, channels, seed = job
    t = time.perf_counter()
    values = mask_design.anneal_mask(size, frames, seed, channels=channels)
    ranks = np.rint(values * size * size - 0.5).astype(np.uint16)
    return job, ranks, time.perf_counter() - t


def target(n: int, t: int | None, c: int | None, s: int) -> Path:
    return DATA_DIR / mask_design.bundled_path(n, t, s, c).name


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="compare with the bundled files instead of writing")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--missing", action="store_true", help="make only the designs that have no file yet")
    args = ap.parse_args()
    jobs = [(n, t, c, s) for (n, t, c), seeds in mask_design.BUNDLED.items() for s in seeds]
    if args.missing:
        jobs = [j for j in jobs if not target(*j).exists()]
    jobs.sort(key=lambda j: -(j[0] ** 4) * (j[1] or 1) * (j[2] or 1))  # longest first
    DATA_DIR.mkdir(parents=True, exist_ok=True)
    differ = 0
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for (n, t, c, s), ranks, secs in pool.map(design, jobs):
            path = target(n, t, c, s)
            digest = hashlib.sha256(ranks.tobytes()).hexdigest()[:16]
            if args.check:
                same = path.exists() and np.array_equal(np.load(path), ranks)
                differ += not same
                print(f"{path.name}: {'same' if same else 'DIFFERENT'} ({secs:.0f} s)", flush=True)
            else:
                np.save(path, ranks)
                print(f"{path.name}: {secs:.0f} s, sha256 of the ranks {digest}", flush=True)
    if differ:
        sys.exit(f"{differ} of {len(jobs)} designs differ from the bundled files")


if __name__ == "__main__":
    main()
