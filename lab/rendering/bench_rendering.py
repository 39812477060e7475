"""dpc's sampler in a real renderer: Mitsuba 3 (scalar_rgb), against every built-in sampler.

    python -m lab.rendering.bench_rendering [--width 128] [--seeds 48] [--quick]

Three scenes built from Mitsuba's own scene dicts: the Cornell box with the `direct` integrator,
a soft-shadow scene (a sphere over a plane under a large area light, `direct`), and the Cornell
box path-traced (`path`, max_depth 5). Box pixel filter, so a pixel's value is the mean of its
own samples. For each scene, sampler (independent, stratified, multijitter, orthogonal,
ldsampler, dpc) and sample count, `--seeds` renders (the sampler's `seed` property 0, 1, ...):
- image MSE and relative MSE (mean of err^2 / (ref^2 + 0.01)) against a reference: ldsampler at
  REF_SPP, rendered as two halves with other seeds (their difference bounds its own error);
- the error image's screen-space power spectrum: low-frequency energy, the mean power over
  0 < |nu| <= 3/16 cycles per pixel over the mean power over all nu != 0 (white noise = 1);
- render time (wall clock, all threads) as a ratio to independent's: per cell the median over
  seeds, and for the goal 7 renders at 64 spp of independent and dpc alternated.
Mitsuba rounds some samplers' counts (stratified: squares, ldsampler: powers of two,
orthogonal: squares of primes): the count a sampler really used is reported.
Writes docs/rendering.md's results section and docs/figures/rendering/*.png; prints whether the
goals of the sampler issue are met.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import time

import numpy as np

from lab.common import (
    CACHE,
    DIRECT_SCENES,
    REF_SPP,
    ROOT,
    SCENES,
    cpu_name,
    ratio_se,
    reference,
    render,
    replace_section,
)

DOC = ROOT / "docs" / "rendering.md"
FIGS = ROOT / "docs" / "figures" / "rendering"
SAMPLERS = ["independent", "stratified", "multijitter", "orthogonal", "ldsampler", "dpc"]
MSE_SPP = [4, 16, 64, 256]
SCREEN_SPP = [1, 2, 4, 16]
BAND = 3 / 16
TIME_SPP, TIME_REPEATS = 64, 7


def low_band_energy(err: np.ndarray) -> float:
    e = err - err.mean()
    q = np.fft.fftfreq(e.shape[0])
    qq = np.hypot(q[:, None], q[None, :])
    p = np.abs(np.fft.fft2(e)) ** 2
    return float(p[(qq > 0) & (qq <= BAND)].mean() / p[qq > 0].mean())


def radial_power(err: np.ndarray, bins: int = 24):
    e = err - err.mean()
    q = np.fft.fftfreq(e.shape[0])
    qq = np.hypot(q[:, None], q[None, :])
    p = np.abs(np.fft.fft2(e)) ** 2
    p /= p[qq > 0].mean()
    edges = np.linspace(0, 0.5 * np.sqrt(2), bins + 1)
    idx = np.digitize(qq.ravel(), edges) - 1
    vals = np.array(
        [
            p.ravel()[(idx == b) & (qq.ravel() > 0)].mean() if np.any((idx == b) & (qq.ravel() > 0)) else np.nan
            for b in range(bins)
        ]
    )
    return 0.5 * (edges[1:] + edges[:-1]), vals


def run(args) -> dict:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    import dpc.mitsuba  # noqa: F401  (registers the plugin)

    commit = (
        subprocess.run(
            ["git", "-C", str(ROOT), "describe", "--always", "--dirty"], capture_output=True, text=True
        ).stdout.strip()
        or "unknown"
    )
    results = {
        "commit": commit,
        "width": args.width,
        "seeds": args.seeds,
        "ref_spp": REF_SPP,
        "cpu": cpu_name(),
        "mitsuba": mi.__version__,
        "scenes": {},
    }
    errors_for_figure = {}
    for scene in SCENES:
        t0 = time.perf_counter()
        ref, ref_mse = reference(mi, scene, args.width, REF_SPP)
        lum_ref = ref.mean(-1)
        rs = {"ref_mse": ref_mse, "samplers": {}}
        print(
            f"{scene}: reference ldsampler {REF_SPP} spp ready ({time.perf_counter() - t0:.0f} s), "
            f"its own MSE ~{ref_mse:.2e}",
            flush=True,
        )
        for sampler in SAMPLERS:
            rows = {}
            for spp in sorted(set(MSE_SPP) | set(SCREEN_SPP)):
                mse, rel, el, times, used = [], [], [], [], None
                for seed in range(args.seeds):
                    img, t, used = render(mi, scene, sampler, spp, seed, args.width)
                    err = img - ref
                    mse.append(float((err**2).mean()))
                    rel.append(float((err**2 / (ref**2 + 0.01)).mean()))
                    el.append(low_band_energy(img.mean(-1) - lum_ref))
                    times.append(t)
                    if seed == 0 and spp in (1, 4):
                        errors_for_figure[(scene, sampler, spp)] = img.mean(-1) - lum_ref
                rows[spp] = {
                    "spp_used": used,
                    "mse": float(np.mean(mse)),
                    "mse_se": float(np.std(mse, ddof=1) / np.sqrt(len(mse))),
                    "relmse": float(np.mean(rel)),
                    "elow": float(np.mean(el)),
                    "elow_se": float(np.std(el, ddof=1) / np.sqrt(len(el))),
                    "time": float(np.median(times)),
                }
                print(
                    f"  {sampler:12s} {spp:4d} spp (used {used:4d}): MSE {rows[spp]['mse']:.3e}  "
                    f"rel {rows[spp]['relmse']:.3e}  E_low {rows[spp]['elow']:.3f}  "
                    f"{rows[spp]['time']:.3f} s",
                    flush=True,
                )
            rs["samplers"][sampler] = rows
        # Render time: the two samplers alternated, so both see the same machine load.
        times = {"independent": [], "dpc": []}
        for _ in range(TIME_REPEATS):
            for name in times:
                times[name].append(render(mi, scene, name, TIME_SPP, 0, args.width)[1])
        rs["timing"] = {name: float(np.median(v)) for name, v in times.items()}
        print(
            f"  render time at {TIME_SPP} spp (median of {TIME_REPEATS}, alternated): "
            f"independent {rs['timing']['independent']:.3f} s, dpc {rs['timing']['dpc']:.3f} s",
            flush=True,
        )
        results["scenes"][scene] = rs
    results["figure_errors"] = {f"{k[0]}|{k[1]}|{k[2]}": v for k, v in errors_for_figure.items()}
    return results


def mse_verdict(d: dict, b: dict) -> str:
    """dpc's MSE over the other's, with its standard error and, for a miss, whether 1 lies within
    two standard errors (a miss not shown to be real at this many seeds)."""
    r, se = ratio_se(d["mse"], d["mse_se"], b["mse"], b["mse_se"])
    note = ""
    if r > 1:
        note = "; within 2 standard errors of 1" if r - 1 <= 2 * se else "; more than 2 standard errors above 1"
    return f"{d['mse']:.3e} vs {b['mse']:.3e} (x{r:.2f} ± {se:.2f}{note})"


def goals(res: dict) -> list[tuple[str, bool, str]]:
    out = []
    for scene in SCENES:
        s = res["scenes"][scene]["samplers"]
        for spp in MSE_SPP:
            d = s["dpc"][spp]["mse"]
            if scene in DIRECT_SCENES:
                # the best built-in sampler that took the samples asked for (Mitsuba rounds some up)
                fair = [n for n in SAMPLERS if n != "dpc" and s[n][spp]["spp_used"] == spp]
                best_name = min(fair, key=lambda n: s[n][spp]["mse"])
                b = s[best_name][spp]["mse"]
                out.append(
                    (
                        f"{scene}, {spp} spp: dpc MSE <= best built-in at {spp} spp ({best_name})",
                        d <= b,
                        mse_verdict(s["dpc"][spp], s[best_name][spp]),
                    )
                )
            else:
                b = s["ldsampler"][spp]["mse"]
                out.append(
                    (
                        f"{scene}, {spp} spp: dpc MSE <= ldsampler",
                        d <= b,
                        mse_verdict(s["dpc"][spp], s["ldsampler"][spp]),
                    )
                )
        d, b = s["dpc"][4]["elow"], s["ldsampler"][4]["elow"]
        out.append(
            (
                f"{scene}, 4 spp: dpc screen low-frequency energy <= 0.25 x ldsampler's",
                d <= 0.25 * b,
                f"{d:.3f} vs 0.25 x {b:.3f} = {0.25 * b:.3f} (ratio {d / b:.2f})",
            )
        )
        t = res["scenes"][scene]["timing"]
        out.append(
            (
                f"{scene}, {TIME_SPP} spp: dpc render time <= 3 x independent's",
                t["dpc"] <= 3 * t["independent"],
                f"{t['dpc']:.3f} s vs {t['independent']:.3f} s (x{t['dpc'] / t['independent']:.2f})",
            )
        )
    return out


def figures(res: dict) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    FIGS.mkdir(parents=True, exist_ok=True)
    made = []
    errs = {tuple(k.split("|")[:2]) + (int(k.split("|")[2]),): np.asarray(v) for k, v in res["figure_errors"].items()}
    for spp in (1, 4):
        fig, axes = plt.subplots(len(SCENES), len(SAMPLERS), figsize=(2.1 * len(SAMPLERS), 2.2 * len(SCENES)))
        for r, scene in enumerate(SCENES):
            lim = max(np.percentile(np.abs(errs[(scene, n, spp)]), 99) for n in SAMPLERS)
            for c, name in enumerate(SAMPLERS):
                ax = axes[r, c]
                ax.imshow(errs[(scene, name, spp)], cmap="RdBu", vmin=-lim, vmax=lim)
                ax.set_xticks([]), ax.set_yticks([])
                row = res["scenes"][scene]["samplers"][name][spp]
                ax.set_title(f"{name} ({row['spp_used']} spp)\nE_low {row['elow']:.2f}", fontsize=8)
                if c == 0:
                    ax.set_ylabel(scene, fontsize=8)
        fig.suptitle(f"Error images (render - reference), {spp} spp, seed 0", fontsize=10)
        fig.tight_layout()
        p = FIGS / f"errors-{spp}spp.png"
        fig.savefig(p, dpi=90)
        plt.close(fig)
        made.append(p.name)
    fig, axes = plt.subplots(1, len(SCENES), figsize=(4.2 * len(SCENES), 3.4))
    for ax, scene in zip(axes, SCENES):
        for name in SAMPLERS:
            rows = res["scenes"][scene]["samplers"][name]
            xs = [rows[s]["spp_used"] for s in MSE_SPP]
            ax.loglog(
                xs,
                [rows[s]["mse"] for s in MSE_SPP],
                "o-" if name == "dpc" else ".--",
                label=name,
                lw=2 if name == "dpc" else 1,
            )
        ax.set_xlabel("samples per pixel")
        ax.set_ylabel("image MSE")
        ax.set_title(scene)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    p = FIGS / "mse.png"
    fig.savefig(p, dpi=90)
    plt.close(fig)
    made.append(p.name)
    fig, axes = plt.subplots(1, len(SCENES), figsize=(4.2 * len(SCENES), 3.4))
    for ax, scene in zip(axes, SCENES):
        for name in SAMPLERS:
            f, pw = radial_power(errs[(scene, name, 4)])
            ax.plot(f, pw, "-" if name == "dpc" else "--", label=name, lw=2 if name == "dpc" else 1)
        ax.axvline(BAND, color="grey", lw=0.8)
        ax.set_xlabel("|nu| (cycles per pixel)")
        ax.set_ylabel("error power (mean = 1)")
        ax.set_title(f"{scene}, 4 spp, seed 0")
        ax.set_yscale("log")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    p = FIGS / "spectra-4spp.png"
    fig.savefig(p, dpi=90)
    plt.close(fig)
    made.append(p.name)
    return made


def section(res: dict, checks, figs) -> str:
    L = [
        f"Measured by `python -m lab.rendering.bench_rendering` (tree {res['commit']}) on {res['cpu']} (2 threads), "
        "Mitsuba "
        f"{res['mitsuba']} `scalar_rgb`, {res['width']} x {res['width']} pixels, {res['seeds']} seeds per "
        f"cell (the sampler's `seed` property). Reference: ldsampler at {res['ref_spp']:,} spp.",
        "",
    ]
    for scene in SCENES:
        s = res["scenes"][scene]
        L += [f"### {scene}", "", f"Reference's own MSE (from its two halves): {s['ref_mse']:.1e}.", ""]
        L += [
            "Image MSE (relative MSE), mean over seeds; samples per pixel actually used in brackets where "
            "Mitsuba rounded the count:",
            "",
        ]
        L += ["| sampler | " + " | ".join(f"{spp} spp" for spp in MSE_SPP) + " |", "|---|" + "---:|" * len(MSE_SPP)]
        for name in SAMPLERS:
            cells = []
            for spp in MSE_SPP:
                r = s["samplers"][name][spp]
                used = f" [{r['spp_used']}]" if r["spp_used"] != spp else ""
                cells.append(f"{r['mse']:.2e} ({r['relmse']:.2e}){used}")
            L.append(f"| {'**dpc**' if name == 'dpc' else name} | " + " | ".join(cells) + " |")
        L += ["", "Screen-space low-frequency error energy (white noise = 1), mean over seeds:", ""]
        L += [
            "| sampler | " + " | ".join(f"{spp} spp" for spp in SCREEN_SPP) + " | time at 64 spp |",
            "|---|" + "---:|" * (len(SCREEN_SPP) + 1),
        ]
        for name in SAMPLERS:
            cells = []
            for spp in SCREEN_SPP:
                r = s["samplers"][name][spp]
                used = f" [{r['spp_used']}]" if r["spp_used"] != spp else ""
                cells.append(f"{r['elow']:.3f}{used}")
            t, t0 = s["samplers"][name][64]["time"], s["samplers"]["independent"][64]["time"]
            L.append(
                f"| {'**dpc**' if name == 'dpc' else name} | " + " | ".join(cells) + f" | {t:.2f} s (x{t / t0:.2f}) |"
            )
        tm = s["timing"]
        L.append("")
        L.append(
            f"Render time at {TIME_SPP} spp, {TIME_REPEATS} renders each, independent and dpc alternated (the "
            f"table's last column is one render per seed, in turn with the other samplers): independent "
            f"{tm['independent']:.3f} s, dpc {tm['dpc']:.3f} s (x{tm['dpc'] / tm['independent']:.2f})."
        )
        L.append("")
    L += ["### Goals", "", "| goal | met | measured |", "|---|---|---|"]
    L += [f"| {g} | {'yes' if ok else '**no**'} | {m} |" for g, ok, m in checks]
    L += [""] + [f"![{f}](figures/rendering/{f})" for f in figs] + [""]
    return "\n".join(L)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--width", type=int, default=128)
    # 48: a hundred rim pixels decide the Cornell boxes' ratios, and two 16-seed runs differed by up
    # to 0.12 (docs/rendering.md, "How sure these ratios are"); the goals print each ratio's
    # standard error
    ap.add_argument("--seeds", type=int, default=48)
    ap.add_argument(
        "--quick",
        action="store_true",
        help="64 x 64 pixels, 3 seeds, REF_SPP 4096: a smoke run that does not write docs/",
    )
    args = ap.parse_args()
    global REF_SPP
    if args.quick:
        args.width, args.seeds, REF_SPP = 64, 3, 4096
    res = run(args)
    checks = goals(res)
    print("\nGoals:")
    for g, ok, m in checks:
        print(f"  [{'met' if ok else 'MISSED'}] {g}: {m}")
    if args.quick:
        return
    figs = figures(res)
    CACHE.mkdir(parents=True, exist_ok=True)
    (CACHE / "results.json").write_text(json.dumps({k: v for k, v in res.items() if k != "figure_errors"}, indent=1))
    replace_section(DOC, "bench_rendering", section(res, checks, figs))
    print(f"wrote {DOC} and {len(figs)} figures in {FIGS}")


if __name__ == "__main__":
    main()
