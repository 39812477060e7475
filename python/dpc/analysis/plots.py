"""PNG plots of the analysis results. Uses matplotlib's object API with the Agg canvas (no
pyplot, so importing this module never changes the user's backend)."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from .integration import IntegrationStudy
from .pcf import PCF
from .spectrum import RadialSpectrum, Spectrum1D, Spectrum2D

_DPI = 110


def _save(fig: Figure, path) -> Path:
    p = Path(path)
    fig.savefig(p, dpi=_DPI)  # layout="tight" figures: one draw, not two
    return p


def save_points(path, points: np.ndarray, *, dims=(0, 1), title: str = "") -> Path:
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
    return _save(fig, path)


def save_spectrum2d(path, spec: Spectrum2D, *, title: str = "") -> Path:
    """Greyscale image of the mean 2-D power spectrum, axes in normalised frequency."""
    fig = Figure(figsize=(4.8, 4.4), layout="tight")
    ax = fig.subplots()
    ext = spec.nu_extent
    p = spec.power
    vmax = float(np.clip(np.percentile(p, 99.5), 2.0, 4.0))
    im = ax.imshow(p.T, origin="lower", cmap="gray", vmin=0.0, vmax=vmax,
                   extent=(-ext, ext, -ext, ext), interpolation="nearest")
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label="P")
    ax.set_xlabel(r"$\nu_{%d}$" % spec.dims[0])
    ax.set_ylabel(r"$\nu_{%d}$" % spec.dims[1])
    ax.set_title(title or f"power spectrum, m={spec.n_points}, {spec.n_sets} sets", fontsize=10)
    return _save(fig, path)


def save_radial(path, curves: Sequence[tuple[str, RadialSpectrum]], *, title: str = "",
                anisotropy: bool = True,
                reference: tuple[str, np.ndarray, np.ndarray] | None = None,
                nu_max: float = 4.0) -> Path:
    """Radial mean power (left axis) and, for a single curve, its anisotropy in dB (right axis,
    grey). ``reference`` = (label, nu, power) is drawn dashed."""
    fig = Figure(figsize=(6.4, 3.8), layout="tight")
    ax = fig.subplots()
    top = 2.0
    for label, r in curves:
        ax.plot(r.nu, r.mean, lw=1.2, label=label)
        sel = r.nu <= nu_max
        if np.any(sel):
            top = max(top, float(np.nanmax(r.mean[sel])) * 1.08)
    if reference is not None:
        ax.plot(reference[1], reference[2], "--", color="k", lw=1.0, label=reference[0])
    ax.axhline(1.0, color="0.6", lw=0.6)
    ax.set_xlim(0, nu_max)
    ax.set_ylim(0, min(top, 8.0))
    ax.set_xlabel(r"normalised frequency $\nu = |q| / m^{1/n}$")
    ax.set_ylabel("radial mean power")
    if anisotropy and len(curves) == 1 and np.any(np.isfinite(curves[0][1].anisotropy_db)):
        ax2 = ax.twinx()
        r = curves[0][1]
        ax2.plot(r.nu, r.anisotropy_db, color="0.55", lw=0.8, label="anisotropy")
        ax2.set_ylabel("anisotropy [dB]", color="0.4")
        finite = r.anisotropy_db[np.isfinite(r.anisotropy_db)]
        lo = float(np.percentile(finite, 1)) if finite.size else -30.0
        ax2.set_ylim(min(lo - 5.0, -25.0), 15.0)
        ax2.tick_params(axis="y", colors="0.4")
    if len(curves) > 1 or reference is not None:
        ax.legend(fontsize=8, loc="upper left" if len(curves) < 5 else "best")
    ax.set_title(title, fontsize=10)
    return _save(fig, path)


def save_pcf(path, curves: Sequence[tuple[str, PCF]], *, title: str = "") -> Path:
    """Pair correlation functions against r / d_max."""
    fig = Figure(figsize=(6.4, 3.8), layout="tight")
    ax = fig.subplots()
    top = 2.0
    for label, p in curves:
        ax.plot(p.r_norm, p.g, lw=1.2, label=label)
        top = max(top, float(np.nanmax(p.g)) * 1.08)
    ax.axhline(1.0, color="0.6", lw=0.6)
    ax.set_xlim(0, max(float(p.r_norm[-1] + 0.5 * (p.r_norm[1] - p.r_norm[0])) for _, p in curves))
    ax.set_ylim(0, min(top, 6.0))
    ax.set_xlabel(r"$r / d_{max}$")
    ax.set_ylabel("pair correlation g(r)")
    if len(curves) > 1:
        ax.legend(fontsize=8)
    ax.set_title(title, fontsize=10)
    return _save(fig, path)


def save_projections(path, curves: Sequence[tuple[str, Spectrum1D]], *, title: str = "",
                     nu_max: float = 4.0) -> Path:
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
    ax.set_xlabel(r"$\nu = q / m$")
    ax.set_ylabel("power of the 1-D projection")
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=10)
    return _save(fig, path)


def save_integration(path, study: IntegrationStudy, *, title: str = "") -> Path:
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
    return _save(fig, path)


def save_series(path, series: dict[str, tuple[Sequence[float], Sequence[float]]], *,
                xlabel: str, ylabel: str, title: str = "", logx: bool = False,
                logy: bool = False) -> Path:
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
    return _save(fig, path)
