"""Make the figures of docs/analysis.md (one per metric) into docs/figures/analysis/.

    python -m lab.analysis.figures            # about two minutes on 2 cores
    python -m lab.analysis.figures --checks   # only the correctness figures

Everything is seeded; the bundled repulsion-2d model is included beside the classics. Prints the
numbers quoted in docs/analysis.md.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

import dpc
from dpc import analysis, baselines
from dpc.analysis import plots
from dpc.analysis.reference import reference_radial_spectrum

OUT = Path(__file__).resolve().parents[2] / "docs" / "figures" / "analysis"
DPI = 110


def model_sampler():
    """(label, sampler(count, m, seed)) for the bundled repulsion-2d (the benchmark model)."""
    model = dpc.load("repulsion-2d")
    return model.name, lambda c, m, s: model.generate_batch(c, seed=s, n_points=m).astype(float)


def sets_2d(count=32, m=1024):
    out = {
        "white": baselines.generate("white", m, count=count, seed=1),
        "jitter": baselines.generate("jitter", m, count=count, seed=1),
        "sobol": baselines.generate("sobol", m, count=count, seed=1),
        "rank1": baselines.generate("rank1", m, count=count, seed=1),
        "ref-bnot": baselines.reference_sets("bnot", 1024, 2),
    }
    ms = model_sampler()
    if ms is not None:
        out[ms[0]] = ms[1](count, m, 1)
    return out


def fig_spectra(data):
    specs = {k: analysis.power_spectrum_2d(v) for k, v in data.items()}
    fig = Figure(figsize=(3.0 * len(specs), 3.2))
    axes = fig.subplots(1, len(specs))
    for ax, (name, s) in zip(axes, specs.items()):
        e = s.nu_extent
        ax.imshow(
            s.power.T, origin="lower", cmap="gray", vmin=0, vmax=2.5, extent=(-e, e, -e, e), interpolation="nearest"
        )
        ax.set_title(f"{name} ({s.n_sets} sets)", fontsize=9)
        ax.set_xlabel(r"$\nu_x$")
    axes[0].set_ylabel(r"$\nu_y$")
    fig.savefig(OUT / "spectrum-2d.png", dpi=DPI, bbox_inches="tight")
    return specs


def fig_radial(specs):
    tgt = reference_radial_spectrum("bnot", 1024, 2)
    # The lattice's radial mean is a few spikes of height ~m: left out of the line plots.
    curves = [(k, s.radial(4.0)) for k, s in specs.items() if k != "rank1"]
    plots.save_radial(
        OUT / "radial-mean.png",
        curves,
        anisotropy=False,
        reference=("BNOT target (authors' file)", tgt.nu, tgt.power),
        title="radial mean power, m = 1024",
    )
    print(
        "radial mean vs BNOT target (ref-bnot sets): mean |diff| =",
        f"{np.abs(specs['ref-bnot'].radial(4.0).mean - tgt.power[:128]).mean():.4f}",
    )
    for k, s in specs.items():
        r = s.radial(4.0)
        peak, nu = r.peak()
        print(
            f"  {k:14s} E_low(<0.5) = {s.low_frequency_energy(0.5):.3g}  "
            f"E_low(<0.75) = {s.low_frequency_energy(0.75):.3g}  peak {peak:.2f} at nu {nu:.2f}"
        )


def fig_anisotropy(specs):
    fig = Figure(figsize=(6.4, 3.6))
    ax = fig.subplots()
    for k, s in specs.items():
        if k == "rank1":
            continue
        r = s.radial(4.0)
        ax.plot(r.nu, r.anisotropy_db, lw=1.0, label=f"{k} ({s.n_sets} sets)")
    n = specs["white"].n_sets
    ax.axhline(-10 * math.log10(n), color="0.5", ls="--", lw=0.8, label=f"isotropic, {n} sets: -10 log10({n}) dB")
    ax.set_xlim(0, 4)
    ax.set_ylim(-35, 25)
    ax.set_xlabel(r"$\nu$")
    ax.set_ylabel("anisotropy [dB]")
    ax.legend(fontsize=7, ncol=2)
    ax.set_title("anisotropy = ring variance / ring mean^2 of the mean spectrum", fontsize=9)
    fig.savefig(OUT / "anisotropy.png", dpi=DPI, bbox_inches="tight")


def fig_projections():
    curves = []
    for name in ("white", "jitter", "lhs", "sobol"):
        x = baselines.generate(name, 1024, count=32, seed=2)
        curves.append((name, analysis.power_spectrum_1d(x, dim=0, nu_max=1.0)))
    fig = Figure(figsize=(6.4, 3.6))
    ax = fig.subplots()
    for name, sp in curves:
        w = 8
        k = np.ones(w) / w
        ax.plot(np.convolve(sp.nu, k, "valid"), np.convolve(sp.power, k, "valid"), lw=1.0, label=name)
    ax.set_xscale("log")
    ax.set_xlim(1 / 1024, 1.0)
    ax.set_ylim(0, 1.6)
    ax.axhline(1, color="0.6", lw=0.6)
    ax.set_xlabel(r"$\nu = q / m$ (projection on x, m = 1024)")
    ax.set_ylabel("power")
    ax.legend(fontsize=8)
    ax.set_title("1-D projection spectra (32 sets, running mean of 8 frequencies)", fontsize=9)
    fig.savefig(OUT / "projections-1d.png", dpi=DPI, bbox_inches="tight")


def fig_radial_nd():
    curves = []
    for name in ("white", "jitter", "sobol", "halton"):
        x = baselines.generate(name, 4096, dims=3, count=16, seed=3)
        curves.append((name, analysis.radial_spectrum_mc(x, directions=128, seed=0)))
    tgt = reference_radial_spectrum("jitter", 4096, 3)
    plots.save_radial(
        OUT / "radial-nd.png",
        curves,
        anisotropy=False,
        reference=("jitter target d=3 (authors' file)", tgt.nu, tgt.power),
        title="3-D radial mean, Monte Carlo (128 directions per ring), m = 4096",
    )
    r = dict(curves)["jitter"]
    n = min(r.mean.size, tgt.power.size)
    print(f"3-D jitter MC radial vs authors' target: mean |diff| = {np.abs(r.mean[:n] - tgt.power[:n]).mean():.4f}")


def fig_pcf(data):
    curves = [(k, analysis.pcf(v, r_max=2.5, bins=100)) for k, v in data.items() if k != "rank1"]
    plots.save_pcf(OUT / "pcf.png", curves, title="pair correlation (toroidal), m = 1024")
    print(f"white-noise PCF mean over r: {np.mean(dict(curves)['white'].g):.4f}")


def fig_min_distance_and_discrepancy(ms):
    counts = [64, 256, 1024, 4096]
    names = ["white", "jitter", "sobol", "halton", "rank1"]
    samplers = {n: (lambda c, m, s, n=n: baselines.generate(n, m, count=c, seed=s)) for n in names}
    if ms is not None:
        samplers[ms[0]] = ms[1]
    dmin, disc = {}, {}
    for name, f in samplers.items():
        ratios, gl2 = [], []
        for m in counts:
            x = f(8, m, 5)
            ratios.append(analysis.min_distance_ratio(x))
            gl2.append(analysis.discrepancy(x[: max(1, 8 * 1024 // m)], "GL2"))
        dmin[name] = (counts, ratios)
        disc[name] = (counts, gl2)
        print(f"  {name:14s} delta_min {np.round(ratios, 3)}  GL2 {np.array(gl2)}")
    bnot = baselines.reference_sets("bnot", 256, 2)
    dmin["ref-bnot"] = (
        [256, 1024],
        [analysis.min_distance_ratio(bnot), analysis.min_distance_ratio(baselines.reference_sets("bnot", 1024, 2))],
    )
    disc["ref-bnot"] = (
        [256, 1024],
        [analysis.discrepancy(bnot, "GL2"), analysis.discrepancy(baselines.reference_sets("bnot", 1024, 2), "GL2")],
    )
    plots.save_series(
        OUT / "min-distance.png",
        dmin,
        xlabel="points m",
        ylabel=r"$\delta_{min}$ = min distance / $d_{max}$",
        logx=True,
        title="minimum-distance ratio (mean over 8 sets)",
    )
    plots.save_series(
        OUT / "discrepancy.png",
        disc,
        xlabel="points m",
        ylabel="generalised L2 discrepancy",
        logx=True,
        logy=True,
        title="GL2 discrepancy (cf. paper Fig. 11)",
    )


def fig_integration(ms):
    counts = [64, 144, 256, 576, 1024, 2304, 4096]
    names = ["white", "jitter", "sobol", "halton", "rank1"]
    samplers = {n: (lambda c, m, s, n=n: baselines.generate(n, m, count=c, seed=s)) for n in names}
    samplers["fibonacci"] = lambda c, m, s: baselines.generate(
        "fibonacci", baselines.nearest_fibonacci(m), count=c, seed=s
    )
    if ms is not None:
        samplers[ms[0]] = ms[1]
    study = analysis.integration_study(
        samplers, counts, integrands_per_family=10, realisations=64, seed=0, progress_bar=True
    )
    plots.save_integration(
        OUT / "integration.png", study, title="relative variance of MC integration (cf. paper Fig. 12)"
    )
    for fam in study.families:
        print(
            f"  {fam}: "
            + ", ".join(f"{k} {v[-1]:.2e}" for k, v in study.rel_var[fam].items())
            + f"  (m = {counts[-1]})"
        )


def checks():
    """The correctness figures quoted in docs/analysis.md (the tests assert the same things)."""
    from scipy.stats import qmc

    w = np.random.default_rng(12345).random((100, 1024, 2))
    s = analysis.power_spectrum_2d(w)
    nu = np.hypot(*np.meshgrid(s.freqs, s.freqs, indexing="ij")) / 32.0
    dev = max(abs(s.power[(nu > lo) & (nu <= lo + 0.5)].mean() - 1) for lo in np.arange(0, 4, 0.5))
    r = s.radial(4.0)
    print(
        f"white noise, 100 x 1024: largest deviation of a nu band (width 0.5) from 1 = "
        f"{dev:.4f}; "
        f"median anisotropy {np.median(r.anisotropy_db[r.nu > 0.5]):.2f} dB (expected -20)"
    )
    j = baselines.generate("jitter", 1024, count=64, seed=7)
    sj = analysis.power_spectrum_2d(j)
    a = np.sinc(sj.freqs / 32) ** 2
    ana = 1 - a[:, None] * a[None, :]
    ana[sj.freqs.size // 2, sj.freqs.size // 2] = 0
    from dpc.analysis.spectrum import Spectrum2D

    ra = Spectrum2D(ana, sj.freqs, 1, 1024, 1, (0, 1)).radial(4.0)
    ratio = sj.radial(4.0).mean / ra.mean
    print(
        f"jitter 32x32, 64 sets: ring mean / analytic: mean {ratio.mean():.4f}, worst ring "
        f"(b >= 2) {np.abs(ratio[1:] - 1).max():.3f}"
    )
    tgt = reference_radial_spectrum("jitter", 1024, 2)
    print(
        f"analytic jitter vs the authors' jitter target: max |diff| {np.abs(tgt.power[:127] - ra.mean[:127]).max():.4f}"
    )
    b = baselines.reference_sets("bnot", 1024, 2)
    rb = analysis.power_spectrum_2d(b).radial(4.0)
    tb = reference_radial_spectrum("bnot", 1024, 2).power[: rb.mean.size]
    print(
        f"authors' 10 BNOT sets vs BNOT target: mean |diff| {np.abs(rb.mean - tb).mean():.4f}, "
        f"max |diff| below nu 0.5 {np.abs(rb.mean - tb)[rb.nu < 0.5].max():.5f}"
    )
    b256 = baselines.reference_sets("bnot", 256, 2)
    s256 = analysis.power_spectrum_2d(b256)
    pk, pnu = s256.radial(4.0).peak()
    print(
        f"authors' 20 BNOT sets, m = 256: E_low(<0.5) {s256.low_frequency_energy(0.5):.5f}, "
        f"E_low(<0.75) {s256.low_frequency_energy(0.75):.4f}, peak {pk:.2f} at nu {pnu:.3f}, "
        f"delta_min {analysis.min_distance_ratio(b256):.4f}"
    )
    p = analysis.pcf(w[:60], bins=50)
    print(
        f"white noise PCF (60 x 1024): mean g {np.average(p.g, weights=p.pairs + 1):.4f}, "
        f"mean |g - 1| {np.abs(p.g - 1).mean():.4f}"
    )
    x = w[0][:200]
    worst = max(
        abs(
            analysis.discrepancy(x, mth)
            - (np.sqrt(qmc.discrepancy(x, method=mth)) if mth != "L2-star" else qmc.discrepancy(x, method=mth))
        )
        for mth in ("CD", "WD", "MD", "L2-star")
    )
    print(f"discrepancy vs scipy on the same set: largest difference {worst:.2e}")


def main() -> int:
    if "--checks" in sys.argv:
        checks()
        return 0
    OUT.mkdir(parents=True, exist_ok=True)
    data = sets_2d()
    print("2-D spectra, radial mean, anisotropy:")
    specs = fig_spectra(data)
    fig_radial(specs)
    fig_anisotropy(specs)
    fig_projections()
    print("n-D radial spectrum:")
    fig_radial_nd()
    fig_pcf(data)
    print("minimum distance and discrepancy (m = 64 ... 4096):")
    ms = model_sampler()
    fig_min_distance_and_discrepancy(ms)
    print("integration study:")
    fig_integration(ms)
    print(f"figures written to {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
