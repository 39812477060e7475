"""Measure every bundled model the way docs/reports/models.md reports it, next to its target and the
classics.

    python -m lab.models.model_cards              # all models: docs/reports/models.md, docs/reports/figures/models/*
    python -m lab.models.model_cards bnot-2d ...  # only these cards (the page keeps the others)

Each card: 100 realisations at the model's trained point count (seeds 0..99; fewer where
stated), and the same metrics for the authors' BNOT sets, jitter and white noise. Conventions
(docs/analysis.md): P is m·|Σ e^{2πi q·x}|²/m², so white noise = 1; E_low(ν) = mean P over
0 < ν' < ν; radial rings b ≤ |q| < b + 1, ν = |q| / m^(1/n); anisotropy = mean over
0.5 ≤ ν ≤ 4 in dB; δ_min = minimum toroidal distance / maximal packing distance (mean over sets /
worst set); **rel. L1** = Σ|P − T| / Σ T over the target's rings in the stated ν range (the
L1 distance relative to the target's own L1 norm: defined for targets that are 0 on a band).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import dpc  # noqa: E402
from dpc import analysis, baselines  # noqa: E402
from dpc.analysis import plots  # noqa: E402
from lab.common import REPORTS, ROOT  # noqa: E402

FIGURES = REPORTS / "figures" / "models"
PAGE = REPORTS / "models.md"
SETS = 100
AXES = "xyzw"
PREVIOUS = " (previous)"  # a model name with this suffix: the file it replaced, models/previous/NAME.onnx


def load_model(name: str, **kw):
    """A bundled model, or with the PREVIOUS suffix the file it replaced (kept for comparison)."""
    if name.endswith(PREVIOUS):
        return dpc.load(ROOT / "models" / "previous" / f"{name.removesuffix(PREVIOUS)}.onnx", **kw)
    return dpc.load(name, **kw)


# ---- targets --------------------------------------------------------------------------------


@dataclass
class Target:
    """A radial target: ring radii b (b <= |q| < b + 1) and the mean power there."""

    label: str
    radius: np.ndarray
    power: np.ndarray
    n_points: int
    dims: int
    note: str = ""  # appended to the card's "Target:" sentence (not to plot legends)

    @property
    def nu(self) -> np.ndarray:
        return self.radius / self.n_points ** (1.0 / self.dims)


def _spectra_dir() -> Path:
    from importlib import resources

    return Path(str(resources.files("dpc") / "data" / "deepsampling" / "spectra"))


def _ring_mean(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ring means of a centred 2-D spectrum, rings b = 1 .. K (DC ring dropped)."""
    K = P.shape[0] // 2
    q = np.arange(-K, K + 1)
    b = np.floor(np.hypot(q[:, None], q[None, :]) + 1e-9).astype(int).ravel()
    ok = b <= K
    s = np.bincount(b[ok], P.ravel()[ok], minlength=K + 1)
    c = np.bincount(b[ok], minlength=K + 1)
    return np.arange(1, K + 1, dtype=np.float64), s[1:] / c[1:]


def bnot_target(m: int, k: int) -> Target:
    """The authors' k-D BNOT radial target for m points; their n-D files stop at 1,024 points,
    so a larger m (blue-10d's 8,192) is compared with the 1,024-point file in ν. A file that repeats
    a lower-dimensional one (the 5-D and 10-D files: `dpc.analysis.reference_spectrum_copies`) says so
    in its label."""
    t = target("bnot", min(m, 1024), k)
    if any(c.source_dims == 2 for c in analysis.reference_copied_from("bnot", min(m, 1024), k)):
        t.label = "bnot (authors' file = their 2-D BNOT spectrum in ν)"
        t.note = (
            "; that file repeats their 2-D spectrum bit for bit "
            "([high-dimensions.md](high-dimensions.md#the-authors-n-d-bnot-targets))"
        )
    return t


def target(key: str, m: int, k: int) -> Target:
    """`bnot`, `step`, `staircase` (the authors' radial files), `jitter` (exact 2-D radial mean of
    1 − sinc²(q_x/N) sinc²(q_y/N)), `green`, `pink` (ring means of the authors' 2-D spectra)."""
    if key == "jitter" and k == 2:
        N = math.isqrt(m)
        K = 4 * N
        s = np.sinc(np.arange(-K, K + 1) / N) ** 2
        r, p = _ring_mean(1.0 - s[:, None] * s[None, :])
        return Target("jitter (exact)", r, p, m, 2)
    if key in ("green", "pink"):
        a = np.load(_spectra_dir() / f"{key}-powspec-d2-n{m}.npy").astype(np.float64)
        c = a.shape[0] // 2
        K = c - 1
        r, p = _ring_mean(a[c - K : c + K + 1, c - K : c + K + 1])
        return Target(f"{key} noise (authors' 2-D spectrum, ring means)", r, p, m, 2)
    ref = analysis.reference_radial_spectrum(key, m, k)
    return Target(f"{key} (authors' file)", ref.radius, ref.power, m, k)


