"""Measure dpc's blue-noise masks against void-and-cluster, STBN and white noise; write
docs/reports/masks.md (the sections marked <!-- key -->) and docs/reports/figures/masks/.

    python -m lab.masks.mask_report scalar     # scalar masks 32, 64, 128 (a few minutes on 1 core)
    python -m lab.masks.mask_report vector     # 2-value masks 64 x 64
    python -m lab.masks.mask_report st         # spatiotemporal masks 32 x 32 x 16 and 64 x 64 x 16
    python -m lab.masks.mask_report cost       # generation times
    python -m lab.masks.mask_report all

Metrics: dpc.analysis.masks (white-noise mask = 1; low band 0 < |q| <= 6 cycles per tile).
Each section replaces its part of docs/reports/masks.md; the rest of the page is kept.
"""

from __future__ import annotations

import argparse
import re
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import dpc  # noqa: E402
from dpc import baselines as B  # noqa: E402
from dpc import mask_design as MD  # noqa: E402
from dpc import masks as M  # noqa: E402
from dpc.analysis import dither as D  # noqa: E402
from dpc.analysis import masks as AM  # noqa: E402
from lab.common import REPORTS  # noqa: E402

FIG = REPORTS / "figures" / "masks"
PAGE = REPORTS / "masks.md"
KEYS = ("scalar", "vector", "st", "cost")

SCALAR_MODEL = "mask-64"
VECTOR_MODEL = "mask-vector-64"
ST_MODEL = "mask-st-32x16"
ANNEALED = "annealed"  # dpc.mask_design's spectral annealing (bundled at some sizes)
COUNT = 8  # masks per row (scalar, vector); volumes per row: ST_COUNT
WIDE_BAND = 12.0  # the scalar tables also report the measures over 0 < |q| <= 12
ST_COUNT = 4


def write_section(key: str, lines: list[str]) -> None:
    """Replace (or add) the section between <!-- key --> markers; sections keep KEYS order."""
    text = PAGE.read_text() if PAGE.exists() else ""
    # head: everything before the first report section (other markers, e.g. bench scripts'
    # <!-- name:begin --> sections, belong to the head); tail: everything after the last one
    starts = [text.find(f"<!-- {k} -->\n") for k in KEYS if f"<!-- {k} -->\n" in text]
    head = text[: min(starts)] if starts else text
    ends = [text.find(f"<!-- /{k} -->\n") + len(f"<!-- /{k} -->\n") for k in KEYS if f"<!-- /{k} -->\n" in text]
    tail = text[max(ends) :] if ends else ""
    sections = dict(re.findall(r"<!-- (\w+) -->\n(.*?)<!-- /\1 -->\n", text, flags=re.S))
    sections[key] = "\n".join(lines) + "\n"
    body = "".join(f"<!-- {k} -->\n{sections[k]}<!-- /{k} -->\n" for k in KEYS if k in sections)
    PAGE.write_text(head + body + tail)
    print(f"updated {PAGE} ({key})")


def savefig(fig, name: str) -> str:
    FIG.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(FIG / name, dpi=90)
    plt.close(fig)
    return f"figures/masks/{name}"


def timed(fn, *a, **k):
    t = time.perf_counter()
    out = fn(*a, **k)
    return out, time.perf_counter() - t


def model_available(name: str) -> bool:
    try:
        dpc.model_path(name)
        return True
    except dpc.ModelNotFoundError:
        return False


# ---- figures ------------------------------------------------------------------------------


def mask_figure(mask: np.ndarray, title: str, name: str) -> str:
    """Mask (2 x 2 tiles), log power spectrum, thresholded patterns at 1/8 ... 7/8."""
    r = D.rank_normalise(mask)
    n = r.shape[0]
    c = r - r.mean()
    p = np.fft.fftshift(np.abs(np.fft.fft2(c)) ** 2 / (n * n * c.var()))
    fig, axs = plt.subplots(1, 9, figsize=(18, 2.4))
    axs[0].imshow(np.tile(r, (2, 2)), cmap="gray", interpolation="nearest")
    axs[0].set_title("mask, 2 x 2 tiles", fontsize=8)
    axs[1].imshow(np.log10(np.maximum(p, 1e-3)), cmap="viridis", vmin=-3, vmax=1, interpolation="nearest")
    axs[1].set_title("log10 power", fontsize=8)
    for k, ax in enumerate(axs[2:], start=1):
        ax.imshow(r < k / 8, cmap="gray_r", interpolation="nearest")
        ax.set_title(f"< {k}/8", fontsize=8)
    for ax in axs:
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title, fontsize=9)
    return savefig(fig, name)


