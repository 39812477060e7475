"""Blue noise that follows a density: dpc's Model.generate_density against the anchors, measured.

    python -m lab.density.study            # the full study, about 20 minutes on 2 cores
    python -m lab.density.study --quick    # m = 4,096 only, fewer seeds; writes to a temp folder

Densities (256 x 256 grids): a ramp rho = 0.1 + x, a Gaussian bump (sigma 0.15) on a floor of
0.05, a step 1 | 16 across x = 1/2, and a photograph (Grace Hopper, matplotlib's sample, a US
Navy photo in the public domain) as (1 - tone) for stippling. Methods: (a) dpc
(bnot-2d-stratified, generate_density), (b) dpc's own uniform set through the density's inverse
CDF, (c) weighted sample elimination (Yuksel 2015), (d) variable-radius dart throwing, (e)
weighted Lloyd relaxation (Secord 2002), and white noise from the density as the calibration row
(lab/density/anchors.py says how each anchor is made).

Metrics, pooled over seeds: count error in square windows of 4, 16 and 64 expected points (mean
squared error of the count over the mean expected count: white noise about 1), nearest-neighbour
distance over the local hexagonal spacing away from density edges and the square's sides, the
low-band energy (E_low below nu = 0.5) of the points sent back to the uniform square through the
density's CDF, and generation time on one core. Writes docs/reports/density.md and the figures in
docs/figures/density/.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core: the timings are single-threaded

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

import dpc  # noqa: E402
from dpc.analysis.spectrum import power_spectrum_2d  # noqa: E402
from lab.common import REPORTS, ROOT, cpu_name, report_header  # noqa: E402
from lab.density import anchors  # noqa: E402
from lab.density.field import Field, bump, hex_spacing, photo, ramp, step  # noqa: E402

PAGE = REPORTS / "density.md"
FIGS = ROOT / "docs" / "figures" / "density"
MODEL = "bnot-2d-stratified"
KS = (4, 16, 64)  # expected points per window
METHODS = ("dpc", "warp", "WSE", "dart", "Lloyd", "Lloyd-ρ", "white")
FAST = ("warp", "WSE", "dart")  # the fast anchors
NAMES = {
    "dpc": "(a) dpc generate_density",
    "warp": "(b) inverse-CDF warp of dpc's uniform set",
    "WSE": "(c) weighted sample elimination",
    "dart": "(d) variable-radius dart throwing",
    "Lloyd": "(e) weighted Lloyd (reference)",
    "Lloyd-ρ": "weighted Lloyd with Secord's weights ρ",
    "white": "white noise from the density",
}
FULL = {
    "counts": (4096, 65536),
    "seeds": {4096: 4, 65536: 2},
    "lloyd_seeds": {4096: 2, 65536: 1},
    "lloyd_cap": {4096: 500, 65536: 40},
    "windows": 4000,
    "gallery": (4096, 16384, 65536),
}
QUICK = {
    "counts": (4096,),
    "seeds": {4096: 2},
    "lloyd_seeds": {4096: 1},
    "lloyd_cap": {4096: 300},
    "windows": 2000,
    "gallery": (1024, 4096),
}
LLOYD_PIXELS = 64  # raster pixels per point, at least
EDGE_GAP = 3.0  # NN statistics: points farther than this many local spacings from edges and sides
NU_LOW = 0.5
SPEED_M = 65536  # the count of the speed goal against the Lloyd reference


_FIELDS: list[Field] = []


def fields() -> list[Field]:
    """The four densities (made once)."""
    if not _FIELDS:
        _FIELDS.extend([ramp(), bump(), step(), photo()])
    return _FIELDS


# ---------------------------------------------------------------- metrics


def windows(field: Field, m: int, k: int, count: int, rng: np.random.Generator):
    """Square windows of about k expected points: centres uniform in the square, side
    sqrt(k / (m rho(centre))), kept when inside the square; (centres, half sides, exact
    expected counts)."""
    cs, hs = [], []
    have = 0
    while have < count:
        c = rng.random((4 * count, 2))
        rho = field.rho(c)
        ok = rho > 0
        half = np.full(len(c), np.inf)
        half[ok] = 0.5 * np.sqrt(k / (m * rho[ok]))
        ok &= np.all((c - half[:, None] >= 0) & (c + half[:, None] <= 1), axis=1)
        cs.append(c[ok])
        hs.append(half[ok])
        have += int(ok.sum())
    c, half = np.concatenate(cs)[:count], np.concatenate(hs)[:count]
    expected = m * field.mass(c[:, 0] - half, c[:, 1] - half, c[:, 0] + half, c[:, 1] + half)
    return c, half, expected


def count_error(sets: list[np.ndarray], wins) -> float:
    """Mean squared count error over the mean expected count, pooled over sets and windows."""
    c, half, expected = wins
    err = []
    for p in sets:
        n = cKDTree(p).query_ball_point(c, half, p=np.inf, return_length=True)
        err.append((n - expected) ** 2)
    return float(np.mean(err) / np.mean(expected))


def nn_quality(field: Field, sets: list[np.ndarray], m: int) -> tuple[float, float, float]:
    """NN distance over the local hexagonal spacing, for points farther than EDGE_GAP local
    spacings from any density edge and from the square's sides: (mean, 1st percentile, the
    fraction of points counted)."""
    ratios, kept = [], 0
    for p in sets:
        d = cKDTree(p).query(p, k=2)[0][:, 1]
        h = hex_spacing(m, field.rho(p))
        side = np.minimum(p.min(axis=1), (1.0 - p).min(axis=1))
        ok = (side > EDGE_GAP * h) & (field.edge_distance(p) > EDGE_GAP * h)
        ratios.append(d[ok] / h[ok])
        kept += int(ok.sum())
    r = np.concatenate(ratios)
    return float(r.mean()), float(np.percentile(r, 1)), kept / sum(len(p) for p in sets)


def low_band(sets: list[np.ndarray], field: Field | None) -> float:
    """E_low below nu = 0.5 (white = 1) of the sets sent back to the uniform square (field None:
    already there), mean over sets."""
    out = []
    for p in sets:
        u = p if field is None else field.unwarp(p)
        out.append(power_spectrum_2d(u, nu_max=NU_LOW, stride=1).low_frequency_energy(NU_LOW))
    return float(np.mean(out))


def strip_ratio(sets: list[np.ndarray], field: Field, m: int, x0, y0, x1, y1) -> float:
    """Points counted in the rectangle over its exact expected count, pooled over sets."""
    expected = m * field.mass(x0, y0, x1, y1) * len(sets)
    got = sum(int(np.sum((p[:, 0] >= x0) & (p[:, 0] < x1) & (p[:, 1] >= y0) & (p[:, 1] < y1))) for p in sets)
    return got / expected


def edge_counts(field: Field, sets: list[np.ndarray], m: int) -> dict:
    """Counts near the square's sides and (step) beside the density edge, over their expectation:
    'sides': the four strips of width 1/(2 sqrt(m)) (half the mean spacing) along the sides;
    for the step, 'low' / 'high': the strips of one local hexagonal spacing just left / right of
    x = 1/2."""
    w = 0.5 / np.sqrt(m)
    strips = [(0, 0, w, 1), (1 - w, 0, 1, 1), (w, 0, 1 - w, w), (w, 1 - w, 1 - w, 1)]
    exp = sum(m * field.mass(*r) for r in strips) * len(sets)
    got = 0
    for p in sets:
        near = (p[:, 0] < w) | (p[:, 0] >= 1 - w) | (p[:, 1] < w) | (p[:, 1] >= 1 - w)
        got += int(near.sum())
    out = {"sides": got / exp}
    if field.name == "step":
        lo, hi = hex_spacing(m, field.grid.min()), hex_spacing(m, field.grid.max())
        out["low"] = strip_ratio(sets, field, m, 0.5 - lo, 0.0, 0.5, 1.0)
        out["high"] = strip_ratio(sets, field, m, 0.5, 0.0, 0.5 + hi, 1.0)
    return out


# ---------------------------------------------------------------- runs


def timed(f, *a, **k):
    t = time.perf_counter()
    out = f(*a, **k)
    return out, time.perf_counter() - t


def run_case(model, field: Field, m: int, cfg: dict, log) -> dict:
    """Every method's sets and times for one density and count."""
    seeds = cfg["seeds"][m]
    grid = field.float32()
    sets = {k: [] for k in METHODS}
    times = {k: [] for k in METHODS}
    uniform, t_uniform = [], []
    info = {"used": [], "lloyd": []}
    for s in range(seeds):
        rng = np.random.default_rng(1000 * s + 7)
        p, t = timed(model.generate_density, grid, m, s)
        sets["dpc"].append(p.astype(np.float64))
        times["dpc"].append(t)
        u, t = timed(model.generate, s, m)
        u = u.astype(np.float64)
        uniform.append(u)
        t_uniform.append(t)
        w, tw = timed(anchors.warp, field, u)
        sets["warp"].append(w)
        times["warp"].append(t + tw)
        p, t = timed(anchors.sample_elimination, field, m, rng)
        sets["WSE"].append(p)
        times["WSE"].append(t)
        (p, used), t = timed(anchors.dart_throwing, field, m, rng)
        sets["dart"].append(p)
        times["dart"].append(t)
        info["used"].append(used / m)
        if s < cfg["lloyd_seeds"][m]:
            (p, it, move, sup), t = timed(anchors.lloyd, field, m, rng, cfg["lloyd_cap"][m], per_point=LLOYD_PIXELS)
            sets["Lloyd"].append(p)
            times["Lloyd"].append(t)
            info["lloyd"].append((it, move, sup))
        if s == 0 and m == min(cfg["counts"]):
            (p, it_r, move_r, _), t = timed(
                anchors.lloyd, field, m, rng, cfg["lloyd_cap"][m], per_point=LLOYD_PIXELS, power=1.0
            )
            sets["Lloyd-ρ"].append(p)
            times["Lloyd-ρ"].append(t)
            info["lloyd_rho"] = (it_r, move_r)
        sets["white"].append(field.sample(m, rng))
        log(
            f"  {field.name} m={m} seed {s}: dpc {times['dpc'][-1]:.2f} s, WSE {times['WSE'][-1]:.1f} s, "
            f"dart {times['dart'][-1]:.1f} s"
            + (f", Lloyd {times['Lloyd'][-1]:.1f} s ({it} it)" if s < cfg["lloyd_seeds"][m] else "")
        )
    # medians of at least 3 runs for dpc and the uniform set
    while len(times["dpc"]) < 3:
        times["dpc"].append(timed(model.generate_density, grid, m, len(times["dpc"]))[1])
    while len(t_uniform) < 5:
        t_uniform.append(timed(model.generate, len(t_uniform), m)[1])
    rng = np.random.default_rng(99)
    wins = {k: windows(field, m, k, cfg["windows"], rng) for k in KS}
    rows = {}
    for name in METHODS:
        got = sets[name]
        if not got:
            continue
        rows[name] = {
            "count": {k: count_error(got, wins[k]) for k in KS},
            "nn": nn_quality(field, got, m),
            "elow": low_band(got, field),
            "edges": edge_counts(field, got, m),
            "time": float(np.median(times[name])) if times[name] else float("nan"),
            "sets": len(got),
            "n": min(len(p) for p in got),
        }
    return {
        "rows": rows,
        "uniform_elow": low_band(uniform, None),
        "uniform_time": float(np.median(t_uniform)),
        "dart_candidates": float(np.mean(info["used"])),
        "lloyd": info["lloyd"],
        "lloyd_rho": info.get("lloyd_rho"),
        "first": {k: v[0] for k, v in sets.items() if v},
        "window_counts": {k: float(np.mean(wins[k][2])) for k in KS},
    }


