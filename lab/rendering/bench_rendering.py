"""dpc's sampler in a real renderer: Mitsuba 3 (scalar_rgb), against every built-in sampler and the
published samplers renderer teams compare against (lab/rendering/anchors: ZSobol, Owen-scrambled
Sobol' joint and padded, PMJ02BN, Heitz et al. 2019).

    python -m lab.rendering.bench_rendering [--width 128] [--jobs 2] [--quick]
    python -m lab.rendering.bench_rendering --only "dpc,dpc (pixel nets)"   # re-render these, keep the rest
    python -m lab.rendering.bench_rendering --report   # rewrite the docs section from the last results

Five scenes built from Mitsuba scene dicts (lab/common.py), one per integrand class:
soft-shadow (direct light from a large area light: the light's 2-D sample against an occluder),
hidden-light (indirect light from a small emitter hidden under the ceiling, path-traced to depth
6: many dimensions, sparse paths), aliasing (only the pixel footprint: a checkerboard of
sub-pixel squares at the horizon and rods thinner than a pixel, all emission), ao-env (visibility
under a uniform sky, BSDF sampling only) and glossy (a rough metal floor reflecting a bright
rectangle light; light and BSDF samples combined by MIS). Box pixel filter; the integrator renders
the image as one block (block_size = width), so every sampler sees the pixels' true positions.

Counts 1, 2, 4, 8, 16, 64, 256 spp; --seeds-low seeds (default 16) below 16 spp and --seeds-high
(default 8) from 16 on (the sampler's `seed` property). Per cell:
- image MSE against a reference (ldsampler at REF_SPP, two halves of other seeds), the reference's
  own error (from its halves) subtracted, with the standard error over seeds;
- the luminance error image's screen-space low-frequency energy E_low: mean power at
  0 < |nu| <= 1/8 cycles per pixel (a quarter of Nyquist) over the mean power at all nu != 0
  (white noise = 1);
- the error a viewer or denoiser keeps: the mean square of the luminance error blurred by a
  Gaussian of sigma = 1.5 px (periodic), as a ratio to the lowest built-in sampler's;
- render time (one thread), as a ratio to independent's: per cell the median over seeds, and for
  the goal TIME_REPEATS renders at TIME_SPP of independent, dpc and the anchors in turn.
Mitsuba rounds some built-ins' counts (stratified: squares, orthogonal: squares of primes): the
count a sampler really used is reported, and only samplers that used the count asked for enter
the goals. `dpc (pixel nets)` is dpc with net_layout "pixel": what the default's screen-ordered
nets (below 64 spp) cost or gain per pixel.
Writes docs/rendering.md's results section and docs/figures/rendering/*.png; prints each goal of
the sampler issue as met / not met with its ratio.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import subprocess
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from lab.common import CACHE, REF_SPP, ROOT, cpu_name, ratio_se, reference, replace_section, scene_dict

DOC = ROOT / "docs" / "rendering.md"
FIGS = ROOT / "docs" / "figures" / "rendering"
BUILTINS = ["independent", "stratified", "multijitter", "orthogonal", "ldsampler"]
ANCHORS = ["zsobol", "owen_sobol", "padded_sobol", "pmj02bn", "heitz2019"]
DPC = ["dpc", "dpc (pixel nets)"]
SAMPLERS = BUILTINS + ANCHORS + DPC
OTHERS = BUILTINS + ANCHORS  # what dpc's goals compare against
SCENES = {
    "soft-shadow": "direct light, large area light (shadow edges in the light's 2-D sample)",
    "hidden-light": "indirect light from a small hidden emitter, path traced to depth 6",
    "aliasing": "pixel antialiasing: sub-pixel checkerboard and thin rods (the film position only)",
    "ao-env": "visibility under a uniform sky, BSDF sampling only (ambient occlusion's integrand)",
    "glossy": "glossy reflection of a bright rectangle light (light + BSDF samples, MIS)",
}
SPP = [1, 2, 4, 8, 16, 64, 256]
LOW_SPP = [1, 2, 4, 8]  # MSE goal within 5 % here, at or below the best from 16 on
SCREEN_SPP = [1, 2, 4, 8, 16]
BAND = 3 / 16  # the other studies' band (mask and pbrt studies)
ISSUE_BAND = 1 / 8  # a quarter of Nyquist: this bench's E_low
BLUR_SIGMA = 1.5
TIME_SPP, TIME_REPEATS = 64, 5
TIMED = ["independent", "dpc", *ANCHORS]


def low_band_energy(err: np.ndarray, band: float = BAND) -> float:
    """Mean power of the error image at 0 < |nu| <= band cycles per pixel over its mean power at
    all nu != 0 (white noise = 1)."""
    e = err - err.mean()
    q0, q1 = np.fft.fftfreq(e.shape[0]), np.fft.fftfreq(e.shape[1])
    qq = np.hypot(q0[:, None], q1[None, :])
    p = np.abs(np.fft.fft2(e)) ** 2
    return float(p[(qq > 0) & (qq <= band)].mean() / p[qq > 0].mean())


def blurred_error(err: np.ndarray) -> float:
    """Mean square of the error blurred by a periodic Gaussian of sigma BLUR_SIGMA pixels."""
    from scipy.ndimage import gaussian_filter  # noqa: PLC0415

    return float((gaussian_filter(err, BLUR_SIGMA, mode="wrap") ** 2).mean())


def radial_power(err: np.ndarray, bins: int = 24):
    e = err - err.mean()
    q = np.fft.fftfreq(e.shape[0])
    qq = np.hypot(q[:, None], q[None, :])
    p = np.abs(np.fft.fft2(e)) ** 2
    p /= p[qq > 0].mean()
    edges = np.linspace(0, 0.5 * np.sqrt(2), bins + 1)
    idx = np.digitize(qq.ravel(), edges) - 1
    keep = qq.ravel() > 0
    vals = np.array([p.ravel()[(idx == b) & keep].mean() if np.any((idx == b) & keep) else np.nan for b in range(bins)])
    return 0.5 * (edges[1:] + edges[:-1]), vals


def _mitsuba():
    import mitsuba as mi  # noqa: PLC0415

    mi.set_variant("scalar_rgb")
    import dpc.mitsuba  # noqa: F401,PLC0415  (registers "dpc")
    from lab.rendering import anchors  # noqa: PLC0415

    anchors.register(mi)
    return mi, anchors


def render(mi, anchors, scene: str, sampler: str, spp: int, seed: int, width: int, extra: dict | None = None):
    """One render as one block: (image, seconds, samples per pixel used); extra: more sampler
    properties."""
    d = scene_dict(mi, scene, width)
    d["integrator"]["block_size"] = width
    props = {"type": sampler, "sample_count": spp, "seed": seed}
    if sampler.startswith("dpc"):
        props.update(type="dpc", block_size=width)
        if sampler == "dpc (pixel nets)":
            props["net_layout"] = "pixel"
    elif sampler in ANCHORS:
        props.update(block_size=width, **anchors.properties(sampler, mi))
    d["sensor"]["sampler"] = {**props, **(extra or {})}
    sc = mi.load_dict(d)
    used = sc.sensors()[0].sampler().sample_count()
    t = time.perf_counter()
    img = np.array(mi.render(sc), dtype=np.float64)
    return img, time.perf_counter() - t, used


def seeds_for(spp: int, args) -> int:
    return args.seeds_low if spp < 16 else args.seeds_high


def run_scene(scene: str, args) -> dict:
    """Every sampler (or those of --only), count and seed of one scene (a worker process)."""
    mi, anchors = _mitsuba()
    t0 = time.perf_counter()
    ref, ref_mse = reference(mi, scene, args.width, args.ref_spp)  # lab.common's, cached
    print(f"{scene}: reference ready ({time.perf_counter() - t0:.0f} s), its own MSE {ref_mse:.2e}", flush=True)
    out = {"ref_mse": ref_mse, "samplers": {}, "figure": {}}
    for sampler in args.only or SAMPLERS:
        rows = {}
        for spp in SPP:
            mse, el, blur, times, used = [], [], [], [], None
            for seed in range(seeds_for(spp, args)):
                img, t, used = render(mi, anchors, scene, sampler, spp, seed, args.width)
                err = img - ref
                lum = err.mean(-1)
                mse.append(float((err**2).mean()) - ref_mse)
                el.append(low_band_energy(lum, ISSUE_BAND))
                blur.append(blurred_error(lum))
                times.append(t)
                if seed == 0 and spp in (1, 4, 16) and sampler in FIG_SAMPLERS:
                    out["figure"][f"{sampler}|{spp}"] = lum.astype(np.float32).tolist()
            n = len(mse)
            rows[spp] = {
                "spp_used": used,
                "mse": float(np.mean(mse)),
                "mse_se": float(np.std(mse, ddof=1) / np.sqrt(n)),
                "elow": float(np.mean(el)),
                "elow_se": float(np.std(el, ddof=1) / np.sqrt(n)),
                "blur": float(np.mean(blur)),
                "blur_se": float(np.std(blur, ddof=1) / np.sqrt(n)),
                "time": float(np.median(times)),
                "seeds": n,
            }
            r = rows[spp]
            print(
                f"  {scene:12s} {sampler:16s} {spp:4d} spp (used {used:4d}): MSE {r['mse']:.3e}  "
                f"E_low {r['elow']:.3f}  blur {r['blur']:.3e}  {r['time']:.3f} s",
                flush=True,
            )
        out["samplers"][sampler] = rows
    return out


def timing(scene: str, args) -> dict:
    """TIME_REPEATS renders at TIME_SPP of each timed sampler, in turn (the same machine load)."""
    mi, anchors = _mitsuba()
    times = {n: [] for n in TIMED}
    for _ in range(TIME_REPEATS):
        for name in TIMED:
            times[name].append(render(mi, anchors, scene, name, TIME_SPP, 0, args.width)[1])
    return {name: float(np.median(v)) for name, v in times.items()}


def run(args) -> dict:
    commit = (
        subprocess.run(
            ["git", "-C", str(ROOT), "describe", "--always", "--dirty"], capture_output=True, text=True
        ).stdout.strip()
        or "unknown"
    )
    mi, _ = _mitsuba()  # builds the plugins once, before the workers start
    res = {
        "commit": f"tree {commit}",
        "width": args.width,
        "seeds_low": args.seeds_low,
        "seeds_high": args.seeds_high,
        "ref_spp": args.ref_spp,
        "cpu": cpu_name(),
        "mitsuba": mi.__version__,
        "scenes": {},
    }
    scenes = list(SCENES)
    if args.only:  # the other samplers' rows (and the timing) from the last full run
        last = load_results()
        args.width, args.seeds_low, args.seeds_high = last["width"], last["seeds_low"], last["seeds_high"]
        res.update(width=args.width, seeds_low=args.seeds_low, seeds_high=args.seeds_high)
    # spawned workers: Mitsuba's thread pool does not survive a fork
    with ProcessPoolExecutor(max_workers=args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        for scene, out in zip(scenes, pool.map(run_scene, scenes, [args] * len(scenes))):
            res["scenes"][scene] = out
    if args.only:
        for scene in scenes:
            old, new = last["scenes"][scene], res["scenes"][scene]
            rows = {n: old["samplers"][n] for n in SAMPLERS if n in old["samplers"] and n not in args.only}
            res["scenes"][scene] = {**old, "samplers": {**rows, **new["samplers"]}, "figure": new["figure"]}
        res["commit"] = provenance(last["commit"], args.only, res["commit"])
        return res
    for scene in scenes:  # alone on the machine
        res["scenes"][scene]["timing"] = timing(scene, args)
        print(f"  {scene}: render time at {TIME_SPP} spp: {res['scenes'][scene]['timing']}", flush=True)
    return res


def provenance(last: str, only: list[str], tree: str) -> str:
    """The results' origin after re-rendering the samplers `only` at `tree`: the last origin's
    parts, less those naming only samplers rendered again."""
    parts = [p for p in last.split("; ") if " at " not in p or not set(p.split(" at ")[0].split(", ")) <= set(only)]
    return "; ".join([*parts, f"{', '.join(only)} at {tree}"])


def load_results() -> dict:
    """The last run's results.json, counts as integers again."""
    res = json.loads((CACHE / "results.json").read_text())
    for sres in res["scenes"].values():
        sres["samplers"] = {n: {int(k): v for k, v in rows.items()} for n, rows in sres["samplers"].items()}
    return res


