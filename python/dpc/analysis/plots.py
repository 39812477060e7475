"""Plots of the analysis results: PNG, PDF or SVG (from the file's extension, plus any other
``formats`` asked for), every axis labelled, a legend wherever a curve needs a name. Uses
matplotlib's object API with the Agg canvas (no pyplot, so importing this module never changes
the user's backend). Every file is written atomically (``dpc._atomic``)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from .. import _atomic
from ..errors import InvalidArgumentError
from ._common import count_of
from .integration import IntegrationStudy
from .pcf import PCF
from .spectrum import RadialSpectrum, Spectrum1D, Spectrum2D

_DPI = 110
#: The formats a plot may be written in.
FORMATS = ("png", "pdf", "svg")

#: A reference curve: (label, nu, power), drawn dashed.
Reference = tuple[str, np.ndarray, np.ndarray]


def _save(fig: Figure, path, formats: Sequence[str] | None = None) -> Path:
    """Write ``path`` (format from its extension) and the same plot in every other format of
    ``formats`` beside it (same stem); returns ``path``."""
    p = Path(path)
    first = p.suffix.lstrip(".").lower() or "png"
    todo = [first] + [f for f in (formats or ()) if f != first]
    for fmt in todo:
        if fmt not in FORMATS:
            raise InvalidArgumentError(f"plot format {fmt!r}: choose from {', '.join(FORMATS)}")
        # layout="tight" figures: one draw, not two; SVG/PDF keep text as text
        _atomic.save_figure(
            fig,
            p.with_suffix("." + fmt),
            dpi=_DPI,
            format=fmt,
            metadata={"Creator": "dpc"} if fmt in ("pdf", "svg") else None,
        )
    return p


def written(path, formats: Sequence[str] | None = None) -> list[str]:
    """The file names a save_* call with these arguments writes (for messages)."""
    p = Path(path)
    first = p.suffix.lstrip(".").lower() or "png"
    return [p.with_suffix("." + f).name for f in [first] + [f for f in (formats or ()) if f != first]]


def save_points(
    path, points: np.ndarray, *, dims=(0, 1), title: str = "", formats: Sequence[str] | None = None
) -> Path:
    """Scatter plot of one set (m, n) in the subspace ``dims`` (a strip plot for 1-D)."""
    pts = np.asarray(points)
    fig = Figure(figsize=(4.4, 4.6) if pts.shape[1] >= 2 else (6.0, 1.6), layout="tight")
    ax = fig.subplots()
    size = float(np.clip(3000.0 / len(pts), 0.2, 8.0))
    if pts.shape[1] >= 2:
        ax.scatter(pts[:, dims[0]], pts[:, dims[1]], s=size, c="k", linewidths=0)
        ax.set_aspect("equal")
        ax.set_ylim(0, 1)
        ax.set_ylabel(f"x{dims[1]}")
        ax.set_xlabel(f"x{dims[0]}")
    else:
        ax.eventplot(pts[:, 0], colors="k", linewidths=0.5)
        ax.set_yticks([])
        ax.set_xlabel("x0")
    ax.set_xlim(0, 1)
    ax.set_title(title or f"{len(pts)} points", fontsize=10)
    return _save(fig, path, formats)


def save_spectrum2d(path, spec: Spectrum2D, *, title: str = "", formats: Sequence[str] | None = None) -> Path:
    """Greyscale image of the mean 2-D power spectrum, axes in normalised frequency."""
    fig = Figure(figsize=(4.8, 4.4), layout="tight")
    ax = fig.subplots()
    ext = spec.nu_extent
    p = spec.power
    vmax = float(np.clip(np.percentile(p, 99.5), 2.0, 4.0))
    im = ax.imshow(
        p.T, origin="lower", cmap="gray", vmin=0.0, vmax=vmax, extent=(-ext, ext, -ext, ext), interpolation="nearest"
    )
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label="power P (white noise = 1)")
    ax.set_xlabel(rf"$\nu_{{{spec.dims[0]}}}$")
    ax.set_ylabel(rf"$\nu_{{{spec.dims[1]}}}$")
    ax.set_title(title or f"power spectrum, m={spec.n_points}, {count_of(spec.n_sets)}", fontsize=10)
    return _save(fig, path, formats)


def save_radial(
    path,
    curves: Sequence[tuple[str, RadialSpectrum]],
    *,
    title: str = "",
    anisotropy: bool = True,
    reference: Reference | Sequence[Reference] | None = None,
    nu_max: float = 4.0,
    formats: Sequence[str] | None = None,
) -> Path:
    """Radial mean power of each curve, with a legend; ``reference`` (one (label, nu, power)
    or a list of them: e.g. a model's target) is drawn dashed. With ``anisotropy`` the
    anisotropy of the curves (dB) goes in a second panel below, on its own labelled axis."""
    refs: list = []
    if reference is not None:
        refs = [reference] if isinstance(reference[0], str) else list(reference)
    aniso = anisotropy and any(np.any(np.isfinite(r.anisotropy_db)) for _, r in curves)
    fig = Figure(figsize=(6.4, 5.4 if aniso else 3.8), layout="tight")
    if aniso:
        ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[2.2, 1])
    else:
        ax, ax2 = fig.subplots(), None
    top = 2.0
    for label, r in curves:
        ax.plot(r.nu, r.mean, lw=1.2, label=label)
        sel = r.nu <= nu_max
        if np.any(sel):
            top = max(top, float(np.nanmax(r.mean[sel])) * 1.08)
    for k, (label, nu, power) in enumerate(refs):
        ax.plot(nu, power, "--", color="k" if k == 0 else f"C{len(curves) + k}", lw=1.0, label=label)
    ax.axhline(1.0, color="0.6", lw=0.6, label="white noise (P = 1)")
    ax.set_xlim(0, nu_max)
    ax.set_ylim(0, min(top, 8.0))
    ax.set_ylabel("radial mean power")
    ax.legend(fontsize=8, loc="best")
    ax.set_title(title, fontsize=10)
    xlabel = r"normalised frequency $\nu = |q| / m^{1/n}$"
    if ax2 is None:
        ax.set_xlabel(xlabel)
    else:
        lows = []
        for label, r in curves:
            ax2.plot(r.nu, r.anisotropy_db, lw=0.9, label=label)
            finite = r.anisotropy_db[np.isfinite(r.anisotropy_db)]
            if finite.size:
                lows.append(float(np.percentile(finite, 1)))
        ax2.axhline(0.0, color="0.6", lw=0.6)
        ax2.set_ylim(min(min(lows, default=-30.0) - 5.0, -25.0), 15.0)
        ax2.set_xlabel(xlabel)
        ax2.set_ylabel("anisotropy [dB]")
        ax2.legend(fontsize=8, loc="upper right")
    return _save(fig, path, formats)


def save_pcf(path, curves: Sequence[tuple[str, PCF]], *, title: str = "", formats: Sequence[str] | None = None) -> Path:
    """Pair correlation functions against r / d_max."""
    fig = Figure(figsize=(6.4, 3.8), layout="tight")
    ax = fig.subplots()
    top = 2.0
    for label, p in curves:
        ax.plot(p.r_norm, p.g, lw=1.2, label=label)
        top = max(top, float(np.nanmax(p.g)) * 1.08)
    ax.axhline(1.0, color="0.6", lw=0.6, label="Poisson (g = 1)")
    ax.set_xlim(0, max(float(p.r_norm[-1] + 0.5 * (p.r_norm[1] - p.r_norm[0])) for _, p in curves))
    ax.set_ylim(0, min(top, 6.0))
    ax.set_xlabel(r"distance $r / d_{max}$ (maximal packing distance)")
    ax.set_ylabel("pair correlation g(r)")
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=10)
    return _save(fig, path, formats)


def save_projections(
    path,
    curves: Sequence[tuple[str, Spectrum1D]],
    *,
    title: str = "",
    nu_max: float = 4.0,
    formats: Sequence[str] | None = None,
) -> Path:
    """1-D power spectra of projections on axes, against nu = q / m."""
    fig = Figure(figsize=(6.4, 3.6), layout="tight")
    ax = fig.subplots()
    top = 2.0
    for label, sp in curves:
        # Many frequencies: show a running mean over ~1/200 of the range to stay readable.
        w = max(1, sp.power.size // 200)
        kern = np.ones(w) / w
        y = np.convolve(sp.power, kern, mode="valid")
        x = np.convolve(sp.nu, kern, mode="valid")
        ax.plot(x, y, lw=1.0, label=label)
        top = max(top, float(np.nanmax(y)) * 1.08)
    ax.axhline(1.0, color="0.6", lw=0.6)
    ax.set_xlim(0, nu_max)
    ax.set_ylim(0, min(top, 8.0))
    ax.set_xlabel(r"normalised frequency $\nu = q / m$")
    ax.set_ylabel("power of the 1-D projection")
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=10)
    return _save(fig, path, formats)


def save_integration(path, study: IntegrationStudy, *, title: str = "", formats: Sequence[str] | None = None) -> Path:
    """Relative variance against point count, log-log, one panel per integrand family."""
    fams = study.families
    fig = Figure(figsize=(4.0 * len(fams), 3.8), layout="tight")
    axes = np.atleast_1d(fig.subplots(1, len(fams)))
    for ax, fam in zip(axes, fams):
        for name, values in study.rel_var[fam].items():
            ax.loglog(study.points[name], values, "o-", ms=3, lw=1.1, label=name)
        ax.set_title(fam, fontsize=10)
        ax.set_xlabel("points m")
        ax.grid(True, which="both", lw=0.3, color="0.85")
    axes[0].set_ylabel("relative variance")
    axes[-1].legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path, formats)


def save_series(
    path,
    series: dict[str, tuple[Sequence[float], Sequence[float]]],
    *,
    xlabel: str,
    ylabel: str,
    title: str = "",
    logx: bool = False,
    logy: bool = False,
    formats: Sequence[str] | None = None,
) -> Path:
    """Generic line plot of named (x, y) series."""
    fig = Figure(figsize=(6.0, 3.8), layout="tight")
    ax = fig.subplots()
    for label, (x, y) in series.items():
        ax.plot(x, y, "o-", ms=3, lw=1.1, label=label)
    if logx:
        ax.set_xscale("log")
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", lw=0.3, color="0.85")
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=10)
    return _save(fig, path, formats)
