"""A study: a 64 x 64 mask refined by greedy value swaps on a spectral energy.

    python -m lab.masks.swap_study    # about 6 minutes on one core; the "mask_swap" section of docs/reports/masks.md
    python -m lab.masks.swap_study --swaps 20000 --no-write   # a quick look

Not a product path and not a dpc model: a study of what a direct optimiser of the masks' spectra
reaches, to set against void-and-cluster (docs/masks.md, "Summary"). The energy is the
Gaussian-weighted power of the rank-normalised mask and of its thresholded patterns at 15 levels
(1/16 ... 15/16, not the report's 1/8 ... 7/8), over every frequency:
    E = sum_q w(q) (|V(q)|^2 / var(v) + sum_L |B_L(q)|^2 / (L (1 - L))),  w(q) = exp(-4 pi^2 s^2 |q|^2 / N^2),
s = 1.5 pixels (the Gaussian of Ulichney's void-and-cluster), V and B_L the DFTs of the mask and of
1[v < L] - L. One step swaps the values of a random pixel and a random pixel within 8 of it (on the
torus) and keeps the swap if E falls; a swap changes V by (v_b - v_a)(e_a - e_b) and each B_L whose
level lies between the two values by +-(e_a - e_b), so a step costs O(frequencies x levels).
Measured with dpc.analysis.dither.mask_quality as every mask in docs/masks.md (0 < |q| <= 6, and
the wider band |q| <= 12).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from dpc import baselines, masks
from dpc.analysis.dither import mask_quality, rank_normalise
from lab.common import REPORTS, replace_section

N, SIGMA, REACH = 64, 1.5, 8
LEVELS = np.arange(1, 16) / 16.0


def refine(v: np.ndarray, swaps: int, seed: int) -> tuple[np.ndarray, int]:
    f = np.fft.fftfreq(N, 1.0 / N)
    qy, qx = np.meshgrid(f, f, indexing="ij")
    w = np.exp(-4 * np.pi**2 * SIGMA**2 * (qx**2 + qy**2) / N**2)
    w[0, 0] = 0.0
    sel = w > 1e-6  # the rest weighs nothing in float64 sums of this size
    qy, qx, w = qy[sel], qx[sel], w[sel]
    norm = 1.0 / np.sqrt(LEVELS * (1 - LEVELS))
    v = v.copy()
    fv = np.fft.fft2(v - v.mean())[sel]
    fl = np.stack([np.fft.fft2((v < lv) - lv)[sel] * k for lv, k in zip(LEVELS, norm)])
    inv_var = 1.0 / v.var()
    rng = np.random.default_rng(seed)
    taken = 0
    for _ in range(swaps):
        a = rng.integers(N, size=2)
        b = (a + rng.integers(-REACH, REACH + 1, size=2)) % N
        if (a == b).all():
            continue
        va, vb = v[a[0], a[1]], v[b[0], b[1]]
        d = np.exp(-2j * np.pi * (qy * a[0] + qx * a[1]) / N) - np.exp(-2j * np.pi * (qy * b[0] + qx * b[1]) / N)
        dv = (vb - va) * d
        de = inv_var * (w * (2 * (np.conj(fv) * dv).real + np.abs(dv) ** 2)).sum()
        idx = np.nonzero((LEVELS > min(va, vb)) & (LEVELS <= max(va, vb)))[0]
        if len(idx):
            dl = np.outer((-1.0 if va < vb else 1.0) * norm[idx], d)
            de += (w * (2 * (np.conj(fl[idx]) * dl).real + np.abs(dl) ** 2)).sum()
        if de < 0:
            v[a[0], a[1]], v[b[0], b[1]] = vb, va
            fv += dv
            if len(idx):
                fl[idx] += dl
            taken += 1
    return v, taken


def row(label: str, m: np.ndarray, extra: str) -> str:
    q, q12 = mask_quality(m), mask_quality(m, q_max=12.0)
    return (
        f"| {label} | {q['mask_elow']:.5f} | {q['levels_elow_mean']:.4f} | {max(q['levels_elow']):.4f} | "
        f"{q12['mask_elow']:.4f} | {q12['levels_elow_mean']:.4f} | {extra} |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--swaps", type=int, default=300_000)
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    rows = [row("void-and-cluster (σ = 1.5)", baselines.void_and_cluster(N), "—")]
    starts = [("white noise", np.random.default_rng(0).random((N, N))), ("`mask-64`", masks.mask("mask-64", seed=0))]
    for label, m0 in starts:
        v0 = rank_normalise(m0)
        rows.append(row(label, v0, "—"))
        t = time.perf_counter()
        v, taken = refine(v0, args.swaps, seed=0)
        rows.append(row(f"{label}, refined", v, f"{taken:,} of {args.swaps:,} in {time.perf_counter() - t:.0f} s"))
        print(rows[-2], rows[-1], sep="\n", flush=True)
    body = "\n".join(
        [
            f"`python -m lab.masks.swap_study` (one mask each, 64 × 64, seed 0; {args.swaps:,} proposed swaps; "
            "energy and steps in the script's docstring). Columns as in the scalar tables: mask E_low and "
            "thresholded mean / worst level over 0 < |q| ≤ 6, then mask and thresholded mean over |q| ≤ 12.",
            "",
            "| mask | mask E_low | thresholded mean | worst level | mask, \\|q\\| ≤ 12 | thresholded, \\|q\\| ≤ 12 "
            "| swaps kept, time |",
            "|---|---:|---:|---:|---:|---:|---|",
            *rows,
        ]
    )
    print(body)
    if not args.no_write:
        doc = REPORTS / "masks.md"
        if "<!-- mask_swap:begin -->" not in doc.read_text():
            sys.exit(f"{doc} has no <!-- mask_swap:begin --> ... end marker pair to replace")
        replace_section(doc, "mask_swap", body)
        print(f"wrote {doc}")


if __name__ == "__main__":
    main()