def dither_figure(masks: dict[str, np.ndarray], name: str) -> tuple[str, list[str]]:
    import matplotlib.image as mpimg
    from matplotlib import cbook
    from scipy.ndimage import gaussian_filter

    img = mpimg.imread(cbook.get_sample_data("grace_hopper.jpg"))
    grey = D.luminance(img)
    fig, axs = plt.subplots(1, len(masks), figsize=(4 * len(masks), 5))
    rows = ["| mask | RMS error of the dithered image after a Gaussian blur (σ = 2 px) |", "|---|---:|"]
    for ax, (label, m) in zip(axs, masks.items()):
        out = D.dither(grey, m)
        err = float(np.sqrt(np.mean((gaussian_filter(out.astype(float), 2.0) - gaussian_filter(grey, 2.0)) ** 2)))
        ax.imshow(out, cmap="gray", interpolation="nearest")
        ax.set(xticks=[], yticks=[], title=label)
        rows.append(f"| {label} | {err:.4f} |")
    return savefig(fig, name), rows


# ---- scalar -------------------------------------------------------------------------------


def scalar_rows(label: str, ms: np.ndarray, secs: float) -> tuple[str, dict]:
    q = AM.scalar_quality(ms)
    wide = AM.scalar_quality(ms, q_max=WIDE_BAND)  # the same measures over a wider low band
    seam = AM.seam_ratio(ms) if ms.shape[1] >= 8 else float("nan")
    return (
        f"| {label} | {len(ms)} | {q['mask_elow']:.5f} | {q['levels_elow_mean']:.4f} | "
        f"{q['levels_elow_max']:.4f} | {wide['mask_elow']:.5f} | {wide['levels_elow_mean']:.4f} | "
        f"{q['levels_peak_mean']:.1f} | {seam:.2f} | {secs:.2f} |"
    ), q


def goal_line(n: int, name: str, q: dict, q_vc: dict) -> str:
    ok = all(q[k] <= q_vc[k] for k in ("mask_elow", "levels_elow_mean", "levels_elow_max"))
    return (
        f"{n} × {n}: {name} mask E_low {q['mask_elow']:.5f} vs {q_vc['mask_elow']:.5f}, thresholded "
        f"mean {q['levels_elow_mean']:.4f} vs {q_vc['levels_elow_mean']:.4f}, worst level "
        f"{q['levels_elow_max']:.4f} vs {q_vc['levels_elow_max']:.4f}: "
        + ("at or below void-and-cluster" if ok else "**worse than void-and-cluster**")
    )


