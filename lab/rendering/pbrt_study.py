"""dpc's sampler in pbrt-v4 (`Sampler "dpc"`, integrations/pbrt-v4/) against every pbrt-v4 sampler.

    python -m lab.rendering.pbrt_study --pbrt PATH [--width 96] [--seeds 8] [--quick]

PATH is a pbrt-v4 binary built with dpc's sampler (integrations/pbrt-v4/). Two measurements:

1. pbrt's `Integrator "function"`: each pixel of a FUNC_RES x FUNC_RES film integrates one of
   pbrt's analytic 2-D functions (step, diagonal, disk, checkerboard, rotatedcheckerboard,
   gaussian; each integrates to 1 over the unit square) with the sampler's pixel samples
   (GetPixel2D), and pbrt writes the MSE over the pixels. One run per (function, sampler, spp)
   with `--spp` = that count, so a sampler's table is the one made for that count (a prefix of a
   256-sample table would not be). pbrt rejects `sobol` there; halton, paddedsobol and stratified
   are replaced by pbrt's own per-pixel randomisations (they ignore --seed).
2. Three scenes of ours (lab/rendering/pbrt_scenes/): soft-shadow (direct light from a large area
   light, maxdepth 1), indirect (path-traced, maxdepth 5, lit by a small emitter facing the
   ceiling) and aliasing (thin lines and poles under a distant light, direct only: the pixel
   position is the integrand). Box pixel filter. For every sampler, spp in SCENE_SPP and seeds
   0 .. --seeds-1 (pbrt's --seed): image MSE against a reference, the error image's screen-space
   low-frequency energy E_low (the Mitsuba study's measure, lab.rendering.bench_rendering:
   mean power over 0 < |nu| <= 3/16 cycles per pixel over the mean over all nu != 0, on the
   channel mean; white noise = 1), and the wall-clock time of the pbrt process (--nthreads,
   startup and the sampler's table making included) relative to independent's at the same spp
   (median over seeds; the samplers of one seed run one after the other, so load hits all alike).
   In the cells of the E_low goals, dpc's and ZSobol's blurred error too (the Mitsuba study's: the
   mean square of the channel-mean error blurred by a Gaussian of sigma = 1.5 px, what a viewer or
   a denoiser keeps), since E_low is a share of each sampler's own error.
   Reference: zsobol at REF_SPP, two halves of other seeds (their difference gives its own MSE,
   which every cell's MSE includes), cached under --cache.

Writes docs/reports/pbrt.md and docs/reports/figures/pbrt/*.png (not with --quick) and prints the
goals: dpc's MSE <= ZSobol's and PaddedSobol's at 16-256 spp in every scene, dpc's E_low <=
ZSobol's at 1-16 spp. PMJ02BN's numbers come from regenerated tables
(integrations/pbrt-v4/make_tables.py), not the ones pbrt-v4 publishes.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from lab.common import REPORTS, ROOT, cpu_name, ratio_se, report_header
from lab.rendering.bench_rendering import blurred_error, low_band_energy

PAGE = REPORTS / "pbrt.md"
FIGS = REPORTS / "figures" / "pbrt"
SCENE_DIR = Path(__file__).resolve().parent / "pbrt_scenes"
PBRT_SHOWN = "BUILD_DIR/build/pbrt"
DEFAULT_CACHE = ROOT / "build" / "pbrt-study"  # ignored by git

SAMPLERS = ["independent", "stratified", "halton", "sobol", "paddedsobol", "zsobol", "pmj02bn", "dpc"]
# the Mitsuba plugin's default model (python/dpc/mitsuba), named explicitly
DPC_MODEL = "bnot-2d-stratified"
FUNCTIONS = ["step", "diagonal", "disk", "checkerboard", "rotatedcheckerboard", "gaussian"]
FUNC_SPP = [4, 16, 64, 256]
FUNC_RES = 128
SCENES = ["soft-shadow", "indirect", "aliasing"]
SCENE_SPP = [1, 2, 4, 8, 16, 32, 64, 256]
MSE_GOAL_SPP = [16, 64, 256]
ELOW_GOAL_SPP = [1, 4, 16]
BLURRED = ("dpc", "zsobol")  # whose blurred error the E_low goals' cells also measure
REF_SAMPLER = "zsobol"
REF_SPP = 8192
REF_SEEDS = (1000, 1001)
FIG_SPP = (1, 4)
# Diagnostics below 32 spp, not candidates: dpc with its documented switches (docs/rendering.md):
# nets in every slot (libdpc's default, where the integration's stops after the light sample),
# nets digitally shifted per pixel instead of screen-ordered, and blue-noise sets instead of nets
# in the slots after the pixel position, unfolded and folded.
VARIANTS = {
    "dpc nets in every slot": '"integer net_dims" -1',
    "dpc nets per pixel": '"string net_layout" "pixel"',
    "dpc sets": '"integer net_dims" 1 "string net_layout" "pixel"',
    "dpc folded sets": '"integer net_dims" 1 "string net_layout" "pixel" "integer fold_from" 1',
}
VARIANT_SPP = [2, 4, 8, 16]


# ----------------------------------------------------------------------------------------------
# reductions (pure: tested in tests/python/test_pbrt_study.py)


def read_pfm(path: Path) -> np.ndarray:
    """A PFM file (pbrt writes 3-channel 'PF', rows bottom to top) as (height, width, 3) float64, top row first."""
    data = path.read_bytes()
    parts, pos = [], 0
    while len(parts) < 4:  # magic, width, height, scale: whitespace-separated tokens
        while data[pos : pos + 1].isspace():
            pos += 1
        end = pos
        while not data[end : end + 1].isspace():
            end += 1
        parts.append(data[pos:end].decode())
        pos = end
    pos += 1  # the single whitespace byte after the scale
    magic, w, h, scale = parts[0], int(parts[1]), int(parts[2]), float(parts[3])
    channels = {"PF": 3, "Pf": 1}[magic]
    dtype = "<f4" if scale < 0 else ">f4"
    img = np.frombuffer(data, dtype=dtype, count=w * h * channels, offset=pos).reshape(h, w, channels)
    return img[::-1].astype(np.float64)


def image_stats(img: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    """(MSE over pixels and channels, E_low of the channel-mean error image)."""
    err = img - ref
    return float((err**2).mean()), low_band_energy(err.mean(-1))


def mean_se(values) -> tuple[float, float]:
    """Mean and its standard error (0 for one value)."""
    v = np.asarray(values, dtype=np.float64)
    se = float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else 0.0
    return float(v.mean()), se


def parse_function_mse(text: str) -> dict[int, float]:
    """pbrt's function integrator output: lines 'spp mse'."""
    out = {}
    for line in text.split("\n"):
        if line.strip():
            n, v = line.split()
            out[int(n)] = float(v)
    return out


