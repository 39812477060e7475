"""The smoke check of run.sh: dpc's image of the smoke scene against pbrt's independent sampler.

    python3 integrations/pbrt-v4/check_smoke.py SMOKE_DIR

SMOKE_DIR holds the renders as PFM (pbrt's imgtool convert): dpc.pfm (16 spp), independent-0.pfm
and independent-1.pfm (16 spp, two seeds) and reference.pfm (independent, 1024 spp). The two
16-spp independent images give the per-pixel noise, hence the standard error of a 16-spp image's
mean; dpc's mean must lie within 4 standard errors of the reference's (independent's expected
value), and so must an independent image's. Prints the numbers; exits 1 if a check fails.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

SPP, REFERENCE_SPP = 16, 1024  # as run.sh renders them


def read_pfm(path: Path) -> np.ndarray:
    """A PFM image as float64 (height, width, channels), top row first."""
    with open(path, "rb") as f:
        kind = f.readline().strip()
        channels = {b"PF": 3, b"Pf": 1}.get(kind)
        if channels is None:
            raise ValueError(f"{path}: not a PFM file")
        width, height = (int(v) for v in f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    return data.reshape(height, width, channels)[::-1].astype(np.float64)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n", maxsplit=1)[0])
    parser.add_argument("smoke_dir", type=Path)
    folder = parser.parse_args().smoke_dir
    dpc = read_pfm(folder / "dpc.pfm")
    ind0, ind1 = read_pfm(folder / "independent-0.pfm"), read_pfm(folder / "independent-1.pfm")
    ref = read_pfm(folder / "reference.pfm")
    if not (dpc.shape == ind0.shape == ind1.shape == ref.shape):
        print(f"image shapes differ: {dpc.shape} {ind0.shape} {ind1.shape} {ref.shape}")
        return 1
    pixels = dpc.shape[0] * dpc.shape[1]
    # per pixel and channel, var(ind0 - ind1) = 2 sigma^2 at 16 spp; the mean's error over the pixels
    sigma2 = ((ind0 - ind1) ** 2).mean() / 2
    se16 = np.sqrt(sigma2 / pixels)
    se_ref = se16 / np.sqrt(REFERENCE_SPP / SPP)
    bound = 4 * np.sqrt(se16**2 + se_ref**2)
    ok = True
    print(f"image {dpc.shape[1]} x {dpc.shape[0]}, {dpc.shape[2]} channels")
    print(f"reference mean (independent, {REFERENCE_SPP} spp) {ref.mean():.6f}")
    print(f"standard error of a 16-spp image's mean {se16:.6f}; bound (4 standard errors) {bound:.6f}")
    print("MSE: per pixel and channel, to the reference")
    for name, image in (("dpc", dpc), ("independent seed 0", ind0), ("independent seed 1", ind1)):
        diff = image.mean() - ref.mean()
        mse = ((image - ref) ** 2).mean()
        verdict = "ok" if abs(diff) <= bound else "FAIL"
        ok &= verdict == "ok"
        print(f"{name:>20}: mean {image.mean():.6f} (minus reference {diff:+.6f}: {verdict}), MSE {mse:.6f}")
    if not np.isfinite(dpc).all() or dpc.max() <= 0:
        print("dpc's image is not finite or is black")
        ok = False
    print("smoke check passed" if ok else "smoke check FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
