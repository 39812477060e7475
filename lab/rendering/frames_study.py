"""The sampler's frames (real-time use: 1 sample per pixel per frame, frames averaged), measured
on the synthetic integrand family and in Mitsuba 3.

    python -m lab.rendering.frames_study         # under a minute on 2 cores

A renderer that takes one sample per pixel per frame wants each frame's error blue in screen
space (what a viewer sees, and what a temporal filter smooths best) and the average of F frames
as good as one render of F samples per pixel. Three ways to use the sampler, F = 16:
- "frames": `frames = 16` (docs/rendering.md, "Frames"), frame f at 1 spp;
- "passes": no frames option, frame f as sample index f of a 1-spp sampler (later passes: each
  a new random shift of the 1-spp table, so every frame is blue but the frames are independent);
- "16 spp": the default sampler at 16 spp in one render, frame f as its sample f (what a
  renderer gets reading one sampler's samples one per frame), and the same render's MSE as the
  frames' target;
- in Mitsuba also "frames, fold": frames with `fold_from = 1` (the baker's transform on every
  dimension but the film position), which makes smooth integrands periodic over the shifts.
Part 1, synthetic (no renderer): bench_rendering's measure E_low (|nu| <= 1/8, a quarter of
Nyquist; white = 1) of each frame's error on a 64 x 64 screen and the 16-frame average's
per-pixel MSE, and for progressive use the same of the first k = 1, 2, 4, 8, 16 samples, on
a toroidal half-plane and a Gaussian lobe in one dimension pair and products of half-planes in
two (the family of the sampler's frame goal; tests/python/test_sampler.py checks
the same), 24 seeds.
Part 2, Mitsuba 3: bench_rendering's five scenes at 128 x 128 against its cached references (run
`python -m lab.rendering.bench_rendering` first), 4 seeds: per-frame E_low of the luminance error
and the 16-frame average's MSE over the 16-spp render's.
Writes the section `frames_study` of docs/reports/rendering-studies.md.
"""

from __future__ import annotations

import argparse
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import dpc
from lab.common import REPORTS, cpu_name, reference, replace_section
from lab.rendering import bench_rendering as br

DOC = REPORTS / "rendering-studies.md"
F = 16
WAYS = ("frames", "passes", "16 spp")
SCENE_WAYS = ("frames", "frames, fold", "passes", "16 spp")
EXTRA = {"frames": {"frames": F}, "frames, fold": {"frames": F, "fold_from": 1}, "passes": {}}


def half_plane(rng: np.random.Generator, p: np.ndarray) -> np.ndarray:
    a, o = rng.random() * 2 * np.pi, rng.random(2)
    d = p - o
    d -= np.rint(d)
    return (np.cos(a) * d[..., 0] + np.sin(a) * d[..., 1] > 0).astype(float)


PREFIXES = (1, 2, 4, 8, 16)


def family(seed: int, v1: np.ndarray, v2: np.ndarray) -> dict:
    """The synthetic integrands of seed on two dimensions' values: {name: (values, integral)}."""
    rng = np.random.default_rng(seed)
    c, w = rng.random(2), 0.15
    d = v1 - c
    d -= np.rint(d)
    return {
        "half-plane (2-D)": (half_plane(rng, v1), 0.5),
        "Gaussian lobe (2-D)": (np.exp(-(d**2).sum(-1) / (2 * w * w)), 2 * np.pi * w * w),
        "product of half-planes (4-D)": (half_plane(rng, v1) * half_plane(rng, v2), 0.25),
    }


def synthetic(seeds: int, width: int = 64) -> tuple[dict, dict]:
    """{(way, integrand): (per-frame E_low, 16-frame MSE)} and, for progressive use,
    {(way, integrand, k): (E_low, MSE) of the average of a pixel's first k samples} with way
    "k spp" a sampler of k samples per pixel; means over seeds."""
    ys, xs = np.mgrid[0:width, 0:width]
    frame = np.arange(F)[:, None, None]
    acc: dict = {}
    pre: dict = {}
    for seed in range(seeds):
        for k in PREFIXES:
            s = dpc.Sampler(samples_per_pixel=k, dimensions=3, seed=seed)
            v1, v2 = (s.get_2d(x=xs, y=ys, dimension=d, index=np.arange(k)[:, None, None]) for d in (1, 2))
            for name, (f, exact) in family(seed, v1.astype(np.float64), v2.astype(np.float64)).items():
                e = f.mean(0) - exact
                pre.setdefault(("k spp", name, k), []).append((br.low_band_energy(e, br.ISSUE_BAND), (e**2).mean()))
        samplers = {
            "frames": (dpc.Sampler(samples_per_pixel=1, dimensions=3, seed=seed, frames=F), dict(index=0, frame=frame)),
            "passes": (dpc.Sampler(samples_per_pixel=1, dimensions=3, seed=seed), dict(index=frame)),
            "16 spp": (dpc.Sampler(samples_per_pixel=F, dimensions=3, seed=seed), dict(index=frame)),
        }
        for way, (s, kw) in samplers.items():
            v1, v2 = (s.get_2d(x=xs, y=ys, dimension=d, **kw).astype(np.float64) for d in (1, 2))
            for name, (f, exact) in family(seed, v1, v2).items():
                el = np.mean([br.low_band_energy(e - exact, br.ISSUE_BAND) for e in f])
                acc.setdefault((way, name), []).append((el, ((f.mean(0) - exact) ** 2).mean()))
                for k in PREFIXES if way != "passes" else ():
                    e = f[:k].mean(0) - exact
                    pre.setdefault((way, name, k), []).append((br.low_band_energy(e, br.ISSUE_BAND), (e**2).mean()))
    mean = lambda d: {k: tuple(np.mean(v, axis=0)) for k, v in d.items()}  # noqa: E731
    return mean(acc), mean(pre)