# ---------------------------------------------------------------- figures


def panel(ax, p: np.ndarray, m: int, title: str, size: float) -> None:
    """Dots as small black discs on white, y down (image coordinates), a square panel."""
    ax.scatter(p[:, 0], p[:, 1], s=size, c="black", linewidths=0, marker="o")
    ax.set_xlim(0, 1)
    ax.set_ylim(1, 0)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title, fontsize=9)


def dot_size(m: int, inches: float, dpi: float, scale: float = 0.55) -> float:
    """Marker area (points^2) for a disc of diameter scale x the mean spacing 1/sqrt(m)."""
    return (scale * inches * 72.0 / np.sqrt(m)) ** 2


def gallery(model, field: Field, counts, have: dict, out: Path) -> Path:
    inches, dpi = 4.0, 130
    fig, axes = plt.subplots(1, len(counts), figsize=(inches * len(counts), inches + 0.35))
    for ax, m in zip(np.atleast_1d(axes), counts):
        p = have.get(m)
        if p is None:
            p = model.generate_density(field.float32(), m, 0)
        panel(ax, p, m, f"dpc, m = {m:,}", dot_size(m, inches, dpi))
    fig.tight_layout(pad=0.3)
    path = out / "photo-gallery.png"
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def side_by_side(field: Field, first: dict, m: int, out: Path) -> Path:
    inches, dpi = 3.0, 110
    names = ("dpc", "warp", "WSE", "dart", "Lloyd")
    fig, axes = plt.subplots(1, len(names), figsize=(inches * len(names), inches + 0.35))
    for ax, name in zip(axes, names):
        panel(ax, first[name], m, f"{NAMES[name][4:] if name != 'dpc' else 'dpc'}", dot_size(m, inches, dpi))
    fig.tight_layout(pad=0.3)
    path = out / f"{field.name}-{m}.png"
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