def scalar() -> None:
    header = [
        "| mask | masks | mask E_low | thresholded 1/8 … 7/8: mean E_low | worst level | "
        f"mask E_low, \\|q\\| ≤ {WIDE_BAND:g} | thresholded mean, \\|q\\| ≤ {WIDE_BAND:g} | "
        "largest single-frequency power | seam ratio | seconds per mask |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    lines = [
        "## Scalar masks",
        "",
        "`python -m lab.masks.mask_report scalar`. Per size: the dpc models (at their trained "
        "grid, or filtered at another size with radii that scale with the point count), "
        "the annealed masks of `dpc.mask_design` (the bundled designs where there are some, "
        "else designed here; their design times are in the cost section), void-and-cluster (σ = 1.5), white noise and "
        "Bayer; seeds 0 … count−1. Seam ratio: "
        "`dpc.analysis.masks.seam_ratio` (≈ 1: tiles seamlessly; a 32 × 32 crop of a 64 × 64 "
        "void-and-cluster mask scores > 1.5 in the tests). Seconds: wall time on the shared "
        "2-core machine, including loading the model (a model at another size runs libdpc's "
        "float64 layer kernels). Largest single-frequency power: the thresholded patterns' "
        "highest peak outside DC, mean over levels (Bayer's low band is empty because all "
        "its power sits in a few spikes). The columns at \\|q\\| ≤ 12 are the same measures over "
        "a low band twice as wide (0 < \\|q\\| ≤ 12 cycles per tile).",
        "",
    ]
    verdict = []
    models = [m for m in (SCALAR_MODEL, "dither-32") if model_available(m)]
    figs = {}
    for n in (32, 64, 128):
        lines += [f"### {n} × {n}", "", *header]
        vc, t_vc = timed(lambda n=n: np.stack([B.void_and_cluster(n, seed=s) for s in range(COUNT)]))
        row_vc, q_vc = scalar_rows("void-and-cluster", vc, t_vc / COUNT)
        rows = []
        bundled = MD.BUNDLED.get((n, None, None), range(0))
        count = len(bundled) if len(bundled) else COUNT
        ms, t = timed(lambda n=n, count=count: np.stack([M.mask(ANNEALED, size=n, seed=s) for s in range(count)]))
        how = "bundled designs: load time" if len(bundled) else "designed here"
        row, q = scalar_rows(f"**{ANNEALED}** ({how})", ms, t / count)
        rows.append(row)
        verdict.append(goal_line(n, ANNEALED, q, q_vc))
        if n == 64:
            figs[ANNEALED] = ms[0]
        for name in models:
            ms, t = timed(lambda name=name, n=n: np.stack([M.mask(name, size=n, seed=s) for s in range(COUNT)]))
            trained = dpc.load(name).grid_shape[0] == n
            label = f"**{name}**" + ("" if trained else " (other size)")
            row, q = scalar_rows(label, ms, t / COUNT)
            rows.append(row)
            if name == SCALAR_MODEL:
                verdict.append(goal_line(n, name, q, q_vc))
                if n == 64:
                    figs[name] = ms[0]
        wh, t_wh = timed(lambda n=n: np.stack([B.white_mask((n, n), seed=s) for s in range(COUNT)]))
        rows += [
            row_vc,
            scalar_rows("white noise", wh, t_wh / COUNT)[0],
            scalar_rows("Bayer (ordered)", B.bayer_mask(n)[None], 0.0)[0],
        ]
        lines += rows + [""]
        print("\n".join(lines[-len(rows) - 3 :]), flush=True)
        if n == 64:
            figs["void-and-cluster"], figs["white noise"] = vc[0], wh[0]
            figs["Bayer"] = B.bayer_mask(64)
    lines += (
        ["**Goal check** (every dpc mask at or below void-and-cluster on mask and thresholded-pattern energy):", ""]
        + [f"- {v}" for v in verdict]
        + [""]
    )
    for label, m in figs.items():
        path = mask_figure(m, f"{label} (64 x 64, seed 0)", f"scalar-{label.replace(' ', '-')}.png")
        lines.append(f"![{label}]({path})")
    path, rows = dither_figure({k: v for k, v in figs.items()}, "dither-64.png")
    lines += [
        "",
        "Ordered dithering of matplotlib's sample photograph with the 64 × 64 masks above (seed 0), tiled:",
        "",
        *rows,
        "",
        f"![dithered]({path})",
        "",
    ]
    write_section("scalar", lines)


# ---- vector -------------------------------------------------------------------------------


