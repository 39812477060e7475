"""Why the density generator is defined as it is (docs/density.md, "Definition"): the float64
reference (lab/density/reference.py) run with each choice varied, on a ramp, 1 : 8 and 1 : 16
steps and a bright spot. Writes docs/reports/density-design.md.

    python -m lab.density.design
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from lab.common import report_header
from lab.density import reference
from lab.density.field import hex_spacing

REPO = Path(__file__).resolve().parents[2]
OUT = REPO / "docs" / "reports" / "density-design.md"
MODEL = "bnot-2d-stratified"
G = 128
MIRROR_M, MIRROR_SEEDS = 2048, 3
SIDE_M, SIDE_SEEDS = 2048, 4


def densities():
    y, x = (np.mgrid[0:G, 0:G] + 0.5) / G
    spot = (x - 0.5) ** 2 + (y - 0.5) ** 2 < 0.03**2
    return {
        "ramp 0.1 + x": (0.1 + x, x < 0.5),
        "step 1 : 16": (np.where(x < 0.5, 1.0, 16.0), x < 0.5),
        "spot 3000 : 1": (1.0 + np.where(spot, 3000.0, 0.0), spot),
    }


def count_error(p, d, k, rng, windows=3000):
    """Mean squared count error over mean expected count in square windows of about k expected
    points (white noise: 1), windows inside the square."""
    return count_error_at(p, d, k, rng.random((windows, 2)))


def count_error_at(p, d, k, centres):
    """count_error with the windows at these centres (those that leave the square are skipped)."""
    m = len(p)
    mass = d / d.sum()
    sat = np.zeros((G + 1, G + 1))
    sat[1:, 1:] = mass.cumsum(0).cumsum(1)

    def F(x, y):
        gx, gy = x * G, y * G
        i, j = min(int(gx), G - 1), min(int(gy), G - 1)
        fx, fy = gx - i, gy - j
        return (
            sat[j, i] * (1 - fx) * (1 - fy)
            + sat[j, i + 1] * fx * (1 - fy)
            + sat[j + 1, i] * (1 - fx) * fy
            + sat[j + 1, i + 1] * fx * fy
        )

    err, exp = [], []
    for c in centres:
        a = np.sqrt(k / (m * d[min(int(c[1] * G), G - 1), min(int(c[0] * G), G - 1)] / d.mean()))
        x0, y0 = c - a / 2
        if x0 < 0 or y0 < 0 or x0 + a > 1 or y0 + a > 1:
            continue
        e = m * (F(x0 + a, y0 + a) - F(x0, y0 + a) - F(x0 + a, y0) + F(x0, y0))
        n = np.sum((p[:, 0] >= x0) & (p[:, 0] < x0 + a) & (p[:, 1] >= y0) & (p[:, 1] < y0 + a))
        err.append((n - e) ** 2)
        exp.append(e)
    return float(np.mean(err) / np.mean(exp))


def strip_count(d, m):
    """The expected count of a strip along the four sides a quarter of the local hexagonal spacing
    wide (the density along each side taken as constant across the strip; corners counted twice)."""
    rho = d / d.mean()
    return sum(m * np.mean(side * 0.25 * hex_spacing(m, side)) for side in (rho[:, 0], rho[:, -1], rho[0], rho[-1]))


def side_count_error(p, d, k, rng, windows=1000):
    """count_error over windows whose edge lies within one local mean spacing of a side."""
    m = len(p)
    keep = []
    for c in rng.random((windows * 24, 2)):
        a = np.sqrt(k / (m * d[min(int(c[1] * G), G - 1), min(int(c[0] * G), G - 1)] / d.mean()))
        lo = c - a / 2
        if 0 <= min(lo[0], lo[1], 1 - lo[0] - a, 1 - lo[1] - a) < a / np.sqrt(k):
            keep.append(c)
            if len(keep) == windows:
                break
    return count_error_at(p, d, k, np.array(keep))


def share(p, region):
    c = np.minimum((p * G).astype(int), G - 1)
    return float(region[c[:, 1], c[:, 0]].mean())


def main() -> None:
    t0 = time.time()
    dens = densities()
    lines = [
        "# Density generator: the design's choices, measured",
        "",
        *report_header("python -m lab.density.design"),
        "On the float64 reference of the definition (lab/density/reference.py, which libdpc matches to "
        f"float rounding: tests/python/test_density.py) with model {MODEL}. The definition itself: "
        "[density.md](../density.md).",
        "",
        "## The pair's spacing",
        "",
        "Count error in windows of about 16 expected points (white noise = 1; uniform blue noise about "
        "0.08), 1,024 points, mean of 3 seeds, without walls, so that only the pair's spacing differs:",
        "",
        "| pair spacing h_ij | " + " | ".join(list(dens)[:2]) + " |",
        "|---|---|---|",
    ]
    for pair in ("own", "arithmetic", "geometric", "harmonic"):
        row = []
        for name in list(dens)[:2]:
            d = dens[name][0]
            errs = [
                count_error(
                    reference.generate(MODEL, d, 1024, s, pair=pair, walls=False), d, 16, np.random.default_rng(s)
                )
                for s in range(3)
            ]
            row.append(f"{np.mean(errs):.3f}")
        label = {"own": "h_i (each point its own)", "arithmetic": "(h_i + h_j) / 2"}.get(pair, pair)
        label = {"geometric": "sqrt(h_i h_j)", "harmonic": "2 h_i h_j / (h_i + h_j) (dpc)"}.get(pair, label)
        lines.append(f"| {label} | " + " | ".join(row) + " |")
        print(lines[-1], flush=True)
    lines += [
        "",
        "## Walls",
        "",
        "The share of the points in the left half (ramp, step) or in the spot, against the density's "
        "share; mean of 8 seeds ± its standard error, harmonic pair spacing:",
        "",
        "| density | points | density's share | without walls | with walls (dpc) |",
        "|---|---|---|---|---|",
    ]
    for name, (d, region) in dens.items():
        want = d[region].sum() / d.sum()
        for m in (64, 1024):
            cells = []
            for walls in (False, True):
                s = [share(reference.generate(MODEL, d, m, k, walls=walls), region) for k in range(8)]
                cells.append(f"{np.mean(s):.3f} ± {np.std(s) / np.sqrt(8):.3f}")
            lines.append(f"| {name} | {m:,} | {want:.3f} | " + " | ".join(cells) + " |")
            print(lines[-1], flush=True)
    lines += [
        "",
        "## Walls as mirrors",
        "",
        "Walls that only stop steps, against walls that are also plain mirrors, and glide mirrors (dpc: the "
        f"images shifted along the wall by {reference.WALL_GLIDE:g} of the point's spacings), on 1 : 8 and "
        f"1 : 16 steps at x = 1/2 ({MIRROR_M:,} points, mean of {MIRROR_SEEDS} seeds): the count in the strip "
        "one local hexagonal spacing wide on each side of the edge over its expectation (1 = no seam), the "
        "count in the strips a quarter of a spacing wide on the dense side, from the edge (a row: one far "
        "from 1), and the count error in windows of about 16 and 64 expected points:",
        "",
        "| step | walls | sparse strip | dense strip | dense 0-¼ | ¼-½ | ½-¾ | ¾-1 | count error k = 16 | k = 64 |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    y, x = (np.mgrid[0:G, 0:G] + 0.5) / G
    for ratio in (8.0, 16.0):
        d = np.where(x < 0.5, 1.0, ratio)
        rho = (2.0 / (1.0 + ratio), 2.0 * ratio / (1.0 + ratio))
        hexes = [hex_spacing(MIRROR_M, r) for r in rho]
        for kind, mirror, glide in (
            ("stop steps", False, False),
            ("stop steps, plain mirrors", True, False),
            ("stop steps, glide mirrors (dpc)", True, True),
        ):
            lo = hi = 0.0
            rows = np.zeros(4)
            errs, errs64 = [], []
            for k in range(MIRROR_SEEDS):
                p = reference.generate(MODEL, d, MIRROR_M, k, mirror=mirror, wall_glides=glide)
                lo += np.sum((p[:, 0] >= 0.5 - hexes[0]) & (p[:, 0] < 0.5)) / (MIRROR_M * rho[0] * hexes[0])
                hi += np.sum((p[:, 0] >= 0.5) & (p[:, 0] < 0.5 + hexes[1])) / (MIRROR_M * rho[1] * hexes[1])
                mid = (p[:, 1] > 0.1) & (p[:, 1] < 0.9)  # away from the corners with the sides
                dense = (p[mid, 0] - 0.5) / hexes[1]
                rows += np.histogram(dense, bins=4, range=(0, 1))[0] / (0.8 * MIRROR_M * rho[1] * 0.25 * hexes[1])
                errs.append(count_error(p, d, 16, np.random.default_rng(k)))
                errs64.append(count_error(p, d, 64, np.random.default_rng(k)))
            strips = f"{lo / MIRROR_SEEDS:.2f} | {hi / MIRROR_SEEDS:.2f} | " + " | ".join(
                f"{v:.2f}" for v in rows / MIRROR_SEEDS
            )
            lines.append(f"| 1 : {ratio:.0f} | {kind} | {strips} | {np.mean(errs):.3f} | {np.mean(errs64):.3f} |")
            print(lines[-1], flush=True)
    lines += [
        "",
        "## Sides as glide mirrors",
        "",
        f"The square's sides as plain mirrors, against glide mirrors (dpc: the image across a side shifted "
        f"along it by {reference.GLIDE:g} mean spacings), on a constant density and on the ramp ({SIDE_M:,} "
        f"points, {SIDE_SEEDS} seeds): the count in strips along the four sides, a quarter of the local "
        "hexagonal spacing wide, over their expected counts, from the side inwards (1 = the density "
        "holds up to the side), and the count error in windows of about 64 expected points whose edge "
        "lies within one local spacing of a side:",
        "",
        "| density | sides | 0-¼ | ¼-½ | ½-¾ | ¾-1 | 1-1¼ | count error k = 64, windows at a side |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, d in (("constant", np.ones((G, G))), ("ramp 0.1 + x", 0.1 + x)):
        rho_of = d / d.mean()
        for glides in (False, True):
            strips = np.zeros(5)
            errs = []
            for k in range(SIDE_SEEDS):
                p = reference.generate(MODEL, d, SIDE_M, k, glides=glides)
                c = np.minimum((p * G).astype(int), G - 1)
                hexp = hex_spacing(SIDE_M, rho_of[c[:, 1], c[:, 0]])
                gap = np.minimum(np.minimum(p[:, 0], 1 - p[:, 0]), np.minimum(p[:, 1], 1 - p[:, 1])) / hexp
                strips += np.histogram(gap, bins=5, range=(0, 1.25))[0]
                errs.append(side_count_error(p, d, 64, np.random.default_rng(k)))
            want = SIDE_SEEDS * strip_count(d, SIDE_M)
            kind = "glide mirrors (dpc)" if glides else "mirrors"
            lines.append(
                f"| {name} | {kind} | " + " | ".join(f"{v:.2f}" for v in strips / want) + f" | {np.mean(errs):.3f} |"
            )
            print(lines[-1], flush=True)
    lines += ["", f"Run time: {time.time() - t0:.0f} s.", ""]
    OUT.write_text("\n".join(lines))
    print(f"wrote {OUT.relative_to(REPO)}")


if __name__ == "__main__":
    main()