def rel_l1(r, t: Target, nu_range: tuple[float, float]) -> float:
    """Σ|P − T| / Σ T over the target's rings with nu in nu_range (P interpolated there)."""
    sel = (t.nu >= nu_range[0]) & (t.nu <= nu_range[1])
    ok = r.samples > 0
    p = np.interp(t.nu[sel], r.nu[ok], r.mean[ok])
    return float(np.sum(np.abs(p - t.power[sel])) / np.sum(t.power[sel]))


def elow_text(r, nu: float) -> str:
    """E_low(nu) of a radial spectrum as table text, or a dash where no integer frequency lies
    below nu (10-D at m = 1,024: the lowest, |q| = 1, is nu = m^(-1/10) = 0.5)."""
    try:
        return f"{r.low_frequency_energy(nu):.4f}"
    except dpc.InvalidArgumentError:
        return "—"


def cancel_coefficients(x: np.ndarray, q: np.ndarray, steps: int = 3) -> np.ndarray:
    """One set x (m, n) after the output balance's Newton steps (docs/model-format.md §5.1), in
    float64, on any frequencies q (F, n; one of each +-q pair) instead of the full-space ball: the
    reports' studies of cancelling a projection's or an axis's coefficients outright."""
    w = 1.0 / (np.pi * (q * q).sum(axis=1) * len(x))
    for _ in range(steps):
        e = np.exp(-2j * np.pi * (x @ q.T))
        x = (x + (w * (e.sum(axis=0) * np.conj(e)).imag) @ q) % 1.0
    return x


# ---- cards ----------------------------------------------------------------------------------


@dataclass
class Card:
    kind: str  # plane | nd | subspaces | dither | integrand | mask
    targets: dict = field(default_factory=dict)  # subspace axes -> target key
    nu_range: tuple = (0.25, 3.0)
    scales: bool = False  # the point-count study
    integrand: str = ""
    full: str = ""  # subspaces: target key of the full space, if trained


CARDS = {
    "bnot-2d": Card("plane", {"xy": "bnot"}, scales=True),
    "bnot-2d-wide": Card("plane", {"xy": "bnot"}, scales=True),
    "bnot-2d-stratified": Card("plane", {"xy": "bnot"}, scales=True),
    "blue-2d": Card("plane", {"xy": "bnot"}, scales=True),  # aims below BNOT: docs/reports/beyond-bnot.md
    "progressive-2d": Card("plane", {"xy": "bnot"}, scales=True),  # prefixes: docs/progressive.md
    "progressive-2d-balanced": Card("plane", {"xy": "bnot"}, scales=True),
    "progressive-2d-relaxed": Card("plane", {"xy": "bnot"}, scales=True),
    "repulsion-2d": Card("plane", {"xy": "bnot"}),
    "jitter-2d": Card("plane", {"xy": "jitter"}),
    "step-2d": Card("plane", {"xy": "step"}),
    "stair-2d": Card("plane", {"xy": "staircase"}),
    "green-2d": Card("plane", {"xy": "green"}, nu_range=(0.25, 1.9)),
    "pink-2d": Card("plane", {"xy": "pink"}, nu_range=(0.25, 1.9)),
    "font-2d": Card("integrand", {"xy": "bnot"}, integrand="font"),
    "bnot-3d": Card("nd", {"xyz": "bnot"}),
    "bnot-4d": Card("nd", {"xyzw": "bnot"}),
    "bnot-5d": Card("nd", {"all": "bnot"}),
    "bnot-10d": Card("nd", {"all": "bnot"}),
    "blue-10d": Card("nd", {"all": "bnot"}),  # m = 8,192: the 1,024-point target in ν (docs/reports/high-dimensions.md)
    "projective-3d": Card("subspaces", {"xy": "bnot", "xz": "bnot", "yz": "bnot"}, full="bnot"),
    "projective-4d": Card("subspaces", {p: "bnot" for p in ("xy", "xz", "xw", "yz", "yw", "zw")}),
    "mixed-3d": Card("subspaces", {"xy": "step", "xz": "jitter", "yz": "bnot"}),
    "dither-32": Card("dither"),
    "mask-64": Card("mask"),
    "mask-vector-64": Card("mask"),
    "mask-st-32x16": Card("mask"),
}


def axes_of(spec: str, n: int) -> tuple[int, ...]:
    return tuple(range(n)) if spec == "all" else tuple(AXES.index(c) for c in spec)