def _fair(s: dict, names: list[str], spp: int) -> list[str]:
    return [n for n in names if s[n][spp]["spp_used"] == spp]


def _ratio(d: dict, b: dict, key: str) -> str:
    r, se = ratio_se(d[key], d[key + "_se"], b[key], b[key + "_se"])
    note = ""
    if r > 1:
        note = "; within 2 s.e. of 1" if r - 1 <= 2 * se else "; > 2 s.e. above 1"
    return f"x{r:.2f} ± {se:.2f}{note}"


def goals(res: dict) -> list[tuple[str, bool, str]]:
    out = []
    for scene, sres in res["scenes"].items():
        s = sres["samplers"]
        for spp in SPP:
            best = min(_fair(s, OTHERS, spp), key=lambda n: s[n][spp]["mse"])
            limit = 1.05 if spp in LOW_SPP else 1.0
            d, b = s["dpc"][spp], s[best][spp]
            out.append(
                (
                    f"{scene}, {spp} spp: MSE <= {limit:g} x best other ({best})",
                    d["mse"] <= limit * b["mse"],
                    f"{d['mse']:.3e} vs {b['mse']:.3e} ({_ratio(d, b, 'mse')})",
                )
            )
        for spp in SCREEN_SPP:
            d, h = s["dpc"][spp], s["heitz2019"][spp]
            out.append(
                (
                    f"{scene}, {spp} spp: E_low <= heitz2019's",
                    d["elow"] <= h["elow"],
                    f"{d['elow']:.3f} vs {h['elow']:.3f}",
                )
            )
            best = min(_fair(s, OTHERS, spp), key=lambda n: s[n][spp]["blur"])
            out.append(
                (
                    f"{scene}, {spp} spp: blurred error the lowest ({best} next)",
                    d["blur"] <= s[best][spp]["blur"],
                    f"{d['blur']:.3e} vs {s[best][spp]['blur']:.3e} ({_ratio(d, s[best][spp], 'blur')})",
                )
            )
        worst = max((s["dpc"][spp]["mse"] / s["dpc (pixel nets)"][spp]["mse"], spp) for spp in SPP if spp < 64)
        out.append(
            (
                f"{scene}: the default's screen-ordered nets (< 64 spp) cost <= 5 % MSE against per-pixel nets",
                worst[0] <= 1.05,
                f"worst x{worst[0]:.2f} at {worst[1]} spp",
            )
        )
        t = sres["timing"]
        out.append(
            (
                f"{scene}: render time <= 1.1 x independent's at {TIME_SPP} spp",
                t["dpc"] <= 1.1 * t["independent"],
                f"{t['dpc']:.3f} s vs {t['independent']:.3f} s (x{t['dpc'] / t['independent']:.2f})",
            )
        )
    return out