def scene_rows(job) -> dict:
    """{way: (per-frame E_low, per-frame E_low's s.e., 16-frame MSE, its s.e.)} of one scene."""
    scene, seeds, width = job
    mi, anchors = br._mitsuba()
    ref, ref_mse = reference(mi, scene, width)
    out: dict = {}
    for way in SCENE_WAYS:
        els, mses = [], []
        for seed in range(seeds):
            if way == "16 spp":  # one render: its MSE the target; its frames not separable in Mitsuba
                img = br.render(mi, anchors, scene, "dpc", F, seed, width)[0]
                mses.append(float(((img - ref) ** 2).mean()) - ref_mse)
                continue
            imgs = [
                br.render(mi, anchors, scene, "dpc", 1, seed, width, {**EXTRA[way], "frame": f})[0] for f in range(F)
            ]
            els.append(np.mean([br.low_band_energy((i - ref).mean(-1), br.ISSUE_BAND) for i in imgs]))
            mses.append(float(((np.mean(imgs, axis=0) - ref) ** 2).mean()) - ref_mse)
        se = lambda v: float(np.std(v, ddof=1) / np.sqrt(len(v))) if len(v) > 1 else float("nan")  # noqa: E731
        out[way] = (float(np.mean(els)) if els else float("nan"), se(els), float(np.mean(mses)), se(mses))
        print(f"{scene:12s} {way:12s} E_low {out[way][0]:.3f}  MSE {out[way][2]:.3e}", flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--synthetic-seeds", type=int, default=24)
    ap.add_argument("--width", type=int, default=128)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    syn, pre = synthetic(args.synthetic_seeds)
    scenes = list(br.SCENES)
    with ProcessPoolExecutor(args.jobs) as ex:
        rows = dict(zip(scenes, ex.map(scene_rows, [(s, args.seeds, args.width) for s in scenes])))
    names = sorted({k[1] for k in syn}, key=lambda n: ("4-D" in n, n))
    L = [
        f"Measured by `python -m lab.rendering.frames_study` on {cpu_name()}: 16 frames of 1 sample per pixel. "
        "E_low: mean over the frames of each frame's error image's low-frequency energy "
        "(|nu| <= 1/8, white = 1); MSE: the 16 frames' average against the integral.",
        "",
        f"Synthetic (64 x 64 pixels, {args.synthetic_seeds} seeds; '16 spp' read one sample per frame):",
        "",
        "| integrand | " + " | ".join(f"E_low {w}" for w in WAYS) + " | MSE frames / 16 spp | MSE passes / 16 spp |",
        "|---|" + "---:|" * (len(WAYS) + 2),
    ]
    for n in names:
        el = [f"{syn[(w, n)][0]:.2f}" for w in WAYS]
        base = syn[("16 spp", n)][1]
        L.append(
            f"| {n} | "
            + " | ".join(el)
            + f" | {syn[('frames', n)][1] / base:.2f} | {syn[('passes', n)][1] / base:.2f} |"
        )
    L += [
        "",
        "Progressive use (synthetic, the same seeds): a renderer that stops after the first k of a pixel's 16 "
        "samples. E_low of the average of the first k, and its MSE over that of a sampler made for k samples "
        "per pixel ('k spp', the default options, whose rows give its own E_low):",
        "",
        "| integrand | way | "
        + " | ".join(f"E_low {k}" for k in PREFIXES)
        + " | "
        + " | ".join(f"MSE {k} / k spp" for k in PREFIXES)
        + " |",
        "|---|---|" + "---:|" * (2 * len(PREFIXES)),
    ]
    for n in names:
        for way in ("frames", "16 spp", "k spp"):
            el = [f"{pre[(way, n, k)][0]:.2f}" for k in PREFIXES]
            ms = [f"{pre[(way, n, k)][1] / pre[('k spp', n, k)][1]:.2f}" for k in PREFIXES]
            L.append(f"| {n} | {way} | " + " | ".join(el + ms) + " |")
    L += [
        "",
        f"Mitsuba 3 (bench_rendering's scenes, {args.width} x {args.width} pixels, {args.seeds} seeds; "
        "the 16-spp render's MSE the target, ± the standard error over seeds):",
        "",
        "| scene | E_low frames | E_low frames, fold | E_low passes | MSE 16 spp | MSE frames / 16 spp "
        "| MSE frames, fold / 16 spp | MSE passes / 16 spp |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for scene in scenes:
        r = rows[scene]
        base = r["16 spp"][2]
        el = " | ".join(f"{r[w][0]:.2f} ± {r[w][1]:.2f}" for w in ("frames", "frames, fold", "passes"))
        ratios = " | ".join(f"{r[w][2] / base:.2f}" for w in ("frames", "frames, fold", "passes"))
        L.append(f"| {scene} | {el} | {base:.2e} ± {r['16 spp'][3]:.1e} | {ratios} |")
    replace_section(DOC, "frames_study", "\n".join(L) + "\n")
    print("\n".join(L))
    print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