def plane_metrics(sets: np.ndarray, t: Target | None, nu_range, dims=(0, 1)) -> dict:
    r = analysis.radial_spectrum(sets, dims=dims, nu_max=4.0)
    peak, peak_nu = r.peak()
    band = (r.nu >= 0.5) & (r.nu <= 4.0) & (r.samples > 0)
    sub = np.ascontiguousarray(sets[:, :, list(dims)])
    md = analysis.min_distance(sub)
    return {
        "sets": len(sets),
        "elow50": r.low_frequency_energy(0.5),
        "elow75": r.low_frequency_energy(0.75),
        "peak": peak,
        "peak_nu": peak_nu,
        "aniso": float(np.mean(r.anisotropy_db[band])),
        "dmin_mean": md.mean_ratio,
        "dmin_min": md.min_ratio,
        "radial": r,
        "l1": rel_l1(r, t, nu_range) if t is not None else float("nan"),
    }


PLANE_HEADER = [
    "| point sets | sets | E_low ν<0.5 | E_low ν<0.75 | peak | anisotropy (dB) | "
    "δ_min mean / worst | rel. L1 to target |",
    "|---|---:|---:|---:|---|---:|---|---:|",
]


def plane_row(name: str, m: dict) -> str:
    return (
        f"| {name} | {m['sets']} | {m['elow50']:.4f} | {m['elow75']:.4f} | {m['peak']:.2f} "
        f"(ν = {m['peak_nu']:.2f}) | {m['aniso']:.2f} | {m['dmin_mean']:.3f} / "
        f"{m['dmin_min']:.3f} | {m['l1']:.3f} |"
    )


_CLASSICS: dict = {}


def classic_sets(name: str, m: int, n: int) -> np.ndarray:
    key = (name, m, n)
    if key not in _CLASSICS:
        if name == "bnot":
            _CLASSICS[key] = baselines.reference_sets("bnot", m, n)
        else:
            _CLASSICS[key] = baselines.generate(name, m, n, count=SETS, seed=0)
    return _CLASSICS[key]


def radial_plot(path: Path, curves, t: Target | None, title: str, xmax: float = 4.0, ymax: float | None = None) -> None:
    fig, ax = plt.subplots(figsize=(7, 3.4))
    if t is not None:
        ax.plot(t.nu, t.power, color="k", lw=1.4, label=f"target: {t.label}")
    for label, r, style in curves:
        ok = r.samples > 0
        ax.plot(r.nu[ok], r.mean[ok], style, lw=1.1, label=label)
    top = ymax if ymax is not None else max(3.6, 1.1 * max(float(np.max(c[1].mean)) for c in curves))
    ax.set(xlim=(0, xmax), ylim=(0, top), xlabel="ν = |q| / m^(1/n)", ylabel="radial mean of P", title=title)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def model_header(name: str, model) -> list[str]:
    path = dpc.model_path(name)
    sha = hashlib.sha256(path.read_bytes()).hexdigest()
    meta = model.metadata
    out = [
        f"## {name}",
        "",
        meta.get("dpc.description", ""),
        "",
        f"- file: `models/{path.name}` ({path.stat().st_size:,} bytes), sha256 `{sha}`",
        f"- {model.dims}-D, trained point count {model.n_points:,}, {model.layers} layers"
        + (f", gridded axes {list(model.grid_axes)}" if model.grid_axes else "")
        + (
            f", {model.input} input points (metadata `dpc.input`; libdpc's default input, AUTO, feeds it these)"
            if model.input != "uniform"
            else ""
        ),
    ]
    if model.balance:
        out.append(
            f"- output balanced at the frequencies 0 < |q| ≤ {model.balance} (metadata `dpc.balance`, "
            "docs/model-format.md §5.1): "
            + (
                "the last step of every level, only the level's own points moving (§6)"
                if model.order == "progressive"
                else "the generator's last step, after the cascade"
            )
        )
    if "dpc.train.steps" not in meta:
        out.append(f"- made by: `python {meta.get('dpc.source', '?')}` (hand-designed, not trained)")
        return out
    cfg = json.loads(meta.get("dpc.config", "{}")).get("train", {})
    out += [
        f"- trained by: `python training/train.py --config training/configs/{name}.toml`, then "
        f"`python training/export.py runs/{name}/checkpoint.pt -o models/{name}.onnx`",
        f"- training: {meta['dpc.train.steps']} steps, batch {cfg.get('batch', '?')}, "
        f"{float(meta.get('dpc.train.wall_time_s', 'nan')):.0f} s of step time "
        f"(impl {cfg.get('impl', 'torch')}, {cfg.get('threads', 1)} thread(s), torch "
        f"{meta.get('dpc.train.torch', '?')})",
    ]
    if "dpc.loss" in meta:
        # the doc tests evaluate each loss on the model's own sets (tests/python/test_docs_commands.py)
        out += ["- loss:", "", f"<!-- doc-test: loss {name} -->", "```python", meta["dpc.loss"].strip(), "```"]
    return out