FIG_SAMPLERS = ["independent", "ldsampler", "zsobol", "owen_sobol", "heitz2019", "dpc"]


def figures(res: dict) -> list[str]:
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    FIGS.mkdir(parents=True, exist_ok=True)
    made = []
    scenes = list(res["scenes"])
    for spp in (1, 4, 16):
        fig, axes = plt.subplots(len(scenes), len(FIG_SAMPLERS), figsize=(2.0 * len(FIG_SAMPLERS), 2.1 * len(scenes)))
        for r, scene in enumerate(scenes):
            sres = res["scenes"][scene]
            errs = {n: np.asarray(sres["figure"][f"{n}|{spp}"]) for n in FIG_SAMPLERS}
            lim = max(np.percentile(np.abs(e), 99) for e in errs.values())
            for c, name in enumerate(FIG_SAMPLERS):
                ax = axes[r, c]
                ax.imshow(errs[name], cmap="RdBu", vmin=-lim, vmax=lim)
                ax.set_xticks([]), ax.set_yticks([])
                row = sres["samplers"][name][spp]
                ax.set_title(f"{name} ({row['spp_used']})\nE_low {row['elow']:.2f}", fontsize=7)
                if c == 0:
                    ax.set_ylabel(scene, fontsize=8)
        fig.suptitle(f"Luminance error (render - reference), {spp} spp, seed 0", fontsize=10)
        fig.tight_layout()
        p = FIGS / f"errors-{spp}spp.png"
        fig.savefig(p, dpi=80)
        plt.close(fig)
        made.append(p.name)
    fig, axes = plt.subplots(1, len(scenes), figsize=(3.6 * len(scenes), 3.3))
    for ax, scene in zip(axes, scenes):
        s = res["scenes"][scene]["samplers"]
        best = [min(s[n][spp]["mse"] for n in _fair(s, OTHERS, spp)) for spp in SPP]
        for name in ["independent", "ldsampler", *ANCHORS, "dpc"]:
            ax.semilogx(
                SPP,
                [s[name][spp]["mse"] / b for spp, b in zip(SPP, best)],
                "o-" if name == "dpc" else ".--",
                label=name,
                lw=2 if name == "dpc" else 1,
            )
        ax.set_ylim(0.4, 3)
        ax.set_yscale("log")
        ax.axhline(1, color="grey", lw=0.8)
        ax.set_xlabel("samples per pixel")
        ax.set_title(f"{scene}: MSE / best other", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=6)
    fig.tight_layout()
    p = FIGS / "mse.png"
    fig.savefig(p, dpi=80)
    plt.close(fig)
    made.append(p.name)
    fig, axes = plt.subplots(1, len(scenes), figsize=(3.6 * len(scenes), 3.3))
    for ax, scene in zip(axes, scenes):
        for name in FIG_SAMPLERS:
            f, pw = radial_power(np.asarray(res["scenes"][scene]["figure"][f"{name}|4"]))
            ax.plot(f, pw, "-" if name == "dpc" else "--", label=name, lw=2 if name == "dpc" else 1)
        ax.axvline(ISSUE_BAND, color="grey", lw=0.8)
        ax.set_xlabel("|nu| (cycles per pixel)")
        ax.set_title(f"{scene}, 4 spp, seed 0", fontsize=9)
        ax.set_yscale("log")
    axes[0].set_ylabel("error power (mean = 1)")
    axes[0].legend(fontsize=6)
    fig.tight_layout()
    p = FIGS / "spectra-4spp.png"
    fig.savefig(p, dpi=80)
    plt.close(fig)
    made.append(p.name)
    return made