def vector() -> None:
    n = 64
    lines = [
        "## Vector (2-value) masks",
        "",
        "`python -m lab.masks.mask_report vector`. 64 × 64, seeds 0 … count−1. Per channel: the "
        "worse channel's scalar numbers. Joint: the pixels whose value pair lies in the box "
        "[0, a) × [0, b), a, b ∈ {1/4, 1/2, 3/4}, as binary patterns (mean and worst of the 9 "
        "boxes). Two independent void-and-cluster masks are blue per channel but not jointly.",
        "",
        "| mask | masks | per channel: mask E_low | per channel: thresholded mean | "
        "per channel: worst level | joint boxes: mean E_low | joint boxes: worst | seconds per mask |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    entries = []
    if model_available(VECTOR_MODEL):
        entries.append((f"**{VECTOR_MODEL}**", lambda s: M.mask(VECTOR_MODEL, seed=s)))
    entries += [
        (f"**{ANNEALED}** (channels=2, bundled designs)", lambda s: M.mask(ANNEALED, size=n, seed=s, channels=2)),
        ("void-and-cluster × 2 (independent)", lambda s: B.vector_void_and_cluster(n, s)),
        ("white noise × 2", lambda s: B.white_mask((n, n, 2), s)),
    ]
    pats = {}
    for label, fn in entries:
        ms, t = timed(lambda fn=fn: np.stack([fn(s) for s in range(COUNT)]))
        q = AM.vector_quality(ms)
        lines.append(
            f"| {label} | {COUNT} | {q['mask_elow_max']:.5f} | {q['levels_elow_mean_max']:.4f}"
            f" | {q['levels_elow_max']:.4f} | {q['joint_elow_mean']:.4f} | "
            f"{q['joint_elow_max']:.4f} | {t / COUNT:.2f} |"
        )
        pats[label] = ms[0]
        print(lines[-1], flush=True)
    fig, axs = plt.subplots(len(pats), 4, figsize=(10, 2.6 * len(pats)))
    for row, (label, m) in zip(np.atleast_2d(axs), pats.items()):
        row[0].imshow(m[..., 0], cmap="gray", interpolation="nearest")
        row[1].imshow(m[..., 1], cmap="gray", interpolation="nearest")
        row[2].imshow((m[..., 0] < 0.5) & (m[..., 1] < 0.5), cmap="gray_r", interpolation="nearest")
        row[3].imshow((m[..., 0] < 0.25) & (m[..., 1] < 0.25), cmap="gray_r", interpolation="nearest")
        for ax, t in zip(row, ("value u", "value v", "u < 1/2 and v < 1/2", "u < 1/4 and v < 1/4")):
            short = label.strip("*").split(" (")[0]
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"{short}: {t}" if t == "value u" else t, fontsize=8)
    path = savefig(fig, "vector.png")
    lines += ["", f"![vector masks]({path})", ""]
    write_section("vector", lines)


# ---- spatiotemporal -----------------------------------------------------------------------


def golden_offsets(n: int, frames: int, seed: int) -> np.ndarray:
    """One void-and-cluster mask shifted by the golden ratio each frame (a common real-time
    trick): frame t = (v + t·φ) mod 1, ranked per frame."""
    v = B.void_and_cluster(n, seed)
    phi = (np.sqrt(5.0) - 1) / 2
    return np.stack([D.rank_normalise((v + t * phi) % 1.0) for t in range(frames)])