# ---- card kinds -----------------------------------------------------------------------------


def card_plane(name: str, card: Card, model) -> list[str]:
    m = model.n_points
    ((axes, key),) = card.targets.items()
    t = target(key, m, 2)
    sets = model.generate_batch(SETS, seed=0)
    mm = plane_metrics(sets, t, card.nu_range)
    rows = [plane_row(f"**{name}** (m = {m:,})", mm)]
    classics = {}
    for label, cname in [("authors' BNOT sets", "bnot"), ("jitter", "jitter"), ("white noise", "white")]:
        classics[label] = plane_metrics(classic_sets(cname, m, 2), t, card.nu_range)
        rows.append(plane_row(label, classics[label]))
    fig = FIGURES / f"{name}-radial.png"
    radial_plot(
        fig,
        [
            (f"{name} ({SETS} sets)", mm["radial"], "-"),
            ("authors' BNOT sets", classics["authors' BNOT sets"]["radial"], ":"),
            ("jitter", classics["jitter"]["radial"], "--"),
        ],
        t,
        f"{name}: radial power spectrum",
    )
    pts = FIGURES / f"{name}-points.png"
    plots.save_points(pts, sets[0], title=f"{name}, seed 0")
    lo, hi = card.nu_range
    out = [
        "",
        f"Target: {t.label}; rel. L1 over {lo:g} ≤ ν ≤ {hi:g}.",
        "",
        *PLANE_HEADER,
        *rows,
        "",
        f"![radial spectrum of {name}](figures/models/{fig.name}) ![points of {name}](figures/models/{pts.name})",
        "",
    ]
    if card.scales:
        out += scale_section(name, model, t)
    print("\n".join(rows))
    return out


LOWEST_Q = np.array([[1, 0], [0, 1], [1, 1], [1, -1]])
SCALES = [(0.25, 100), (1, 100), (4, 40), (16, 10), (64, 4)]  # (point-count factor, sets)