def miss_percent(r: float) -> str:
    """How far a ratio above 1 misses, in percent (one decimal below 10%)."""
    m = 100 * (r - 1)
    return f"{m:.1f}%" if m < 10 else f"{m:.0f}%"


def verdict(r: float, se: float) -> str:
    """A ratio's words: for one above 1, whether it is more than two standard errors above."""
    if r <= 1:
        return f"x{r:.2f} ± {se:.2f}"
    side = "more than 2 standard errors above 1" if r - 1 > 2 * se else "within 2 standard errors of 1"
    return f"x{r:.2f} ± {se:.2f}, {side}"


# ----------------------------------------------------------------------------------------------
# running pbrt


def sampler_line(name: str) -> str:
    if name == "dpc":
        return f'Sampler "dpc" "string model" "{DPC_MODEL}"'
    if name.startswith("dpc "):  # a diagnostic variant: dpc with extra parameters
        return f'Sampler "dpc" "string model" "{DPC_MODEL}" {VARIANTS[name]}'
    return f'Sampler "{name}"'


class Pbrt:
    def __init__(self, exe: Path, nthreads: int, env: dict, work: Path):
        self.exe, self.nthreads, self.env, self.work = exe, nthreads, env, work

    def run(self, text: str, spp: int, seed: int, out: Path | None) -> float:
        """Renders a scene text; the wall-clock seconds of the pbrt process."""
        scene = self.work / "scene.pbrt"
        scene.write_text(text)
        cmd = ["nice", "-n", "10", str(self.exe), "--quiet", "--nthreads", str(self.nthreads)]
        cmd += ["--seed", str(seed), "--spp", str(spp)]
        if out is not None:
            cmd += ["--outfile", str(out)]
        cmd.append(str(scene))
        t = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True, env=self.env, cwd=self.work)
        dt = time.perf_counter() - t
        if p.returncode != 0:
            raise RuntimeError(f"pbrt failed ({p.returncode}): {shlex.join(cmd)}\n{text}\n{p.stdout}\n{p.stderr}")
        return dt

    def render(self, scene: str, sampler: str, spp: int, seed: int, width: int) -> tuple[np.ndarray, float]:
        text = "\n".join(
            [
                f'Film "rgb" "integer xresolution" {width} "integer yresolution" {width} "string filename" "out.pfm"',
                'PixelFilter "box"',
                sampler_line(sampler),
                f'Include "{SCENE_DIR / (scene + ".pbrt")}"',
                "",
            ]
        )
        out = self.work / "out.pfm"
        if out.exists():
            out.unlink()
        dt = self.run(text, spp, seed, out)
        return read_pfm(out), dt

    def function_mse(self, func: str, sampler: str, spp: int, seed: int) -> float:
        mse_file = self.work / "function-mse.txt"
        if mse_file.exists():
            mse_file.unlink()
        # halton reports only at 2^a 3^a unless skipbad is off; stratified recomputes every square
        # count from scratch, which skipbad (on) limits to the squares
        skip = "false" if sampler == "halton" else "true"
        text = "\n".join(
            [
                f'Film "rgb" "integer xresolution" {FUNC_RES} "integer yresolution" {FUNC_RES}',
                sampler_line(sampler),
                'Camera "perspective"',
                f'Integrator "function" "string function" "{func}" "string filename" "{mse_file}" '
                f'"bool skipbad" {skip}',
                "WorldBegin",
                "",
            ]
        )
        self.run(text, spp, seed, None)
        got = parse_function_mse(mse_file.read_text())
        if spp not in got:
            raise RuntimeError(f"function integrator: no line for {spp} spp in {mse_file}: {sorted(got)}")
        return got[spp]


