"""The rendering bench's scenes in Mitsuba 3's spectral mode (scalar_spectral), where the sampler's
1-D values meet hero-wavelength sampling.

    python -m lab.rendering.spectral_study       # about ten minutes on 2 cores
    python -m lab.rendering.spectral_study --only dpc   # re-render dpc, keep the others' last cells

Mitsuba's spectral mode draws a camera ray's four wavelengths from one 1-D value v, at v + i/4
(hero-wavelength sampling, Wilkie et al. 2014), as pbrt-v4 does. dpc's 1-D values are made to fill
the 4n strata that gives at n samples per pixel (docs/rendering.md, "Screen-space
decorrelation"); the bench (lab.rendering.bench_rendering) renders in scalar_rgb, where no
wavelength is drawn. Here the bench's five scenes are rendered in scalar_spectral by dpc, Mitsuba's
built-ins and the bench's anchors, at 2, 4, 16 and 64 spp over 8 seeds, 128 x 128 pixels; the
reference is ldsampler at 4,096 spp (two halves of other seeds, its own error subtracted), in the
same mode. Per cell: image MSE with its standard error, the bench's E_low (|nu| <= 1/8) and its
blurred error. Writes the section `spectral_study` of docs/reports/rendering-studies.md.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from lab.common import CACHE, REPORTS, cpu_name, ratio_se, replace_section
from lab.rendering import bench_rendering as br

DOC = REPORTS / "rendering-studies.md"
VARIANT = "scalar_spectral"
COUNTS = (2, 4, 16, 64)
SAMPLERS = ["independent", "multijitter", "ldsampler", "zsobol", "padded_sobol", "owen_sobol", "pmj02bn", "heitz2019"]
REF_SPP = 4096
WIDTH = 128  # the anchors' block size: a power of two
RESULTS = CACHE / f"spectral-study-{WIDTH}.json"  # the last run's cells, for --only


def _mitsuba():
    import mitsuba as mi  # noqa: PLC0415

    mi.set_variant(VARIANT)
    import dpc.mitsuba  # noqa: F401,PLC0415  (registers "dpc")
    from lab.rendering import anchors  # noqa: PLC0415

    anchors.register(mi)
    return mi, anchors


def reference(mi, anchors, scene: str) -> tuple[np.ndarray, float]:
    """ldsampler at REF_SPP in VARIANT, two halves of other seeds (cached), and its own MSE."""
    path = CACHE / f"ref-{VARIANT}-{scene}-{WIDTH}-{REF_SPP}.npz"
    if path.is_file():
        z = np.load(path)
        return z["ref"], float(z["ref_mse"])
    halves = [br.render(mi, anchors, scene, "ldsampler", REF_SPP // 2, 1000 + k, WIDTH)[0] for k in range(2)]
    ref = 0.5 * (halves[0] + halves[1])
    ref_mse = float(((halves[0] - halves[1]) ** 2).mean() / 4)
    CACHE.mkdir(parents=True, exist_ok=True)
    np.savez(path, ref=ref, ref_mse=ref_mse)
    return ref, ref_mse


def scene_rows(job) -> dict:
    """{(sampler, spp): {mse, mse_se, elow, blur, blur_se}} of one scene, for the given samplers."""
    scene, seeds, samplers = job
    mi, anchors = _mitsuba()
    ref, ref_mse = reference(mi, anchors, scene)
    out = {}
    for sampler in samplers:
        for spp in COUNTS:
            mse, el, blur = [], [], []
            for seed in range(seeds):
                img, _, used = br.render(mi, anchors, scene, sampler, spp, seed, WIDTH)
                if used != spp:  # Mitsuba rounded the count (ldsampler: powers of 4): not compared
                    break
                err = img - ref
                lum = err.mean(-1)
                mse.append(float((err**2).mean()) - ref_mse)
                el.append(br.low_band_energy(lum, br.ISSUE_BAND))
                blur.append(br.blurred_error(lum))
            if not mse:
                continue
            se = np.sqrt(seeds)
            out[(sampler, spp)] = {
                "mse": float(np.mean(mse)),
                "mse_se": float(np.std(mse, ddof=1) / se),
                "elow": float(np.mean(el)),
                "blur": float(np.mean(blur)),
                "blur_se": float(np.std(blur, ddof=1) / se),
            }
        got = [f"{out[(sampler, n)]['mse']:.3e}" if (sampler, n) in out else "rounded" for n in COUNTS]
        print(f"{scene:12s} {sampler:13s} " + " ".join(got), flush=True)
    return out


def section(rows: dict, seeds: int) -> str:
    L = [
        f"Measured by `python -m lab.rendering.spectral_study` on {cpu_name()}: Mitsuba {VARIANT}, the bench's "
        f"scenes at {WIDTH} x {WIDTH} pixels, {seeds} seeds, reference ldsampler at {REF_SPP:,} spp in the same "
        "mode. dpc's image MSE over the best other sampler's (which, in brackets) and over ZSobol's, with "
        "standard errors; E_low (white = 1) of dpc and ZSobol; dpc's blurred error over the lowest other "
        "sampler's. A sampler whose count Mitsuba rounds (ldsampler at 2 spp) is left out of that count.",
        "",
        "| scene | spp | dpc MSE | over the best other's | over ZSobol's | E_low dpc / ZSobol "
        "| blurred, over the lowest other's |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for scene, r in rows.items():
        for spp in COUNTS:
            d = r[("dpc", spp)]
            others = [s for s in SAMPLERS if (s, spp) in r]
            best = min(others, key=lambda s: r[(s, spp)]["mse"])
            low = min(others, key=lambda s: r[(s, spp)]["blur"])
            b, z, lo = r[(best, spp)], r[("zsobol", spp)], r[(low, spp)]
            rb, seb = ratio_se(d["mse"], d["mse_se"], b["mse"], b["mse_se"])
            rz, sez = ratio_se(d["mse"], d["mse_se"], z["mse"], z["mse_se"])
            rl, sel = ratio_se(d["blur"], d["blur_se"], lo["blur"], lo["blur_se"])
            L.append(
                f"| {scene} | {spp} | {d['mse']:.2e} | x{rb:.2f} ± {seb:.2f} ({best}) | x{rz:.2f} ± {sez:.2f} | "
                f"{d['elow']:.2f} / {z['elow']:.2f} | x{rl:.2f} ± {sel:.2f} ({low}) |"
            )
    return "\n".join(L) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--jobs", type=int, default=2, help="scenes rendered side by side (one thread each)")
    ap.add_argument("--only", help="re-render these samplers (comma-separated), keep the last run's others")
    args = ap.parse_args()
    scenes = list(br.SCENES)
    samplers = ["dpc", *SAMPLERS]
    only = args.only.split(",") if args.only else samplers
    if not set(only) <= set(samplers):
        ap.error(f"--only: samplers among {', '.join(samplers)}")
    last = json.loads(RESULTS.read_text()) if args.only else {"seeds": args.seeds, "scenes": {}}
    args.seeds = last["seeds"]
    # spawned workers: Mitsuba's thread pool does not survive a fork
    with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("spawn")) as ex:
        new = dict(zip(scenes, ex.map(scene_rows, [(s, args.seeds, only) for s in scenes])))
    for scene in scenes:  # JSON keeps the cells as "sampler|spp"
        cells = last["scenes"].setdefault(scene, {})
        cells.update({f"{s}|{n}": v for (s, n), v in new[scene].items()})
        for s in only:  # a count rounded now is not kept from before
            for n in COUNTS:
                if (s, n) not in new[scene]:
                    cells.pop(f"{s}|{n}", None)
    RESULTS.write_text(json.dumps(last))
    rows = {sc: {(k.split("|")[0], int(k.split("|")[1])): v for k, v in c.items()} for sc, c in last["scenes"].items()}
    text = section(rows, args.seeds)
    replace_section(DOC, "spectral_study", text)
    print(text)
    print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