def scale_section(name: str, model, t: Target) -> list[str]:
    """E_low, the power at the torus-scale frequencies and the radial spectrum at m/4 ... 64m
    with the scale-aware radius (the paper's Fig. 17 went to 2m)."""
    rows = [
        "| points | sets | E_low ν<0.5 | E_low ν<0.75 | ratio to m (ν<0.5) | mean P at the lowest frequencies |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    curves, base = [], None
    for factor, count in SCALES:
        mp = int(model.n_points * factor)
        sets = model.generate_batch(count, seed=0, n_points=mp)
        r = analysis.radial_spectrum(sets, nu_max=4.0 if mp <= 16384 else 1.5)
        # E_low from every integer frequency (stride 1), whatever the plot's grid stride
        s_low = analysis.power_spectrum_2d(sets, nu_max=0.75, max_size=1025)
        assert s_low.stride == 1
        low = float(np.mean(analysis.power_spectrum_direct(sets, LOWEST_Q)))
        e50 = s_low.low_frequency_energy(0.5)
        if factor == 1:
            base = e50
        rows.append((mp, factor, count, e50, s_low.low_frequency_energy(0.75), low))
        curves.append((f"{mp:,} points ({factor:g} m, {count} sets)", r, "-"))
    fig = FIGURES / f"{name}-scales.png"
    radial_plot(fig, curves, t, f"{name} at other point counts (trained at m = {model.n_points:,})")
    table = rows[:2] + [
        f"| {mp:,} ({f:g} m) | {c} | {e50:.4f} | {e75:.4f} | {e50 / base:.2f} | {low:.4f} |"
        for mp, f, c, e50, e75, low in rows[2:]
    ]
    return [
        "### Other point counts",
        "",
        'Scale-aware radius; "lowest frequencies" = q in {(1,0), (0,1), (1,1), (1,−1)}, white '
        "noise = 1. At 64 m the spectrum is measured to ν = 1.5.",
        "",
        *table,
        "",
        f"![{name} at other point counts](figures/models/{fig.name})",
        "",
        torus_scale_note(model),
        "",
    ]


def torus_scale_note(model) -> str:
    """Why the point-count table's last column (the torus-scale power) is what it is."""
    if model.order == "progressive" and model.balance:
        return (
            "Each level of this progressive model ends with the balance of its prefix (model-format.md "
            "§5.1, §6), so the last column is 0 at every m, at the price of low-band energy above the "
            'balanced frequencies (docs/reports/progressive.md, "Balanced levels").'
        )
    if model.order == "progressive" and model.relax:
        return (
            "After its levels this progressive model relaxes every prefix jointly (model-format.md §6.1), "
            "with a term that cancels each prefix's power at 0 < |q| <= min(8, sqrt(n)/4): the last "
            'column stays near 0 at every m (docs/reports/progressive.md, "Jointly relaxed prefixes").'
        )
    if model.order == "progressive":
        return (
            "A progressive model's levels hold their earlier points in place, so whatever imbalance a "
            "level's insertion leaves at the torus scale stays in every larger set: the last column "
            "keeps a small power that the stratified input of a set model would not leave "
            "(bnot-2d-stratified: at most 0.0008; docs/reports/progressive.md)."
        )
    if model.input == "uniform":
        return (
            "A cascade of local filters moves each point a bounded distance per layer, so density "
            "fluctuations on scales far beyond the receptive field relax slowly: E_low stays within "
            "a small factor of its trained value, but the torus-scale frequencies (last column) keep "
            "more and more of their white-noise power as m grows."
        )
    if model.balance:
        return (
            "The input points are stratified (one per grid cell) and the output balanced at the "
            "torus-scale frequencies (model-format.md §5.1): the last column is 0 at every m."
        )
    return (
        "The input points are stratified (one per grid cell), so there are no large-scale density "
        "fluctuations for the local filters to leave behind: the torus-scale frequencies (last "
        "column) stay near 0 at every m."
    )


def card_nd(name: str, card: Card, model) -> list[str]:
    m, n = model.n_points, model.dims
    t = bnot_target(m, n)
    sets = model.generate_batch(SETS, seed=0)
    rows = [
        "| point sets | sets | E_low ν<0.5 | E_low ν<0.75 | peak | δ_min mean / worst | rel. L1 to target |",
        "|---|---:|---:|---:|---|---|---:|",
    ]
    curves = []
    others = [("white noise", classic_sets("white", m, n))]
    if n <= 5:  # toroidal dart throwing: the delta_min to reach (the high-dimensional goals); slow beyond 5-D
        others.insert(0, ("relaxed dart throwing", classic_sets("dart-throwing", m, n)))
    if round(m ** (1.0 / n)) ** n == m:  # jitter needs m = k^n strata
        others.insert(0, ("jitter", classic_sets("jitter", m, n)))
    for label, s in [(f"**{name}**", sets)] + others:
        r = analysis.radial_spectrum(s, nu_max=4.0, directions=128)
        peak, pnu = r.peak()
        md = analysis.min_distance(s)
        rows.append(
            f"| {label} | {len(s)} | {elow_text(r, 0.5)} | "
            f"{elow_text(r, 0.75)} | {peak:.2f} (ν = {pnu:.2f}) | "
            f"{md.mean_ratio:.3f} / {md.min_ratio:.3f} | {rel_l1(r, t, (0.25, 3.0)):.3f} |"
        )
        curves.append((label.strip("*"), r, "-" if label.startswith("**") else ":"))
    fig = FIGURES / f"{name}-radial.png"
    radial_plot(fig, curves, t, f"{name}: radial power spectrum (Monte Carlo, 128 frequencies per ring)")
    print("\n".join(rows))
    return [
        "",
        f"Target: {t.label}"
        + (f" (the authors' file for {t.n_points:,} points, compared in ν)" if t.n_points != m else "")
        + t.note
        + ". Radial spectra by Monte Carlo over 128 integer frequencies per "
        "ring (`dpc.analysis.radial_spectrum_mc`); rel. L1 over 0.25 ≤ ν ≤ 3."
        + (
            f" —: no integer frequency lies below that ν at m = {m:,} in {n}-D (the lowest, "
            f"|q| = 1, is ν = {m ** (-1.0 / n):.2f})."
            if m ** (-1.0 / n) >= 0.5
            else ""
        ),
        "",
        *rows,
        "",
        f"![radial spectrum of {name}](figures/models/{fig.name})",
        "",
    ]


def card_subspaces(name: str, card: Card, model) -> list[str]:
    m, n = model.n_points, model.dims
    sets = model.generate_batch(SETS, seed=0)
    rows = [
        "| subspace | target | E_low ν<0.5 | E_low ν<0.75 | peak | anisotropy (dB) | δ_min mean / worst | rel. L1 to "
        "target |",
        "|---|---|---:|---:|---|---:|---|---:|",
    ]
    cols = min(3, len(card.targets))
    lines = -(-len(card.targets) // cols)
    fig, axs = plt.subplots(lines, cols, figsize=(4.2 * cols, 3.3 * lines), squeeze=False)
    plane_elow = []  # E_low nu<0.5 of each projection, for the comparison table
    for ax, (axes, key) in zip(axs.ravel(), card.targets.items()):
        d = axes_of(axes, n)
        t = target(key, m, 2)
        mm = plane_metrics(sets, t, card.nu_range, dims=d)
        plane_elow.append(mm["elow50"])
        rows.append(
            f"| {axes} | {t.label} | {mm['elow50']:.4f} | {mm['elow75']:.4f} | "
            f"{mm['peak']:.2f} (ν = {mm['peak_nu']:.2f}) | {mm['aniso']:.2f} | "
            f"{mm['dmin_mean']:.3f} / {mm['dmin_min']:.3f} | {mm['l1']:.3f} |"
        )
        r = mm["radial"]
        ok = r.samples > 0
        ax.plot(t.nu, t.power, color="tab:orange", lw=1.6, label="target")
        ax.plot(r.nu[ok], r.mean[ok], lw=1.1, label=f"{name} ({SETS} sets)")
        ax.set(xlim=(0, 4), ylim=(0, 3.6), title=f"{axes}: {key}", xlabel="ν")
        ax.legend(fontsize=7)
    space = AXES[:n]
    full = analysis.radial_spectrum(sets, nu_max=4.0, directions=128)
    if card.full:
        t = target(card.full, m, n)
        (peak, peak_nu), md = full.peak(), analysis.min_distance(sets)
        rows.append(
            f"| {space} ({n}-D) | {t.label} | {elow_text(full, 0.5)} | {elow_text(full, 0.75)} | "
            f"{peak:.2f} (ν = {peak_nu:.2f}) | — | {md.mean_ratio:.3f} / {md.min_ratio:.3f} | "
            f"{rel_l1(full, t, (0.25, 3.0)):.3f} |"
        )
    else:
        rows.append(
            f"| {space} ({n}-D, not trained) | — | {elow_text(full, 0.5)} | {elow_text(full, 0.75)} | — | — | — | — |"
        )
    fig.tight_layout()
    path = FIGURES / f"{name}-subspaces.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print("\n".join(rows))
    out = [
        "",
        "Each trained 2-D projection against its target (rel. L1 over 0.25 ≤ ν ≤ 3), and "
        f"the full {n}-D spectrum (Monte Carlo, 128 frequencies per ring"
        + (f", against the {n}-D target)." if card.full else "; no loss term constrains it)."),
        "",
        *rows,
        "",
        f"![subspace spectra of {name}](figures/models/{path.name})",
        "",
    ]
    if len(set(card.targets.values())) == 1:  # one target in every projection: compare with the classics
        planes = [axes_of(a, n) for a in card.targets]
        out += subspace_comparison(name, sets, planes, n, (plane_elow, elow_text(full, 0.5)))
    return out


def subspace_comparison(name: str, sets: np.ndarray, planes: list, n: int, measured: tuple) -> list[str]:
    """E_low ν<0.5 of the projections (mean, worst) and of the full space, against classic sets;
    `measured` = (the model's per-projection E_low, its full-space E_low text), already computed."""
    m = sets.shape[1]
    rows = [
        f"| point sets | sets | projections: E_low ν<0.5 mean | worst projection | {n}-D: E_low ν<0.5 |",
        "|---|---:|---:|---:|---:|",
    ]

    def row(label: str, count: int, e: list, full_text: str) -> str:
        return f"| {label} | {count} | {np.mean(e):.4f} | {np.max(e):.4f} | {full_text} |"

    rows.append(row(f"**{name}**", len(sets), *measured))
    others = [(b, classic_sets(b, m, n)) for b in ("sobol", "halton", "white")]
    iso = f"bnot-{n}d"  # dpc's isotropic model of that dimension: blue in n-D, not in projections
    if iso in dpc.available_models():
        others.insert(0, (iso, dpc.load(iso, threads=0, backend="cpu").generate_batch(len(sets), seed=0)))
    for label, s in others:
        e = [analysis.radial_spectrum(s, dims=d, nu_max=1.0).low_frequency_energy(0.5) for d in planes]
        rows.append(row(label, len(s), e, elow_text(analysis.radial_spectrum(s, nu_max=1.0, directions=128), 0.5)))
    print("\n".join(rows))
    return [
        f"The same measures for dpc's isotropic {n}-D model and classic point sets (Owen-scrambled "
        "Sobol', scrambled Halton, white noise; `dpc.baselines`):",
        "",
        *rows,
        "",
    ]


def card_integrand(name: str, card: Card, model) -> list[str]:
    from dpc.analysis import integrand_spectra as IS

    m = model.n_points
    F = IS.integrand_spectrum(card.integrand)
    fam = IS.random_phase_family(card.integrand, count=100, seed=0)
    rows = [
        "| point sets | sets | Eq. 5 variance (white = 1) | measured MC squared error / white noise's (100 "
        "random-phase integrands) |",
        "|---|---:|---:|---:|",
    ]
    sets = {
        f"**{name}**": model.generate_batch(SETS, seed=0),
        "authors' BNOT sets": classic_sets("bnot", m, 2),
        "bnot-2d (dpc)": dpc.load("bnot-2d", backend="cpu").generate_batch(SETS, seed=0),
        "bnot-2d-wide (dpc)": dpc.load("bnot-2d-wide", backend="cpu").generate_batch(SETS, seed=0),
        "jitter": classic_sets("jitter", m, 2),
        "white noise": classic_sets("white", m, 2),
    }
    white = IS.mc_error(sets["white noise"], fam)
    for label, s in sets.items():
        err, se = IS.mc_error(s, fam, with_se=True)
        rows.append(f"| {label} | {len(s)} | {IS.eq5_variance(s, F):.4f} | {err / white:.4f} ± {se / white:.4f} |")
    path = FIGURES / f"{name}-radial.png"
    r_model = analysis.radial_spectrum(sets[f"**{name}**"], nu_max=4.0)
    r_bnot = analysis.radial_spectrum(sets["authors' BNOT sets"], nu_max=4.0)
    radial_plot(
        path, [(f"{name}", r_model, "-"), ("authors' BNOT sets", r_bnot, ":")], None, f"{name}: radial power spectrum"
    )
    print("\n".join(rows))
    return [
        "",
        f"Integrand family: the authors' mean {card.integrand} power spectrum F "
        "(`integrand-spectra/`, normalised to sum 1). Eq. 5 = Σ_q F(q)·E[P(q)]; the measured "
        "column integrates 100 random-phase integrands f = Re Σ_q √F(q) e^{i(2π q·x + φ_q)} "
        "(expected power F, integral 0) with every set (`dpc.analysis.integrand_spectra`) and "
        "divides the mean squared error of the estimates by white noise's (± one standard "
        "error over integrands × sets; the authors ship only 10 BNOT sets).",
        "",
        *rows,
        "",
        f"![radial spectrum of {name}](figures/models/{path.name})",
        "",
    ]


def card_dither(name: str, card: Card, model) -> list[str]:
    from dpc.analysis import dither as D

    masks = {
        f"**{name}**": np.stack([D.model_mask(model, seed=s) for s in range(SETS)]),
        "white-noise mask": np.random.default_rng(0).random((SETS, 32, 32)),
        "Bayer 32 × 32 (ordered)": D.bayer(32)[None],
    }
    rows = [
        "| mask | masks | mask spectrum E_low (|q| ≤ 6) | thresholded patterns E_low (|q| ≤ 6), mean over levels 1/8 "
        "… 7/8 | worst level | largest single-frequency power (mean over levels) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for label, ms in masks.items():
        q = D.mask_quality(ms)
        rows.append(
            f"| {label} | {len(ms)} | {q['mask_elow']:.4f} | {q['levels_elow_mean']:.4f} | "
            f"{q['levels_elow_max']:.4f} | {q['levels_peak_mean']:.1f} |"
        )
    mask = masks[f"**{name}**"][0]
    path = FIGURES / f"{name}-mask.png"
    D.save_mask_figure(path, mask)
    print("\n".join(rows))
    return [
        "",
        "Quality of the mask as a threshold map (`dpc.analysis.dither`): the power "
        "spectrum of the rank-normalised mask and of the binary patterns it gives for constant "
        "greys 1/8 … 7/8, as mean power over 0 < |q| ≤ 6 (of 16 = Nyquist), white-noise "
        "mask = 1.",
        "",
        *rows,
        "",
        f"![{name}: mask, its spectrum and thresholded patterns](figures/models/{path.name})",
        "",
    ]


def card_mask(name: str, card: Card, model) -> list[str]:
    """Mask models (scalar, vector, spatiotemporal): dpc.analysis.masks numbers next to
    void-and-cluster (STBN for spatiotemporal) and white noise at the trained size, 8 masks
    (4 volumes) each; docs/reports/masks.md has the full comparison (python -m lab.masks.mask_report)."""
    from dpc import masks as M
    from dpc.analysis import masks as AM

    kind = M.mask_kind(model)
    n = model.grid_shape[0]
    if kind == "scalar":
        rows = [
            "| mask | masks | mask E_low | thresholded 1/8 … 7/8: mean | worst level |",
            "|---|---:|---:|---:|---:|",
        ]
        for label, fn in (
            (f"**{name}**", lambda s: M.mask(name, seed=s)),
            ("void-and-cluster", lambda s: baselines.void_and_cluster(n, s)),
            ("white noise", lambda s: baselines.white_mask((n, n), s)),
        ):
            q = AM.scalar_quality(np.stack([fn(s) for s in range(8)]))
            rows.append(
                f"| {label} | 8 | {q['mask_elow']:.5f} | {q['levels_elow_mean']:.4f} | {q['levels_elow_max']:.4f} |"
            )
    elif kind == "vector":
        rows = [
            "| mask | masks | per channel: mask E_low | per channel: thresholded mean | "
            "joint boxes: mean | joint boxes: worst |",
            "|---|---:|---:|---:|---:|---:|",
        ]
        for label, fn in (
            (f"**{name}**", lambda s: M.mask(name, seed=s)),
            ("void-and-cluster × 2", lambda s: baselines.vector_void_and_cluster(n, s)),
            ("white noise × 2", lambda s: baselines.white_mask((n, n, 2), s)),
        ):
            q = AM.vector_quality(np.stack([fn(s) for s in range(8)]))
            rows.append(
                f"| {label} | 8 | {q['mask_elow_max']:.5f} | {q['levels_elow_mean_max']:.4f} | "
                f"{q['joint_elow_mean']:.4f} | {q['joint_elow_max']:.4f} |"
            )
    else:
        t = model.grid_shape[2]
        rows = [
            "| mask | volumes | frames: mask E_low | frames: thresholded mean | temporal E_low | "
            "accumulated RMSE, all frames |",
            "|---|---:|---:|---:|---:|---:|",
        ]
        for label, fn in (
            (f"**{name}**", lambda s: M.mask(name, seed=s)),
            ("STBN (scalar)", lambda s: baselines.stbn_scalar(n, t, s)),
            ("white noise", lambda s: np.stack([baselines.white_mask((n, n), 1000 * s + k) for k in range(t)])),
        ):
            q = AM.spatiotemporal_quality(np.stack([fn(s) for s in range(4)]))
            rows.append(
                f"| {label} | 4 | {q['mask_elow_mean']:.5f} | {q['levels_elow_mean']:.4f} | "
                f"{q['temporal_elow']:.3f} | {q['accumulated_rmse'][-1]:.4f} |"
            )
    print("\n".join(rows))
    return [
        "",
        f"A {kind} threshold mask (`dpc mask -m {name}`); metrics of `dpc.analysis.masks` "
        "(white-noise mask = 1, low band 0 < |q| ≤ 6), seeds 0 … 7 (volumes 0 … 3). The full "
        "comparison, figures and other sizes: [masks.md](masks.md).",
        "",
        *rows,
        "",
    ]


KINDS = {
    "plane": card_plane,
    "nd": card_nd,
    "subspaces": card_subspaces,
    "integrand": card_integrand,
    "dither": card_dither,
    "mask": card_mask,
}


# ---- the page -------------------------------------------------------------------------------

INTRO = [
    "# Bundled models",
    "",
    "> Measurements, not the manual: made by `python -m lab.models.model_cards` (`... NAME` redoes "
    "one card); machine: not recorded on this page (each card's training line records its training "
    "run). The manual is [docs/](../architecture.md).",
    "",
    "This page and `docs/reports/figures/models/` are its output. "
    "Conventions: P = |Σ_k e^{2πi⟨q,x_k⟩}|²/m at integer q, white noise = 1; rings "
    "b ≤ |q| < b + 1; ν = |q|/m^(1/n); E_low(ν) = mean P over 0 < ν' < ν; anisotropy = mean "
    "over 0.5 ≤ ν ≤ 4 in dB (the isotropic floor of 100 sets is about −20 dB); δ_min = "
    "minimum toroidal distance / maximal packing distance (mean over sets / worst set); "
    "rel. L1 = Σ|P − T| / Σ T over the target's rings in the stated ν range.",
    "",
]
OUTRO = [
    "Reference data: the authors' targets, BNOT point sets and integrand spectra come from "
    "`sinbag/deepsampling` (BSD 3-Clause, `python/dpc/data/deepsampling/LICENSE`).",
    "",
]


def split_cards(text: str) -> dict[str, str]:
    parts = re.split(r"(?m)^## ", text)
    return {p.split("\n", 1)[0].strip(): "## " + p for p in parts[1:]}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", help="models to (re)measure (default: all bundled)")
    args = ap.parse_args(argv)
    FIGURES.mkdir(parents=True, exist_ok=True)
    bundled = dpc.available_models()
    unknown = [n for n in args.names if n not in bundled]
    if unknown:
        raise SystemExit(f"not bundled: {unknown}; bundled: {bundled}")
    old = split_cards(PAGE.read_text()) if PAGE.exists() and args.names else {}
    cards = {}
    for name in bundled:
        if args.names and name not in args.names:
            if name in old:
                cards[name] = old[name].rstrip().split("\nReference data:")[0].rstrip() + "\n"
            continue
        if name not in CARDS:
            print(f"(no card spec for {name}: skipped)")
            continue
        model = dpc.load(name, threads=0, backend="cpu")  # the CPU: the same bits on every machine
        card = CARDS[name]
        print(f"== {name}")
        body = model_header(name, model) + KINDS[card.kind](name, card, model)
        cards[name] = "\n".join(body).rstrip() + "\n"  # as a kept card: one blank line between cards
    order = [n for n in CARDS if n in cards]
    PAGE.write_text("\n".join(INTRO) + "\n" + "\n".join(cards[n] for n in order) + "\n" + "\n".join(OUTRO))
    print(f"wrote {PAGE}")


if __name__ == "__main__":
    main()