# ----------------------------------------------------------------------------------------------
# the study


class Cache:
    """Results of single renders, keyed by everything that decides them, kept across runs."""

    def __init__(self, path: Path):
        self.path = path
        self.data = json.loads(path.read_text()) if path.is_file() else {}

    def get(self, key: str):
        return self.data.get(key)

    def put(self, key: str, value) -> None:
        self.data[key] = value
        tmp = self.path.with_suffix(".tmp")
        tmp.write_text(json.dumps(self.data))
        tmp.replace(self.path)


def file_digest(*paths: Path) -> str:
    h = hashlib.sha256()
    for p in paths:
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def reference(pb: Pbrt, cache_dir: Path, scene: str, width: int, ref_spp: int, tag: str):
    path = cache_dir / f"ref-{scene}-{width}-{REF_SAMPLER}-{ref_spp}-{tag}.npz"
    if path.is_file():
        z = np.load(path)
        return z["ref"], float(z["ref_mse"]), float(z["seconds"])
    t = time.perf_counter()
    halves = [pb.render(scene, REF_SAMPLER, ref_spp // 2, s, width)[0] for s in REF_SEEDS]
    ref = 0.5 * (halves[0] + halves[1])
    ref_mse = float(((halves[0] - halves[1]) ** 2).mean() / 4)  # the mean of two halves' own error
    seconds = time.perf_counter() - t
    np.savez(path, ref=ref, ref_mse=ref_mse, seconds=seconds)
    return ref, ref_mse, seconds


def run_functions(pb: Pbrt, cache: Cache, tags: tuple[str, str], samplers: list[str]) -> dict:
    res = {}
    for func in FUNCTIONS:
        for spp in FUNC_SPP:
            for sampler in samplers:
                if sampler == "sobol":
                    continue  # pbrt: '"sobol" sampler should be replaced with "paddedsobol"'
                key = f"func|{tags[sampler == 'dpc']}|{func}|{sampler}|{spp}|{FUNC_RES}"
                v = cache.get(key)
                if v is None:
                    t = time.perf_counter()
                    mse = pb.function_mse(func, sampler, spp, 0)
                    v = {"mse": mse, "time": time.perf_counter() - t}
                    cache.put(key, v)
                res.setdefault(func, {}).setdefault(sampler, {})[spp] = v
        row = "  ".join(f"{s} {res[func][s][16]['mse']:.2e}" for s in samplers if s != "sobol")
        print(f"function {func}, 16 spp: {row}", flush=True)
    return res


def run_scenes(pb: Pbrt, cache: Cache, cache_dir: Path, tags: tuple[str, str], args, samplers: list[str]) -> dict:
    res = {}
    for scene in SCENES:
        sdig = file_digest(SCENE_DIR / f"{scene}.pbrt")
        # keyed by the scene, not the binary: zsobol and pbrt's core do not change with dpc's sampler
        ref, ref_mse, ref_s = reference(pb, cache_dir, scene, args.width, args.ref_spp, sdig)
        print(f"{scene}: reference {REF_SAMPLER} {args.ref_spp} spp ({ref_s:.0f} s), its own MSE {ref_mse:.2e}")
        rows = {s: {} for s in samplers}
        figs = {}
        t_scene = time.perf_counter()
        for spp in SCENE_SPP:
            per = {s: {"mse": [], "elow": [], "time": [], "blur": []} for s in samplers}
            for seed in range(args.seeds):
                for sampler in samplers:  # one seed's samplers back to back: load hits all alike
                    tag = tags[sampler == "dpc"]
                    key = f"scene|{tag}|{sdig}|{scene}|{sampler}|{spp}|{seed}|{args.width}|{args.ref_spp}"
                    fig_path = cache_dir / f"err-{tag}-{sdig}-{scene}-{sampler}-{spp}-{args.width}.npy"
                    v = cache.get(key)
                    blur = spp in ELOW_GOAL_SPP and sampler in BLURRED
                    if (
                        v is None
                        or (blur and "blur" not in v)
                        or (seed == 0 and spp in FIG_SPP and not fig_path.is_file())
                    ):
                        img, dt = pb.render(scene, sampler, spp, seed, args.width)
                        mse, el = image_stats(img, ref)
                        # a cell rendered again for its blurred error keeps the time of its first render
                        v = {"mse": mse, "elow": el, "time": dt if v is None else v["time"]}
                        if blur:
                            v["blur"] = blurred_error((img - ref).mean(-1))
                        cache.put(key, v)
                        if seed == 0 and spp in FIG_SPP:
                            np.save(fig_path, (img - ref).mean(-1).astype(np.float32))
                    if seed == 0 and spp in FIG_SPP:
                        figs[(sampler, spp)] = np.load(fig_path)
                    for k in per[sampler]:
                        if k in v:
                            per[sampler][k].append(v[k])
            for sampler in samplers:
                m, m_se = mean_se(per[sampler]["mse"])
                e, e_se = mean_se(per[sampler]["elow"])
                rows[sampler][spp] = {
                    "mse": m,
                    "mse_se": m_se,
                    "elow": e,
                    "elow_se": e_se,
                    "time": float(np.median(per[sampler]["time"])),
                    "total_time": float(np.sum(per[sampler]["time"])),
                }
                if per[sampler]["blur"]:
                    rows[sampler][spp]["blur"], rows[sampler][spp]["blur_se"] = mean_se(per[sampler]["blur"])
            line = "  ".join(f"{s} {rows[s][spp]['mse']:.2e}/{rows[s][spp]['elow']:.2f}" for s in samplers)
            print(f"  {spp:3d} spp MSE/E_low: {line}  [{time.perf_counter() - t_scene:.0f} s]", flush=True)
        res[scene] = {"ref_mse": ref_mse, "ref_seconds": ref_s, "rows": rows, "figs": figs}
    return res


def run_variants(pb: Pbrt, cache: Cache, cache_dir: Path, tag: str, args) -> dict:
    """dpc's diagnostic variants: mean MSE (± standard error) over the seeds per scene and spp."""
    res = {}
    for scene in SCENES:
        sdig = file_digest(SCENE_DIR / f"{scene}.pbrt")
        ref = reference(pb, cache_dir, scene, args.width, args.ref_spp, sdig)[0]
        for name in VARIANTS:
            for spp in VARIANT_SPP:
                mses = []
                for seed in range(args.seeds):
                    key = f"variant|{tag}|{sdig}|{scene}|{VARIANTS[name]}|{spp}|{seed}|{args.width}|{args.ref_spp}"
                    v = cache.get(key)
                    if v is None:
                        img, dt = pb.render(scene, name, spp, seed, args.width)
                        v = {"mse": image_stats(img, ref)[0], "time": dt}
                        cache.put(key, v)
                    mses.append(v["mse"])
                m, se = mean_se(mses)
                res.setdefault(scene, {}).setdefault(name, {})[spp] = {"mse": m, "mse_se": se}
        print(f"{scene} variants: " + "  ".join(f"{n} {res[scene][n][16]['mse']:.2e}" for n in VARIANTS), flush=True)
    return res


def variant_section(res: dict) -> list[str]:
    v = res.get("variants")
    if not v:
        return []
    L = [
        "## Diagnostics: dpc's switches below 32 spp",
        "",
        "Not candidates and not tuned: dpc with its documented switches (docs/rendering.md) set to "
        "put nets in every slot (libdpc's default; the integration's stops after the first light "
        "sample, slot 5), to lay the nets out per pixel instead of in screen order, or to serve the "
        "slots after the pixel position with blue-noise sets, unfolded and folded, rendered with the "
        "same seeds, to show what the default's screen-ordered nets gain or lose below 32 spp. "
        + "; ".join(f"`{n}`: `{VARIANTS[n]}`" for n in VARIANTS)
        + ". MSE over the default dpc's (below 1: the switch lowers the MSE) and, for scale, ZSobol's "
        "and PaddedSobol's MSE over the default dpc's.",
        "",
        "| scene | spp | " + " | ".join(VARIANTS) + " | zsobol | paddedsobol |",
        "|---|---:|" + "---:|" * (len(VARIANTS) + 2),
    ]
    for scene, by in v.items():
        rows = res["scenes"][scene]["rows"]
        for spp in VARIANT_SPP:
            d = rows["dpc"][spp]
            cells = []
            for n in VARIANTS:
                r, se = ratio_se(by[n][spp]["mse"], by[n][spp]["mse_se"], d["mse"], d["mse_se"])
                cells.append(f"{r:.2f} ± {se:.2f}")
            cells += [f"{rows[o][spp]['mse'] / d['mse']:.2f}" for o in ("zsobol", "paddedsobol")]
            L.append(f"| {scene} | {spp} | " + " | ".join(cells) + " |")
    return L + [""]


# ----------------------------------------------------------------------------------------------
# goals


def mse_cause(scene: str, spp: int, other: str, clear: bool) -> str:
    """Likely cause of dpc's MSE above other's; clear: more than two standard errors above."""
    if spp < 64 and other == "zsobol" and clear:
        return (
            "not isolated: below 64 spp dpc's nets are screen-ordered like ZSobol's but in 32 x 32 tiles, "
            "each tile Owen-scrambled on its own, where ZSobol orders and scrambles the whole image; "
            "dpc's MSE here is PaddedSobol's or lower, and ZSobol's is below both"
        )
    if spp < 64 and other == "zsobol":
        return (
            "below 64 spp dpc's nets are screen-ordered like ZSobol's (one Owen-scrambled Sobol' "
            "sequence per 32 x 32 tile, pixels in a randomised Morton order), so a small miss here is "
            "within what the hashes, the pairing of slots and the seeds' noise give (see the standard error)"
        )
    if other == "zsobol":
        return (
            "likely the structure across dimensions: ZSobol draws one Owen-scrambled Sobol' point over all "
            "of a camera sample's dimensions (pbrt's wavelength Get1D, the pixel position, the light and "
            "BSDF samples), so they are stratified jointly, while dpc pads per-pair nets whose pairing "
            "across slots is a per-pixel rotation (docs/rendering.md, 'One dpc set per dimension')"
        )
    return (
        "both pad Owen-scrambled nets (dpc's one scramble per slot, digitally shifted, shuffled and "
        "rotated per pixel; PaddedSobol's scrambled anew per pixel), so a small miss here is within what "
        "the pairing and the seeds' noise give (see the standard error)"
    )


def elow_cause(spp: int, blur_lower: bool = False) -> str:
    """Likely cause of dpc's E_low above ZSobol's; blur_lower: dpc's blurred error is more than two
    standard errors below ZSobol's."""
    if blur_lower:
        return (
            "E_low is a share of each sampler's own error, and dpc's error is the smaller: its blurred "
            "error (what a viewer or a denoiser keeps) is below ZSobol's, as is its MSE. ZSobol's larger "
            "error is likely most of it the wavelengths' (pbrt draws four hero wavelengths from one 1-D "
            "value, whose strata dpc's 1-D values fill: docs/rendering.md), which screen order makes "
            "blue; what is left of dpc's has a larger low-band share"
        )
    if spp == 1:
        return (
            "likely the mix of dimensions: at 1 spp dpc's screen-space structure is each slot's per-pixel "
            "shift, and the error mixes several slots (wavelength, pixel position, light and BSDF samples) "
            "whose shifts are decorrelated, while ZSobol's Morton-ordered index changes all of a pixel's "
            "dimensions against its neighbours' at once"
        )
    if spp >= 64:
        return (
            "from 64 spp on dpc's nets are digitally shifted per pixel, whose error is white across "
            "pixels (docs/rendering.md, 'Screen-ordered nets'), while ZSobol stays Morton-ordered"
        )
    return (
        "the slots up to the first light sample get dpc's screen-ordered nets (in 32 x 32 tiles; ZSobol "
        "orders the whole image), the BSDF samples and later bounces dpc's sets (the integration's "
        "default; nets there too: 'dpc nets in every slot' in the diagnostics), "
        "whose error is not ordered across pixels above 1 spp, so where those slots carry the error (the "
        "path-traced scene) E_low is higher; elsewhere a miss is within what the tiles' edges, the "
        "hashes and the seeds' noise give"
    )


def goals(scenes: dict) -> list[tuple[str, bool, str, str]]:
    """(goal, met, measured, likely cause of a miss or "")."""
    out = []
    for scene, s in scenes.items():
        rows = s["rows"]
        for spp in MSE_GOAL_SPP:
            for other in ("zsobol", "paddedsobol"):
                d, b = rows["dpc"][spp], rows[other][spp]
                r, se = ratio_se(d["mse"], d["mse_se"], b["mse"], b["mse_se"])
                text = f"{d['mse']:.3e} vs {b['mse']:.3e} ({verdict(r, se)})"
                cause = ""
                if r > 1:
                    text += f"; miss by {miss_percent(r)}"
                    cause = mse_cause(scene, spp, other, r - 2 * se > 1)
                out.append((f"{scene}, {spp} spp: dpc MSE <= {other}'s", r <= 1, text, cause))
        for spp in ELOW_GOAL_SPP:
            d, b = rows["dpc"][spp], rows["zsobol"][spp]
            r, se = ratio_se(d["elow"], d["elow_se"], b["elow"], b["elow_se"])
            text = f"{d['elow']:.3f} vs {b['elow']:.3f} ({verdict(r, se)})"
            blur_lower = False
            if "blur" in d and "blur" in b:
                rb, seb = ratio_se(d["blur"], d["blur_se"], b["blur"], b["blur_se"])
                text += f"; blurred error x{rb:.2f} ± {seb:.2f}"
                blur_lower = rb + 2 * seb < 1
            cause = ""
            if r > 1:
                text += f"; miss by {miss_percent(r)}"
                cause = elow_cause(spp, blur_lower)
            out.append((f"{scene}, {spp} spp: dpc E_low <= zsobol's", r <= 1, text, cause))
    return out


# ----------------------------------------------------------------------------------------------
# the page


def save_small(fig, path: Path) -> None:
    """A figure as a PNG of at most 64 colours (the pages' figures stay small in the repository)."""
    from PIL import Image

    fig.savefig(path, dpi=72)
    Image.open(path).convert("RGB").quantize(colors=64).save(path, optimize=True)


def figures(scenes: dict, samplers: list[str]) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    FIGS.mkdir(parents=True, exist_ok=True)
    made = []
    for spp in FIG_SPP:
        fig, axes = plt.subplots(len(scenes), len(samplers), figsize=(1.25 * len(samplers), 1.4 * len(scenes)))
        for r, (scene, s) in enumerate(scenes.items()):
            lim = max(float(np.percentile(np.abs(s["figs"][(n, spp)]), 99)) for n in samplers) or 1.0
            for c, name in enumerate(samplers):
                ax = axes[r, c]
                ax.imshow(s["figs"][(name, spp)], cmap="RdBu", vmin=-lim, vmax=lim, interpolation="nearest")
                ax.set_xticks([]), ax.set_yticks([])
                if r == 0:
                    ax.set_title(name, fontsize=7)
                if c == 0:
                    ax.set_ylabel(scene, fontsize=7)
        fig.suptitle(f"error (render - reference), channel mean, {spp} spp, seed 0", fontsize=8)
        fig.tight_layout(pad=0.3)
        p = FIGS / f"errors-{spp}spp.png"
        save_small(fig, p)
        plt.close(fig)
        made.append(p.name)
    fig, axes = plt.subplots(1, len(scenes), figsize=(3.3 * len(scenes), 2.8))
    for ax, (scene, s) in zip(axes, scenes.items()):
        for name in samplers:
            rows = s["rows"][name]
            ax.loglog(
                SCENE_SPP,
                [rows[n]["mse"] for n in SCENE_SPP],
                "o-" if name == "dpc" else ".--",
                label=name,
                lw=2 if name == "dpc" else 0.8,
                ms=4,
            )
        ax.set_xlabel("spp", fontsize=8)
        ax.set_title(scene, fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("image MSE", fontsize=8)
    axes[0].legend(fontsize=6)
    fig.tight_layout(pad=0.3)
    p = FIGS / "mse.png"
    save_small(fig, p)
    plt.close(fig)
    made.append(p.name)
    return made


def ratio_section(res: dict) -> list[str]:
    """dpc's MSE over every other sampler's, per scene and spp (the goals compare two of them)."""
    others = [n for n in res["samplers"] if n != "dpc"]
    L = [
        "## dpc's MSE over each sampler's",
        "",
        "Below 1: dpc's image MSE is lower. Mean over the seeds; the standard errors are in the tables further down.",
        "",
        "| scene | spp | " + " | ".join(others) + " |",
        "|---|---:|" + "---:|" * len(others),
    ]
    for scene, s in res["scenes"].items():
        for n in SCENE_SPP:
            d = s["rows"]["dpc"][n]["mse"]
            L.append(f"| {scene} | {n} | " + " | ".join(f"{d / s['rows'][o][n]['mse']:.2f}" for o in others) + " |")
    worse = []
    for scene, s in res["scenes"].items():
        for name in res["samplers"]:
            for n in SCENE_SPP:
                a, b = s["rows"][name][n], s["rows"]["independent"][n]
                r, se = ratio_se(a["mse"], a["mse_se"], b["mse"], b["mse_se"])
                if name != "independent" and r - 1 > 2 * se:
                    worse.append(f"{name} in {scene} at {n} spp (x{r:.2f} ± {se:.2f})")
    L.append("")
    if worse:
        L.append("MSE above independent's by more than two standard errors: " + "; ".join(worse) + ".")
        if any(w.startswith("pmj02bn") and " 4 spp" in w for w in worse):
            L.append(
                "PMJ02BN at 4 spp, likely: its Get1D returns (index + delta)/spp with one blue-noise delta per "
                "pixel and dimension, so a pixel's 4 wavelength samples lie exactly 1/4 apart, and pbrt "
                "draws its four wavelengths at u, u + 1/4, u + 1/2, u + 3/4: all four samples see the same "
                "wavelengths. Any table would do this (the regenerated ones give delta its values)."
            )
    else:
        L.append("No sampler's MSE lies above independent's by more than two standard errors.")
    return L + [""]


def page(res: dict, checks, figs, command: str) -> str:
    samplers = res["samplers"]
    L = ["# pbrt-v4: dpc's sampler against pbrt's samplers", "", *report_header(command)]
    L += [
        f'pbrt-v4 commit {res["pbrt_commit"]} with dpc\'s `Sampler "dpc"` (integrations/pbrt-v4/; model '
        f"`{DPC_MODEL}`, the Mitsuba plugin's default; the other parameters at their defaults), "
        f"`{PBRT_SHOWN}` a pbrt built by `bash integrations/pbrt-v4/run.sh PBRT_SRC BUILD_DIR`, "
        f"{res['nthreads']} threads under `nice -n 10`, on {res['cpu']}. The renders of this "
        f"page's cells took {res['render_minutes']:.1f} minutes of wall clock (pbrt processes, the references "
        "not counted).",
        "",
        "**PMJ02BN's numbers come from regenerated tables**: pbrt-v4 keeps its pmj02bn points and "
        "blue-noise textures in Git LFS, which this checkout lacks; "
        "`python integrations/pbrt-v4/make_tables.py` regenerated them (5 pmj02bn sets from pmj-cpp, "
        "48 void-and-cluster textures from dpc). The blue-noise textures also set PMJ02BN's per-pixel "
        "Cranley-Patterson shifts; no other sampler reads them.",
        "",
        "## Goals",
        "",
        "| goal | met | measured (dpc vs the other; ratio ± standard error) |",
        "|---|---|---|",
    ]
    L += [f"| {g} | {'yes' if ok else '**no**'} | {m} |" for g, ok, m, _ in checks]
    met = sum(ok for _, ok, _, _ in checks)
    L += ["", f"{met} of {len(checks)} met.", ""]
    causes: dict[str, list[str]] = {}
    for g, ok, _, cause in checks:
        if not ok:
            causes.setdefault(cause, []).append(g.replace(": dpc", ":"))
    if causes:
        L += [
            "Likely causes of the misses (the diagnostics section tests the fold; the others are not tested "
            "one by one here; nothing was tuned to pass):",
            "",
        ]
        L += [f"- {cause[0].upper() + cause[1:]}. Misses: {'; '.join(gs)}." for cause, gs in causes.items()]
        L.append("")
    times = {
        name: [s["rows"][name][256]["time"] / s["rows"]["independent"][256]["time"] for s in res["scenes"].values()]
        for name in samplers
    }
    L += [
        "Render time at 256 spp over independent's (pbrt process wall clock, median over seeds; range over "
        "the scenes): "
        + "; ".join(f"{n} x{min(t):.2f}-{max(t):.2f}" for n, t in times.items() if n != "independent")
        + ".",
        "",
    ]
    L += ratio_section(res)
    L += variant_section(res)
    L += [
        "## pbrt's function integrator",
        "",
        f'`Integrator "function"`: each pixel of a {FUNC_RES} x {FUNC_RES} film is one estimate of a '
        "2-D function's integral (1) from the sampler's pixel samples (`GetPixel2D`, dpc's slot 0); pbrt "
        f"writes the MSE over the {FUNC_RES**2} pixels. One run per cell (seed 0), with `--spp` at that "
        "count. For squared errors of a normal distribution the relative standard error of such a mean is "
        f"sqrt(2/{FUNC_RES**2}) = {100 * np.sqrt(2 / FUNC_RES**2):.1f}%; step-like integrands have heavier tails. "
        "pbrt refuses `sobol` here (it asks for paddedsobol); for halton, paddedsobol and stratified "
        "the integrator uses its own per-pixel randomisation instead of the sampler's.",
        "",
    ]
    fs = [s for s in samplers if s != "sobol"]
    for func in FUNCTIONS:
        L += [f"**{func}**: MSE", "", "| spp | " + " | ".join(fs) + " | dpc / best other |"]
        L += ["|---:|" + "---:|" * (len(fs) + 1)]
        for spp in FUNC_SPP:
            vals = {s: res["functions"][func][s][spp]["mse"] for s in fs}
            best = min((s for s in fs if s != "dpc"), key=lambda s: vals[s])
            cells = [f"**{vals[s]:.2e}**" if s == "dpc" else f"{vals[s]:.2e}" for s in fs]
            if vals[best] > 0:
                rel = f"x{vals['dpc'] / vals[best]:.2f} ({best})"
            else:  # pbrt prints 6 decimals: exact integration shows as 0
                rel = "both 0" if vals["dpc"] == 0 else f"{best} 0, dpc not"
            L.append(f"| {spp} | " + " | ".join(cells) + f" | {rel} |")
        L.append("")
    L += [
        "## Scenes",
        "",
        f"Our scenes (lab/rendering/pbrt_scenes/), {res['width']} x {res['width']} pixels, box filter, "
        f"{res['seeds']} seeds per cell (pbrt's `--seed` 0 .. {res['seeds'] - 1}). MSE over pixels and RGB "
        "channels against the reference (mean over seeds ± standard error); E_low of the channel-mean error "
        "image (white noise = 1; mean over seeds); time: the pbrt process's wall clock (startup and tables "
        "included), median over seeds, over independent's at the same spp. "
        f"Reference: {REF_SAMPLER} at {res['ref_spp']} spp (two halves, seeds {REF_SEEDS[0]} and "
        f"{REF_SEEDS[1]}); its own MSE is in every cell's MSE.",
        "",
    ]
    for scene in SCENES:
        s = res["scenes"][scene]
        L += [f"### {scene}", "", f"Reference's own MSE: {s['ref_mse']:.1e}.", ""]
        L += ["| sampler | " + " | ".join(f"MSE {n} spp" for n in SCENE_SPP) + " |", "|---|" + "---:|" * len(SCENE_SPP)]
        for name in samplers:
            cells = [f"{s['rows'][name][n]['mse']:.2e} ± {s['rows'][name][n]['mse_se']:.0e}" for n in SCENE_SPP]
            L.append(f"| {'**dpc**' if name == 'dpc' else name} | " + " | ".join(cells) + " |")
        L += [""]
        L += [
            "| sampler | " + " | ".join(f"E_low {n} spp" for n in SCENE_SPP) + " | time 64 spp | time 256 spp |",
            "|---|" + "---:|" * (len(SCENE_SPP) + 2),
        ]
        for name in samplers:
            r = s["rows"][name]
            cells = [f"{r[n]['elow']:.2f}" for n in SCENE_SPP]
            for n in (64, 256):
                t0 = s["rows"]["independent"][n]["time"]
                cells.append(f"{r[n]['time']:.2f} s (x{r[n]['time'] / t0:.2f})")
            L.append(f"| {'**dpc**' if name == 'dpc' else name} | " + " | ".join(cells) + " |")
        L.append("")
    L += [f"![{f}](figures/pbrt/{f})" for f in figs] + [""]
    return "\n".join(L)


def render_minutes(functions: dict, scenes: dict) -> float:
    """The wall clock of every cell's pbrt processes (cached ones included), references not."""
    t = sum(v["time"] for f in functions.values() for s in f.values() for v in s.values())
    t += sum(r["total_time"] for s in scenes.values() for rows in s["rows"].values() for r in rows.values())
    return t / 60  # the diagnostic variants not counted


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pbrt", type=Path, required=True, help="pbrt-v4 binary with dpc's sampler")
    ap.add_argument("--width", type=int, default=96)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--ref-spp", type=int, default=REF_SPP)
    ap.add_argument("--nthreads", type=int, default=2)
    ap.add_argument("--pbrt-commit", default="5f7a6068", help="the pbrt-v4 commit the binary was built from")
    ap.add_argument("--cache", type=Path, default=DEFAULT_CACHE, help="references and per-render results")
    ap.add_argument("--models", type=Path, default=ROOT / "models", help="DPC_MODEL_PATH for pbrt")
    ap.add_argument(
        "--dpc-prefix",
        type=Path,
        default=None,
        help="libdpc's install (default: run.sh's layout, BUILD_DIR/dpc-prefix beside BUILD_DIR/build/pbrt)",
    )
    ap.add_argument("--samplers", default=",".join(SAMPLERS), help="a subset, comma-separated (testing)")
    ap.add_argument("--skip-functions", action="store_true")
    ap.add_argument(
        "--quick", action="store_true", help="48 x 48 pixels, 2 seeds, reference 1024 spp: prints only, no docs/"
    )
    args = ap.parse_args(argv)
    if args.quick:
        args.width, args.seeds, args.ref_spp = 48, 2, 1024
    samplers = [s for s in args.samplers.split(",") if s]
    exe = args.pbrt.resolve()
    env = dict(os.environ, DPC_MODEL_PATH=str(args.models))
    prefix = args.dpc_prefix or args.pbrt.absolute().parent.parent / "dpc-prefix"
    lib = prefix / "lib"
    if lib.is_dir():
        env["LD_LIBRARY_PATH"] = f"{lib}:{env['LD_LIBRARY_PATH']}" if env.get("LD_LIBRARY_PATH") else str(lib)
    args.cache.mkdir(parents=True, exist_ok=True)
    cache = Cache(args.cache / "results.json")
    st = exe.stat()
    libdpc = sorted(lib.glob("libdpc.so*")) if lib.is_dir() else []
    # cells are keyed by the binary; dpc's also by the shared libdpc it loads (the other samplers
    # do not use it)
    tag = hashlib.sha256(f"{exe}|{st.st_size}|{st.st_mtime_ns}".encode()).hexdigest()[:12]
    dpc_tag = hashlib.sha256(f"{tag}|{file_digest(*libdpc) if libdpc else ''}".encode()).hexdigest()[:12]
    tags = (tag, dpc_tag)
    given = list(sys.argv[1:] if argv is None else argv)
    # the page names no machine's paths: the binary is whatever run.sh built there
    shown = [PBRT_SHOWN if i > 0 and given[i - 1] == "--pbrt" else a for i, a in enumerate(given)]
    shown = [f"--pbrt={PBRT_SHOWN}" if a.startswith("--pbrt=") else a for a in shown]
    command = "python -m lab.rendering.pbrt_study " + shlex.join(shown)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="pbrt-study-") as tmp:
        pb = Pbrt(exe, args.nthreads, env, Path(tmp))
        functions = {} if args.skip_functions else run_functions(pb, cache, tags, samplers)
        scenes = run_scenes(pb, cache, args.cache, tags, args, samplers)
        variants = run_variants(pb, cache, args.cache, dpc_tag, args) if "dpc" in samplers else {}
    res = {
        "samplers": samplers,
        "functions": functions,
        "scenes": scenes,
        "variants": variants,
        "width": args.width,
        "seeds": args.seeds,
        "ref_spp": args.ref_spp,
        "nthreads": args.nthreads,
        "cpu": cpu_name(),
        "pbrt": str(exe),
        "pbrt_commit": args.pbrt_commit,
        "seconds": time.perf_counter() - t0,
        "render_minutes": render_minutes(functions, scenes),
    }
    checks = goals(scenes) if {"dpc", "zsobol", "paddedsobol"} <= set(samplers) else []
    print("\nGoals:")
    for g, ok, m, cause in checks:
        print(f"  [{'met' if ok else 'MISSED'}] {g}: {m}" + (f": {cause}" if cause else ""))
    print(
        f"{sum(ok for _, ok, _, _ in checks)} of {len(checks)} met; this run {res['seconds'] / 60:.1f} minutes, "
        f"the cells' renders {res['render_minutes']:.1f} minutes"
    )
    if args.quick or args.skip_functions or samplers != SAMPLERS:
        return
    figs = figures(scenes, samplers)
    PAGE.write_text(page(res, checks, figs, command))
    print(f"wrote {PAGE} and {len(figs)} figures in {FIGS}")


if __name__ == "__main__":
    main()