def st() -> None:
    lines = [
        "## Spatiotemporal masks",
        "",
        "`python -m lab.masks.mask_report st`. Per frame: the scalar numbers of each frame "
        "(mean over frames and volumes; worst: the worst frame's mean over levels). Temporal "
        "E_low: each pixel's values along time, power at 0 < k ≤ T/4 (white = 1). "
        "Accumulated RMSE: pixel p after n frames estimates ∫ f by the mean of f(v_t(p)), "
        "t < n, for the steps f_c(u) = [u < c], c = 1/16 … 15/16; RMS error over pixels and "
        "c (white noise: about √(0.17/n)).",
        "",
    ]
    curves = {}
    for n, t in ((32, 16), (64, 16)):
        lines += [
            f"### {n} × {n} × {t}",
            "",
            "| mask | volumes | frames: mask E_low | frames: thresholded mean | worst frame | "
            "temporal E_low | RMSE 1 frame | RMSE 4 frames | RMSE all frames | seconds per volume |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        count = ST_COUNT if n == 32 else 2
        entries = []
        if model_available(ST_MODEL):
            other = dpc.load(ST_MODEL).grid_shape[0] != n
            entries.append(
                (
                    f"**{ST_MODEL}**" + (" (other size)" if other else ""),
                    lambda s, n=n, t=t: M.mask(ST_MODEL, size=n, frames=t, seed=s),
                )
            )
        how = "bundled designs" if len(MD.BUNDLED.get((n, t, None), ())) >= count else "designed here"
        entries.append((f"**{ANNEALED}** ({how})", lambda s, n=n, t=t: M.mask(ANNEALED, size=n, frames=t, seed=s)))
        entries += [
            ("STBN (scalar, after Wolfe et al. 2022)", lambda s, n=n, t=t: B.stbn_scalar(n, t, s)),
            (
                "void-and-cluster, independent per frame",
                lambda s, n=n, t=t: np.stack([B.void_and_cluster(n, s * 1000 + k) for k in range(t)]),
            ),
            ("void-and-cluster + golden-ratio offset per frame", lambda s, n=n, t=t: golden_offsets(n, t, s)),
            ("white noise", lambda s, n=n, t=t: np.stack([B.white_mask((n, n), s * 1000 + k) for k in range(t)])),
        ]
        for label, fn in entries:
            vs, secs = timed(lambda fn=fn, count=count: np.stack([fn(s) for s in range(count)]))
            q = AM.spatiotemporal_quality(vs)
            r = q["accumulated_rmse"]
            lines.append(
                f"| {label} | {count} | {q['mask_elow_mean']:.5f} | {q['levels_elow_mean']:.4f} | "
                f"{q['levels_elow_max']:.4f} | {q['temporal_elow']:.3f} | {r[0]:.4f} | "
                f"{r[3]:.4f} | {r[-1]:.4f} | {secs / count:.1f} |"
            )
            print(lines[-1], flush=True)
            if n == 32:
                curves[label.strip("*")] = (r, q["temporal_spectrum"])
        lines.append("")
    fig, axs = plt.subplots(1, 2, figsize=(11, 4))
    for label, (r, ts) in curves.items():
        axs[0].loglog(np.arange(1, len(r) + 1), r, "o-", ms=3, label=label)
        axs[1].plot(np.arange(len(ts))[1:], ts[1:], "o-", ms=3, label=label)
    axs[0].set(
        xlabel="frames accumulated",
        ylabel="RMS error (step integrands)",
        title="accumulated 1-spp estimates, 32 x 32 x 16",
    )
    axs[1].set(xlabel="temporal frequency k (of 16)", ylabel="power (white = 1)", title="per-pixel temporal spectrum")
    axs[0].legend(fontsize=7)
    axs[0].grid(alpha=0.3)
    axs[1].grid(alpha=0.3)
    path = savefig(fig, "spatiotemporal.png")
    lines += [f"![spatiotemporal]({path})", ""]
    write_section("st", lines)


# ---- cost ---------------------------------------------------------------------------------


def cost() -> None:
    lines = [
        "## Cost of making a mask",
        "",
        "`python -m lab.masks.mask_report cost`: wall seconds for one mask on this (shared, 2-core) machine, seed 0.",
        "",
        "| mask | size | seconds |",
        "|---|---|---:|",
    ]
    for n in (32, 64, 128, 256):
        _, t = timed(B.void_and_cluster, n, 0)
        lines.append(f"| void-and-cluster (numpy, O(N⁴)) | {n} × {n} | {t:.2f} |")
        print(lines[-1], flush=True)
    for n, t in ((16, 16), (32, 16), (64, 16)):
        _, s = timed(B.stbn_scalar, n, t, 0)
        lines.append(f"| STBN scalar (numpy, O((T·N²)²)) | {n} × {n} × {t} | {s:.2f} |")
        print(lines[-1], flush=True)
    for n, t in ((32, None), (64, None), (128, None), (32, 16)):
        _, s = timed(MD.anneal_mask, n, t, 0)
        shape = f"{n} × {n}" + ("" if t is None else f" × {t}")
        lines.append(
            f"| {ANNEALED} (dpc.mask_design, {MD.STEPS_PER_PIXEL} proposed swaps per pixel) | {shape} | {s:.2f} |"
        )
        print(lines[-1], flush=True)
    for name in (SCALAR_MODEL, VECTOR_MODEL, ST_MODEL):
        if not model_available(name):
            continue
        model = dpc.load(name)
        model.generate(seed=0)
        _, s = timed(model.generate, seed=1)
        shape = " × ".join(str(g) for g in model.grid_shape)
        lines.append(f"| {name} (libdpc `dpc_generate`, trained grid) | {shape} | {s:.3f} |")
        print(lines[-1], flush=True)
    lines.append("")
    write_section("cost", lines)


SECTIONS = {"scalar": scalar, "vector": vector, "st": st, "cost": cost}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", nargs="+", choices=list(SECTIONS) + ["all"])
    args = ap.parse_args(argv)
    for key in list(SECTIONS) if "all" in args.what else args.what:
        SECTIONS[key]()


if __name__ == "__main__":
    main()