# ---------------------------------------------------------------- page


def revision() -> str:
    """The repository's commit (and whether the tree has changes) when the study ran."""
    import subprocess

    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=True
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "an unknown commit"
    return f"commit {head}"


def fmt(v: float) -> str:
    if v == 0 or not np.isfinite(v):
        return f"{v:g}"
    if abs(v) >= 100:
        return f"{v:,.0f}"
    if abs(v) >= 1:
        return f"{v:.2f}"
    return f"{v:.3g}"


def met(ok: bool) -> str:
    return "met" if ok else "**missed**"


def page(results: dict, cfg: dict, command: str, seconds: float, figs: list[Path], out: Path) -> str:
    L = [
        "# Blue noise that follows a density: dpc against the anchors",
        "",
        *report_header(command),
        f"Machine: {cpu_name()}; {os.cpu_count()} logical CPUs, every method on one core (dpc "
        f"`{MODEL}` loaded with its default threads = 1, NumPy/SciPy single-threaded). "
        f"dpc {dpc.__version__} as installed; the repository at {revision()} when it ran. "
        "What the density generator is: [density.md](../density.md). "
        f"Total run time {seconds / 60:.1f} min.",
        "",
        "## What was measured",
        "",
        "Densities, 256 × 256 grids, piecewise constant, row r covering y in [r/256, (r+1)/256) "
        "(figures: y down, as in an image):",
        "",
        "* **ramp**: ρ = 0.1 + x (11 : 1 across the square);",
        "* **bump**: ρ = 0.05 + exp(−|x − (½, ½)|² / (2 · 0.15²));",
        "* **step**: ρ = 1 for x < ½, 16 for x ≥ ½ (no zero region);",
        "* **photo**: Grace Hopper, the sample photograph matplotlib ships "
        "(`matplotlib.cbook.get_sample_data('grace_hopper.jpg')`, a US Navy photograph, public domain): "
        "600 × 512 px, rows 44–555 (a centred square), averaged 2 × 2 to 256 × 256; ρ = (1 − tone)^1, "
        "tone the Rec. 709 luminance in [0, 1] (`dpc.density.image_tone`): dark is dense. "
        f"{100 * float(np.mean(fields()[3].grid == 0)):.2f} % of its cells are 0.",
        "",
        "Methods (code: `lab/density/anchors.py`):",
        "",
        f"* **(a) dpc**: `dpc.load('{MODEL}').generate_density(grid, m, seed)`.",
        "* **(b) warp**: dpc's uniform set of the same model and m (`generate(seed, m)`) through the "
        "density's inverse CDF (marginal over rows by y, then the row's conditional by x, piecewise "
        "linear, the fraction within the cell kept). Its time includes the uniform set's.",
        "* **(c) WSE**: weighted sample elimination (Yuksel 2015), written from the paper in NumPy/SciPy: "
        "5 m candidates drawn from the density (white), w_ij = (1 − d̂_ij / (2 r_ij))^8 over pairs with "
        "d_ij < 2 r_ij, the heaviest removed until m remain. Adaptive radius per candidate "
        "r_i = r_max / √ρ(x_i), r_max = √(1 / (2√3 m)) (ρ has mean 1), pair radius the harmonic mean "
        "2 r_i r_j / (r_i + r_j) (as dpc's pair spacing); the paper's weight limiting with its defaults: "
        "d̂_ij = max(d_ij, 2 r_ij · 0.65 · (1 − (1/5)^1.5)).",
        "* **(d) dart**: sequential dart throwing with candidates drawn from the density, radius "
        f"r(x) = {anchors.DART_C} · √(2 / (√3 m ρ(x))) ({anchors.DART_C} local hexagonal spacings), a "
        "candidate rejected when a kept point is closer than the harmonic mean of their radii, thrown until "
        "exactly m are kept (the coefficient chosen so that m is reached in about 10 m candidates; "
        "the table below gives the candidates used).",
        "* **(e) Lloyd**: weighted Lloyd relaxation (Secord 2002): each pixel of the density grid "
        f"supersampled by 2^k to at least {LLOYD_PIXELS} pixels per point goes to its nearest site "
        "(cKDTree, one thread), each site moves to its cell's weighted centroid; start: a jittered "
        "√m × √m grid through the inverse CDF; stop when the mean move is below 10⁻⁴ of the local "
        "hexagonal spacing or at the iteration cap ("
        + ", ".join(f"{cfg['lloyd_cap'][m]} at m = {m:,}" for m in cfg["counts"])
        + "). Pixel weights **ρ²**, not Secord's ρ: a centroidal Voronoi tessellation of weight f has "
        "point density ∝ f^(d/(d+2)) (Gersho 1979), √f in 2-D, so ρ² makes the points follow ρ. The row "
        f"**Lloyd-ρ** (m = {min(cfg['counts']):,}, seed 0 only) is Secord's weighting under the same rule, "
        "for comparison. Fewer seeds than the others: "
        + ", ".join(f"{cfg['lloyd_seeds'][m]} at m = {m:,}" for m in cfg["counts"])
        + ".",
        "* **white**: independent points drawn from the density: the calibration row.",
        "",
        "Seeds per (density, m): "
        + ", ".join(f"{cfg['seeds'][m]} at m = {m:,}" for m in cfg["counts"])
        + "; metrics pooled over them.",
        "",
        "Metrics:",
        "",
        f"* **count error k**: {cfg['windows']:,} square windows per k (the same for every method): "
        "centre uniform in the square, side √(k / (m ρ(centre))) so that about k points are expected, "
        "kept only when inside the square; expected count E = m × the window's exact mass (summed-area "
        "table, partial pixels by their covered fraction). Reported: mean (count − E)² / mean E; white "
        "noise gives about 1 (its row checks it).",
        "* **NN mean / NN 1 %**: each point's nearest-neighbour distance over the local hexagonal spacing "
        "√(2 / (√3 m ρ(x))), mean and 1st percentile, over the points farther than "
        f"{EDGE_GAP:g} local spacings from the square's sides and from any density edge cell (a cell "
        "whose density differs from a 4-neighbour's by more than 2×); *kept* is the fraction of points "
        "counted.",
        "* **E_low**: the points sent back to the uniform square through the density's CDF (the inverse "
        "of (b)'s map), then the mean power over the integer frequencies 0 < |q| < 0.5 √m (white = 1, "
        "`dpc.analysis.spectrum.power_spectrum_2d(...).low_frequency_energy(0.5)`). (b) maps back to "
        "dpc's uniform set itself, so its E_low is the uniform model's by construction.",
        "* **time**: median wall time of one set on one core (dpc: at least 3 runs; anchors: over the seeds).",
        "",
    ]
    goals = []
    for m in cfg["counts"]:
        L += [f"## m = {m:,}", ""]
        L += [
            "| density | method | count err k=4 | k=16 | k=64 | NN mean | NN 1 % | kept | E_low ν<0.5 | time (s) |",
            "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for fname, res in results[m].items():
            for name in res["rows"]:
                r = res["rows"][name]
                nn_mean, nn_p1, kept = r["nn"]
                t = "—" if name == "white" else fmt(r["time"])
                L.append(
                    f"| {fname} | {name} | "
                    + " | ".join(fmt(r["count"][k]) for k in KS)
                    + f" | {nn_mean:.3f} | {nn_p1:.3f} | {kept:.2f} | {fmt(r['elow'])} | {t} |"
                )
            L.append(
                f"| {fname} | uniform set (no density) | | | | | | | {fmt(res['uniform_elow'])} | "
                f"{fmt(res['uniform_time'])} |"
            )
        L += [""]
        L += [
            "| density | expected counts k=4 / 16 / 64 (mean) | dart candidates / m "
            "| Lloyd iterations (last mean move, spacings) | Lloyd raster |",
            "|---|---|---:|---|---|",
        ]
        for fname, res in results[m].items():
            ll = "; ".join(f"{it} ({mv:.1e})" for it, mv, _ in res["lloyd"])
            if res["lloyd_rho"] is not None:
                ll += f"; Lloyd-ρ {res['lloyd_rho'][0]} ({res['lloyd_rho'][1]:.1e})"
            sup = res["lloyd"][0][2]
            L.append(
                f"| {fname} | "
                + " / ".join(f"{res['window_counts'][k]:.1f}" for k in KS)
                + f" | {res['dart_candidates']:.1f} | {ll} | {256 * sup} × {256 * sup} "
                f"({(256 * sup) ** 2 / m:.0f} px per point) |"
            )
        L += [""]
        L += [
            "Counts at the square's sides and at the step's edge, over their exact expectation (1 = "
            "unbiased; pooled over seeds): *sides*: the strips of width ½/√m along the four sides; "
            "*step, left of edge* / *right of edge*: the strips one local hexagonal spacing wide "
            "(of ρ = 1 and of ρ = 16) just left and right of x = ½. Where the density at a side is low "
            "(the bump's floor: ρ ≈ 0.26 of the mean) ½/√m is about a quarter of the local spacing, and "
            "a method that keeps points half a local spacing from the sides has none there (0.00).",
            "",
            "| method | " + " | ".join(f"sides, {f}" for f in results[m]) + " | step, left of edge | right of edge |",
            "|---|" + "---:|" * (len(results[m]) + 2),
        ]
        for name in METHODS:
            have = [res["rows"][name]["edges"] for res in results[m].values() if name in res["rows"]]
            if len(have) != len(results[m]):
                continue
            st = results[m]["step"]["rows"][name]["edges"] if "step" in results[m] else {}
            L.append(
                f"| {name} | "
                + " | ".join(f"{e['sides']:.2f}" for e in have)
                + f" | {st.get('low', float('nan')):.2f} | {st.get('high', float('nan')):.2f} |"
            )
        L += [""]
        for fname, res in results[m].items():
            rows = res["rows"]
            dpc_r, white = rows["dpc"], rows["white"]
            r16 = dpc_r["count"][16] / white["count"][16]
            goals.append(
                (
                    m,
                    fname,
                    "count error at k=16 ≤ 0.1 × white's",
                    f"{fmt(dpc_r['count'][16])} / {fmt(white['count'][16])} = {r16:.3f}",
                    r16 <= 0.1,
                )
            )
            for k in KS:
                best = min(FAST, key=lambda a: rows[a]["count"][k])
                rb = dpc_r["count"][k] / rows[best]["count"][k]
                goals.append(
                    (
                        m,
                        fname,
                        f"count error at k={k} ≤ best fast anchor's ({best})",
                        f"{fmt(dpc_r['count'][k])} / {fmt(rows[best]['count'][k])} = {rb:.3f}",
                        rb <= 1.0,
                    )
                )
            p1 = dpc_r["nn"][1]
            goals.append((m, fname, "NN 1st percentile ≥ 0.6 away from edges", f"{p1:.3f}", p1 >= 0.6))
            re = dpc_r["elow"] / res["uniform_elow"]
            goals.append(
                (
                    m,
                    fname,
                    "E_low within 2× the uniform model's",
                    f"{fmt(dpc_r['elow'])} / {fmt(res['uniform_elow'])} = {re:.2f}",
                    re <= 2.0,
                )
            )
            rt = dpc_r["time"] / res["uniform_time"]
            goals.append(
                (
                    m,
                    fname,
                    "time within 2× a uniform set's",
                    f"{dpc_r['time']:.3f} s / {res['uniform_time']:.3f} s = {rt:.1f}",
                    rt <= 2.0,
                )
            )
            if m == max(cfg["counts"]) and m >= SPEED_M:
                rl = rows["Lloyd"]["time"] / dpc_r["time"]
                it = res["lloyd"][0][0]
                capped = it >= cfg["lloyd_cap"][m]
                goals.append(
                    (
                        m,
                        fname,
                        "≥ 100× faster than the Lloyd reference",
                        f"{rows['Lloyd']['time']:.1f} s / {dpc_r['time']:.2f} s = {rl:.0f}×"
                        + (f" (Lloyd capped at {it} iterations: a lower bound)" if capped else ""),
                        rl >= 100,
                    )
                )
    n_met = sum(g[4] for g in goals)
    L += [
        "## Goals",
        "",
        f"{n_met} of {len(goals)} met.",
        "",
        "| m | density | goal | measured | |",
        "|---:|---|---|---|---|",
    ]
    L += [f"| {m:,} | {f} | {g} | {v} | {met(ok)} |" for m, f, g, v, ok in goals]
    L += ["", "## Figures", ""]
    for p in figs:
        rel = os.path.relpath(p, out)
        L.append(f"![{p.stem}]({rel})")
        L.append("")
    L.append(
        "`photo-gallery.png`: the photograph stippled by dpc (seed 0); the others: seed 0 of each method at "
        f"m = {min(cfg['counts']):,} (dpc, warp, WSE, dart, Lloyd from left). Dots: black discs of 0.55 mean "
        "spacings 1/√m, y down."
    )
    L.append("")
    return "\n".join(L)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="m = 4,096 only, fewer seeds; output to a temp folder")
    args = ap.parse_args()
    cfg = QUICK if args.quick else FULL
    command = "python -m lab.density.study" + (" --quick" if args.quick else "")
    if args.quick:
        base = Path(tempfile.gettempdir()) / "dpc-density-quick"
        page_path, figs_dir = base / "density.md", base / "figures"
    else:
        page_path, figs_dir = PAGE, FIGS
    figs_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.time()

    def log(s: str) -> None:
        print(f"[{time.time() - t0:6.0f} s] {s}", flush=True)

    model = dpc.load(MODEL, threads=1)
    model.generate_density(ramp().float32(), 256, 0)  # warm-up
    results = {m: {} for m in cfg["counts"]}
    for m in cfg["counts"]:
        for field in fields():
            res = run_case(model, field, m, cfg, log)
            results[m][field.name] = res
            rows = res["rows"]
            for name in rows:
                r = rows[name]
                log(
                    f"{field.name:6s} m={m:6d} {name:6s} count "
                    + " ".join(f"{r['count'][k]:.3f}" for k in KS)
                    + f"  NN {r['nn'][0]:.3f} p1 {r['nn'][1]:.3f} (kept {r['nn'][2]:.2f})  E_low {r['elow']:.4f}"
                    f"  t {r['time']:.3f}"
                )
            log(f"{field.name:6s} m={m:6d} uniform E_low {res['uniform_elow']:.4f} t {res['uniform_time']:.3f}")
    figs = []
    photo_sets = {m: results[m]["photo"]["first"]["dpc"] for m in cfg["counts"]}
    figs.append(gallery(model, fields()[3], cfg["gallery"], photo_sets, figs_dir))
    m0 = min(cfg["counts"])
    for fname in ("ramp", "step", "photo"):
        field = {f.name: f for f in fields()}[fname]
        figs.append(side_by_side(field, results[m0][fname]["first"], m0, figs_dir))
    for p in figs:
        log(f"figure {p} ({p.stat().st_size / 1024:.0f} KB)")
    text = page(results, cfg, command, time.time() - t0, figs, page_path.parent)
    page_path.write_text(text)
    print(text[text.index("## Goals") :])
    log(f"wrote {page_path}")


if __name__ == "__main__":
    main()
