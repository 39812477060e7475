"""One call that measures everything about a batch of point sets (what ``dpc analyze`` writes)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InvalidArgumentError
from ._common import MAX_PACKING_DIMS, as_sets, check_dims, max_packing_distance
from .discrepancy import METHODS, discrepancy_per_set
from .pcf import PCF, MinDistance, pair_statistics
from .spectrum import RadialSpectrum, Spectrum1D, Spectrum2D, power_spectrum_1d, power_spectrum_2d, radial_spectrum_mc

FORMAT_VERSION = 1
LOW_BANDS = (0.5, 0.75, 1.0)
CONVENTIONS = {
    "power": "P(q) = |sum_k exp(2 pi i <q, x_k>)|^2 / m at integer q (white noise = 1), "
    "DC removed, averaged over the sets",
    "nu": "nu = |q| / m^(1/n), n = dimension of the (sub)space analysed",
    "radial": "ring b holds b <= |q|/stride < b+1 and is reported at |q| = b*stride",
    "anisotropy": "10 log10(variance / mean^2) of the set-averaged P over a ring, in dB",
    "low_frequency_energy": "mean P over the frequencies with 0 < nu < band",
    "pcf": "toroidal distances; g = ordered pairs per shell / (sets m (m-1) shell volume); r also in units of d_max",
    "d_max": "maximal packing distance 2 (delta_n / m)^(1/n); 2-D: sqrt(2 / (sqrt(3) m))",
    "min_distance_ratio": "minimum toroidal distance / d_max, per set",
    "discrepancy": "D (not D^2) on the unit cube; CD/WD/MD/L2-star from scipy.stats.qmc, GL2 and UL2 closed forms",
}


@dataclass
class Analysis:
    """All measurements of one batch of sets; ``to_json()`` gives the metrics document."""

    label: str
    n_sets: int
    n_points: int
    dims: int
    spectrum: Spectrum2D | None = None
    radial: RadialSpectrum | None = None  # of the 2-D subspace (or the 1-D spectrum)
    radial_nd: RadialSpectrum | None = None  # full n-D, Monte Carlo, for n >= 3
    projections: list[Spectrum1D] = field(default_factory=list)
    pcf: PCF | None = None
    min_distance: MinDistance | None = None
    discrepancy: dict[str, float] = field(default_factory=dict)
    discrepancy_sets: int = 0
    notes: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    options: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """The headline numbers (one row of ``dpc compare``)."""
        out = {"label": self.label, "sets": self.n_sets, "points": self.n_points, "dims": self.dims}
        if self.radial is not None:
            for band in LOW_BANDS:
                out[f"E_low<{band:g}"] = _low(self, band)
            val, nu = self.radial.peak()
            out["peak"], out["peak_nu"] = val, nu
        if self.min_distance is not None:
            out["delta_min"] = self.min_distance.mean_ratio
        for k, v in self.discrepancy.items():
            out[k] = v
        return out

    def to_json(self) -> dict:
        doc: dict = {
            "dpc_analysis": FORMAT_VERSION,
            "label": self.label,
            "input": {"sets": self.n_sets, "points": self.n_points, "dims": self.dims},
            "options": self.options,
            "conventions": CONVENTIONS,
            "summary": _clean(self.summary()),
        }
        if self.spectrum is not None:
            sp = self.spectrum
            doc["spectrum_2d"] = {
                "dims": list(sp.dims),
                "stride": sp.stride,
                "grid_size": int(sp.freqs.size),
                "max_frequency": int(sp.freqs[-1]),
            }
        if self.radial is not None:
            doc["radial"] = _radial_json(self.radial, self)
        if self.radial_nd is not None:
            doc["radial_nd"] = _radial_json(self.radial_nd, None)
        if self.projections:
            doc["projections"] = [
                {
                    "dim": p.dim,
                    "stride": p.stride,
                    "low_frequency_energy": {str(b): _mean_below(p, b) for b in LOW_BANDS},
                    "nu": _list(p.nu),
                    "power": _list(p.power),
                }
                for p in self.projections
            ]
        if self.pcf is not None:
            doc["pcf"] = {
                "d_max": self.pcf.d_max,
                "r_over_dmax": _list(self.pcf.r_norm),
                "r": _list(self.pcf.r),
                "g": _list(self.pcf.g),
            }
        if self.min_distance is not None:
            md = self.min_distance
            doc["min_distance"] = {
                "d_max": md.d_max,
                "mean_ratio": md.mean_ratio,
                "min_ratio": md.min_ratio,
                "mean_distance": float(md.distances.mean()),
                "ratio_per_set": _list(md.ratios),
            }
        doc["discrepancy"] = {"sets": self.discrepancy_sets, **_clean(self.discrepancy)}
        doc["notes"] = self.notes
        doc["timings_s"] = {k: round(v, 4) for k, v in self.timings.items()}
        return doc


def _low(a: Analysis, band: float) -> float | None:
    try:
        if a.spectrum is not None:
            return a.spectrum.low_frequency_energy(band)
        return a.radial.low_frequency_energy(band)
    except InvalidArgumentError:
        return None


def _mean_below(p: Spectrum1D, band: float) -> float | None:
    sel = p.nu < band
    return float(p.power[sel].mean()) if np.any(sel) else None


def _radial_json(r: RadialSpectrum, owner: Analysis | None) -> dict:
    out = {
        "method": r.method,
        "dims": r.dims,
        "nu": _list(r.nu),
        "radius": _list(r.radius),
        "mean": _list(r.mean),
        "anisotropy_db": _list(r.anisotropy_db),
        "samples": [int(v) for v in r.samples],
    }
    if owner is None:
        out["low_frequency_energy"] = {}
        for b in LOW_BANDS:
            try:
                out["low_frequency_energy"][str(b)] = r.low_frequency_energy(b)
            except InvalidArgumentError:
                out["low_frequency_energy"][str(b)] = None
        val, nu = r.peak()
        out["peak"] = {"value": val, "nu": nu}
    return out


def _finite(v):
    return None if v is None or not math.isfinite(v) else float(v)


def _list(a) -> list:
    return [_finite(float(v)) for v in np.asarray(a, dtype=np.float64)]


def _clean(d: dict) -> dict:
    return {k: (_finite(v) if isinstance(v, (float, np.floating)) else v) for k, v in d.items()}


def analyze(
    points,
    *,
    label: str = "points",
    nu_max: float = 4.0,
    max_size: int = 513,
    dims=(0, 1),
    directions: int = 128,
    pcf_r_max: float = 2.5,
    pcf_bins: int = 100,
    discrepancies=METHODS,
    discrepancy_budget: float = 2.0**26,
    projections: bool = True,
    seed: int = 0,
    progress_bar: bool = False,
) -> Analysis:
    """Measure a batch of point sets by the conventions of docs/architecture.md ("Analysis conventions").

    2-D spectrum of the subspace ``dims`` (n >= 2), its radial mean and anisotropy; for n >= 3
    also the n-D Monte Carlo radial spectrum; 1-D spectra of every axis; PCF and minimum-distance
    ratio (n <= 10, where d_max is tabulated); discrepancies on as many sets as
    ``discrepancy_budget`` pair terms allow (all methods together; O(m^2) each), at least one
    set while one costs under 16 budgets."""
    sets = as_sets(points, min_points=2)
    s_count, m, n = sets.shape
    res = Analysis(label=label, n_sets=s_count, n_points=m, dims=n)
    res.options = {
        "nu_max": nu_max,
        "max_size": max_size,
        "dims": list(dims) if n >= 2 else [0],
        "directions": directions,
        "pcf_r_max": pcf_r_max,
        "pcf_bins": pcf_bins,
        "discrepancy_budget": discrepancy_budget,
        "seed": seed,
    }

    def timed(key, fn):
        t0 = time.perf_counter()
        out = fn()
        res.timings[key] = time.perf_counter() - t0
        return out

    if n >= 2:
        d = check_dims(dims, n, 2)
        res.spectrum = timed(
            "spectrum_2d",
            lambda: power_spectrum_2d(sets, dims=d, nu_max=nu_max, max_size=max_size, progress_bar=progress_bar),
        )
        res.radial = res.spectrum.radial(nu_max)
        if res.spectrum.stride > 1:
            res.notes.append(
                f"2-D spectrum sampled every {res.spectrum.stride} integer "
                f"frequencies (grid limit {max_size}); exact at those frequencies"
            )
    if n >= 3:
        res.radial_nd = timed(
            "radial_nd",
            lambda: radial_spectrum_mc(
                sets, nu_max=nu_max, directions=directions, seed=seed, progress_bar=progress_bar
            ),
        )
    if projections or n == 1:
        res.projections = timed(
            "projections",
            lambda: [power_spectrum_1d(sets, dim=k, nu_max=nu_max, progress_bar=progress_bar) for k in range(n)],
        )
    if n == 1:
        sp = res.projections[0]
        ones = np.ones_like(sp.power)
        res.radial = RadialSpectrum(
            nu=sp.nu,
            radius=sp.freqs.astype(np.float64),
            mean=sp.power,
            anisotropy_db=np.full_like(sp.power, np.nan),
            samples=np.full(sp.power.shape, 2),
            weights=ones,
            n_points=m,
            n_sets=s_count,
            dims=1,
            method="1-d",
        )
    if n <= MAX_PACKING_DIMS:
        d_max = max_packing_distance(m, n)
        r_max = min(float(pcf_r_max), 0.5 / d_max)
        if r_max < pcf_r_max:
            res.notes.append(f"PCF radius limited to {r_max:.3g} d_max (half the torus)")
        res.pcf, res.min_distance = timed(
            "pcf_min_distance", lambda: pair_statistics(sets, r_max=r_max, bins=pcf_bins, progress_bar=progress_bar)
        )
    else:
        res.notes.append(f"PCF and minimum distance need d_max, tabulated up to {MAX_PACKING_DIMS} dimensions")
    methods = [mth for mth in discrepancies]
    for mth in methods:
        if mth not in METHODS:
            raise InvalidArgumentError(f"unknown discrepancy {mth!r}; choose from {METHODS}")
    if methods:
        cost = float(m) ** 2 * len(methods)  # pair terms for one set
        # As many sets as the budget pays for, and at least one while that costs < 16 budgets.
        k = int(min(s_count, max(discrepancy_budget // cost, 1 if cost <= 16 * discrepancy_budget else 0)))
        res.discrepancy_sets = k
        if k == 0:
            res.notes.append(
                f"discrepancies skipped: one set of {m} points costs "
                f"{len(methods)} x {m}^2 pair terms, over the budget of "
                f"{discrepancy_budget:.3g}"
            )
        else:
            if k < s_count:
                res.notes.append(
                    f"discrepancies averaged over the first {k} of {s_count} sets "
                    f"(budget {discrepancy_budget:.3g} pair terms)"
                )
            for mth in methods:
                res.discrepancy[mth] = timed(
                    f"discrepancy_{mth}",
                    lambda mth=mth: float(discrepancy_per_set(sets[:k], mth, progress_bar=progress_bar).mean()),
                )
    return res
