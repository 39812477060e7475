#!/usr/bin/env python3
"""Write golden/*.f32: the float64 reference cascade's output for a few (model, seed, count).

    python3 tests/data/make_golden.py          # after make_models.py

The C tests compare libdpc's float32 output with these files (max toroidal difference 1e-5), so
the C suite checks the cascade's absolute correctness without Python. Each file is raw
little-endian float32, row-major (n_points, dims), named MODEL__seedS__nN.f32. The values come
from tests/python/reference_cascade.py (independent of libdpc), rounded to float32.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent

# (model, seed, point count); seed 1 with a count other than the trained 1024 where allowed.
CASES = [
    ("model_2d", 0, 1024),
    ("model_2d", 1, 777),
    ("model_3d_proj", 0, 1024),
    ("model_3d_proj", 1, 1500),
    ("model_3d_mixed", 0, 1024),
    ("model_3d_mixed", 1, 600),
    ("model_grid_3to1", 0, 1024),
    ("model_10d", 0, 1024),
    ("model_10d", 1, 600),
]


def golden_name(model: str, seed: int, n: int) -> str:
    return f"{model}__seed{seed}__n{n}.f32"


def _reference():
    spec = importlib.util.spec_from_file_location(
        "reference_cascade", ROOT / "tests" / "python" / "reference_cascade.py"
    )
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", type=Path, default=HERE, help="folder of the test models")
    ap.add_argument("--out", type=Path, default=HERE / "golden", help="output folder")
    args = ap.parse_args()
    rc = _reference()
    args.out.mkdir(parents=True, exist_ok=True)
    for old in args.out.glob("*.f32"):
        old.unlink()
    for model, seed, n in CASES:
        ref = rc.load_reference(args.models / f"{model}.onnx")
        y = rc.generate(ref, seed, n)
        y32 = y.astype("<f4")
        y32[y32 >= 1] = 0  # float32 rounding of values just below 1 (none expected; kept in [0, 1))
        (args.out / golden_name(model, seed, n)).write_bytes(y32.tobytes())
    print(f"{len(CASES)} golden files in {args.out}")


if __name__ == "__main__":
    main()