def _name(n: str) -> str:
    return f"**{n}**" if n == "dpc" else n


def section(res: dict, checks, figs) -> str:
    L = [
        f"Measured by `python -m lab.rendering.bench_rendering` ({res['commit']}) on {res['cpu']}, one "
        f"thread per render, Mitsuba {res['mitsuba']} `scalar_rgb`, {res['width']} x {res['width']} pixels; "
        f"{res['seeds_low']} seeds per cell below 16 spp, {res['seeds_high']} from 16 on (the sampler's `seed` "
        f"property). Reference: ldsampler at {res['ref_spp']:,} spp, its own error subtracted from every MSE.",
        "",
    ]
    for scene, sres in res["scenes"].items():
        s = sres["samplers"]
        L += [f"### {scene}", "", f"{SCENES[scene]}. Reference's own MSE: {sres['ref_mse']:.1e}.", ""]
        L += ["Image MSE, mean over seeds (samples per pixel used in brackets where Mitsuba rounded):", ""]
        L += ["| sampler | " + " | ".join(f"{n}" for n in SPP) + " |", "|---|" + "---:|" * len(SPP)]
        for name in SAMPLERS:
            cells = []
            for spp in SPP:
                r = s[name][spp]
                cells.append(f"{r['mse']:.2e}" + (f" [{r['spp_used']}]" if r["spp_used"] != spp else ""))
            L.append(f"| {_name(name)} | " + " | ".join(cells) + " |")
        L += [
            "",
            "Screen-space low-frequency energy E_low (white = 1), and the blurred error as a ratio to the "
            "lowest built-in's, at 1-16 spp:",
            "",
        ]
        L += [
            "| sampler | "
            + " | ".join(f"E_low {n}" for n in SCREEN_SPP)
            + " | "
            + " | ".join(f"blur {n}" for n in SCREEN_SPP)
            + " |",
            "|---|" + "---:|" * (2 * len(SCREEN_SPP)),
        ]
        lowest = {spp: min(s[n][spp]["blur"] for n in _fair(s, BUILTINS, spp)) for spp in SCREEN_SPP}
        for name in SAMPLERS:
            used = {n: f" [{s[name][n]['spp_used']}]" if s[name][n]["spp_used"] != n else "" for n in SCREEN_SPP}
            el = [f"{s[name][spp]['elow']:.2f}{used[spp]}" for spp in SCREEN_SPP]
            bl = [f"{s[name][spp]['blur'] / lowest[spp]:.2f}{used[spp]}" for spp in SCREEN_SPP]
            L.append(f"| {_name(name)} | " + " | ".join(el + bl) + " |")
        tm = sres["timing"]
        L += [
            "",
            f"Render time at {TIME_SPP} spp, median of {TIME_REPEATS} renders each, in turn: "
            + ", ".join(f"{n} {tm[n]:.3f} s (x{tm[n] / tm['independent']:.2f})" for n in TIMED)
            + ".",
            "",
        ]
    met = sum(ok for _, ok, _ in checks)
    L += [f"### Goals ({met} of {len(checks)} met)", "", "| goal | met | measured |", "|---|---|---|"]
    L += [f"| {g} | {'yes' if ok else '**no**'} | {m} |" for g, ok, m in checks]
    L += [""] + [f"![{f}](figures/rendering/{f})" for f in figs] + [""]
    return "\n".join(L)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--width", type=int, default=128)
    ap.add_argument("--seeds-low", type=int, default=16)
    ap.add_argument("--seeds-high", type=int, default=8)
    ap.add_argument("--jobs", type=int, default=2, help="scenes rendered side by side (one thread each)")
    ap.add_argument("--quick", action="store_true", help="64 x 64 pixels, 3 seeds: a smoke run, writes nothing")
    ap.add_argument(
        "--only",
        help="comma-separated samplers to render again; the others' rows come from the last run's results.json",
    )
    ap.add_argument(
        "--report", action="store_true", help="rewrite the docs section from the last run's results.json (no renders)"
    )
    args = ap.parse_args()
    args.only = [n.strip() for n in args.only.split(",")] if args.only else None
    if args.only and not set(args.only) <= set(SAMPLERS):
        ap.error(f"--only: samplers among {', '.join(SAMPLERS)}")
    if args.report:
        res = load_results()
        figs = sorted(p.name for p in FIGS.glob("*.png"))
        replace_section(DOC, "bench_rendering", section(res, goals(res), figs))
        print(f"rewrote {DOC} from {CACHE / 'results.json'}")
        return
    args.ref_spp = REF_SPP
    if args.quick:
        args.width, args.seeds_low, args.seeds_high, args.ref_spp = 64, 3, 3, 1024
    res = run(args)
    checks = goals(res)
    print("\nGoals:")
    for g, ok, m in checks:
        print(f"  [{'met' if ok else 'MISSED'}] {g}: {m}")
    print(f"{sum(ok for _, ok, _ in checks)} of {len(checks)} goals met")
    if args.quick:
        return
    # a partial run has the error images of its own samplers only: the figures stay the last full run's
    figs = sorted(p.name for p in FIGS.glob("*.png")) if args.only else figures(res)
    CACHE.mkdir(parents=True, exist_ok=True)
    (CACHE / "results.json").write_text(
        json.dumps({**res, "scenes": {k: {**v, "figure": None} for k, v in res["scenes"].items()}})
    )
    replace_section(DOC, "bench_rendering", section(res, checks, figs))
    print(f"wrote {DOC} and {len(figs)} figures in {FIGS}")


if __name__ == "__main__":
    main()
