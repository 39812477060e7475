"""Measure every bundled 2-D model the way docs/models.md reports it, next to the classics.

    python models/model_cards.py            # writes docs/models.md and docs/figures/models/*.png

For each model: 100 realisations at its trained point count (seeds 0..99), and the same metrics
for the authors' BNOT sets (all that ship), jitter and white noise (100 sets each): mean m*P
below nu = 0.5 and 0.75 (white noise = 1), the radial-spectrum peak and where it is, mean
anisotropy over 0.5 <= nu <= 4 (dB), and the minimum-distance ratio (mean and worst set).
Conventions: docs/analysis.md (DESIGN.md §8).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import dpc  # noqa: E402
from dpc import analysis, baselines  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures" / "models"
SETS = 100


TARGET = None  # the authors' BNOT radial target at m = 1,024, loaded in main()


def target_distance(r) -> float:
    """Mean relative L1 distance |P - T| / T of a radial spectrum to the BNOT target over
    0.25 <= nu <= 3 (the target's own points; the spectrum interpolated there)."""
    sel = (TARGET.nu >= 0.25) & (TARGET.nu <= 3.0)
    ok = r.samples > 0
    p = np.interp(TARGET.nu[sel], r.nu[ok], r.mean[ok])
    return float(np.mean(np.abs(p - TARGET.power[sel]) / TARGET.power[sel]))


def metrics(sets: np.ndarray) -> dict:
    r = analysis.radial_spectrum(sets, nu_max=4.0)
    peak, peak_nu = r.peak()
    band = (r.nu >= 0.5) & (r.nu <= 4.0) & (r.samples > 0)
    md = analysis.min_distance(sets)
    return {
        "sets": len(sets), "elow50": r.low_frequency_energy(0.5), "elow75": r.low_frequency_energy(0.75),
        "peak": peak, "peak_nu": peak_nu, "aniso": float(np.mean(r.anisotropy_db[band])),
        "dmin_mean": md.mean_ratio, "dmin_min": md.min_ratio, "radial": r, "l1": target_distance(r),
    }


LOWEST_Q = np.array([[1, 0], [0, 1], [1, 1], [1, -1]])
SCALES = [(0.25, 100), (1, 100), (4, 40), (16, 10)]  # (point-count factor, sets)


def scale_rows(model) -> list[str]:
    """E_low and the power of the lowest frequencies (|q| = 1, sqrt 2) at other point counts,
    using the scale-aware radius; the model was trained (or designed) for model.n_points."""
    out = ["| points | sets | E_low ν<0.5 | E_low ν<0.75 | mean P at the lowest frequencies |",
           "|---:|---:|---:|---:|---:|"]
    for factor, count in SCALES:
        m = int(model.n_points * factor)
        sets = model.generate_batch(count, seed=0, n_points=m)
        r = analysis.radial_spectrum(sets, nu_max=1.0)
        low = float(np.mean(analysis.power_spectrum_direct(sets, LOWEST_Q)))
        out.append(f"| {m:,} ({factor:g} m) | {count} | {r.low_frequency_energy(0.5):.4f} | "
                   f"{r.low_frequency_energy(0.75):.4f} | {low:.4f} |")
    return out


def made_by(name: str, meta: dict) -> list[str]:
    if "dpc.train.steps" not in meta:
        return [f"- made by: `python {meta.get('dpc.source', '?')}` (hand-designed, not trained)"]
    out = [f"- trained by: `python training/train.py --config training/configs/{name}.toml`, then "
           f"`python training/export.py runs/{name}/checkpoint.pt -o models/{name}.onnx`",
           f"- training: {meta['dpc.train.steps']} steps, {float(meta.get('dpc.train.wall_time_s', 'nan')):.0f} s "
           f"of step time (torch {meta.get('dpc.train.torch', '?')})"]
    if "dpc.loss" in meta:
        out += ["- loss:", "", "```python", meta["dpc.loss"].strip(), "```"]
    return out


def row(name: str, m: dict) -> str:
    return (f"| {name} | {m['sets']} | {m['elow50']:.4f} | {m['elow75']:.4f} | {m['peak']:.2f} "
            f"(ν = {m['peak_nu']:.2f}) | {m['aniso']:.2f} | {m['dmin_mean']:.3f} / {m['dmin_min']:.3f} | "
            f"{m['l1']:.3f} |")


def main() -> None:
    FIGURES.mkdir(parents=True, exist_ok=True)
    global TARGET
    TARGET = analysis.reference_radial_spectrum("bnot", 1024, 2)
    classics = {
        "authors' BNOT sets": metrics(baselines.reference_sets("bnot", 1024, 2)),
        "jitter": metrics(baselines.generate("jitter", 1024, 2, count=SETS, seed=0)),
        "white noise": metrics(baselines.generate("white", 1024, 2, count=SETS, seed=0)),
    }
    target = analysis.reference_radial_spectrum("bnot", 1024, 2)

    lines = ["# Bundled models", "",
             "Each card is made by `python models/model_cards.py` (this page and its figures are its "
             "output). Metrics over realisations by the conventions of [analysis](analysis.md): "
             "E_low(ν) = mean m·P over 0 < ν' < ν (white noise = 1); anisotropy = mean over "
             "0.5 ≤ ν ≤ 4, in dB; δ_min = minimum toroidal distance / maximal packing distance "
             "(mean over sets / worst set).", ""]
    header = ["| point sets | sets | E_low ν<0.5 | E_low ν<0.75 | peak | anisotropy (dB) | δ_min mean / worst "
              "| rel. L1 to BNOT target, 0.25 ≤ ν ≤ 3 |",
              "|---|---:|---:|---:|---|---:|---|---:|"]
    for name in dpc.available_models():
        model = dpc.load(name)
        if model.dims != 2 or model.grid_axes:
            continue
        path = dpc.model_path(name)
        sha = hashlib.sha256(path.read_bytes()).hexdigest()
        sets = model.generate_batch(SETS, seed=0)
        mm = metrics(sets)
        lines += [f"## {name}", "", model.metadata.get("dpc.description", ""), "",
                  f"- file: `models/{path.name}` ({path.stat().st_size:,} bytes), sha256 `{sha}`",
                  f"- {model.dims}-D, trained point count {model.n_points:,}, {model.layers} layers",
                  *made_by(name, model.metadata), "", *header, row(f"**{name}** (m = {model.n_points:,})", mm)]
        lines += [row(label, m) for label, m in classics.items()]
        fig, ax = plt.subplots(figsize=(7, 3.6))
        for label, m, style in [(name, mm, "-"), ("authors' BNOT sets", classics["authors' BNOT sets"], "--"),
                                ("jitter", classics["jitter"], ":")]:
            r = m["radial"]
            ok = r.samples > 0
            ax.plot(r.nu[ok], r.mean[ok], style, lw=1.2, label=f"{label} ({m['sets']} sets)")
        ax.plot(target.nu, target.power, color="0.6", lw=0.8, label="BNOT radial target (authors' file)")
        ax.set(xlim=(0, 4), ylim=(0, 3.6), xlabel="ν = |q| / √m", ylabel="radial mean of m·P")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig_path = FIGURES / f"{name}-radial.png"
        fig.savefig(fig_path, dpi=110)
        plt.close(fig)
        lines += ["", f"![radial spectrum of {name}](figures/models/{fig_path.name})", "",
                  "Other point counts (scale-aware radius; \"lowest frequencies\" = q in "
                  "{(1,0), (0,1), (1,1), (1,-1)}, white noise = 1):", "", *scale_rows(model), "",
                  "A cascade of local filters moves each point a bounded distance per layer, so density "
                  "fluctuations on scales far beyond the receptive field relax slowly: the last column "
                  "shows how much power is left at the torus-scale frequencies as m grows (E_low averages "
                  "over many more frequencies and hides it).", ""]
        print("\n".join(lines[-(len(classics) + 4):]))
    lines += ["Reference data: the authors' BNOT point sets and radial target come from "
              "`sinbag/deepsampling` (BSD 3-Clause, `python/dpc/data/deepsampling/LICENSE`).", ""]
    out = ROOT / "docs" / "models.md"
    out.write_text("\n".join(lines))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
