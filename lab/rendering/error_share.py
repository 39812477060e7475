"""Where in the image the rendering bench's MSE comes from (docs/rendering.md).

    python -m lab.rendering.error_share            # a few minutes; uses bench_rendering's references

For each scene of lab/rendering/bench_rendering.py at 16 and 64 spp: the pixels with the highest
per-pixel variance of the `independent` sampler (4 renders; a measure of the pixel's integrand
that neither compared sampler chose) are split off (the top 1%), and for dpc, ldsampler and
multijitter (8 seeds each, the bench's seeds) the share of the image MSE in those pixels and
the ratio of dpc's MSE to each built-in sampler's inside and outside them are printed. It tells
whether a sampler's image MSE is decided by a few pixels (an emitter's rim seen through the pixel
footprint) or by the whole image. Writes the section `error_share` of docs/reports/rendering-studies.md.
"""

from __future__ import annotations

import time

import numpy as np

from lab.common import REPORTS, SCENES, reference, render, replace_section

DOC = REPORTS / "rendering-studies.md"

WIDTH, SEEDS, TOP = 128, 8, 0.01
SAMPLERS = ["dpc", "ldsampler", "multijitter"]


def main() -> None:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    import dpc.mitsuba  # noqa: F401  (registers the plugin)

    t0 = time.time()
    lines = [
        f"Measured by `python -m lab.rendering.error_share` ({WIDTH} x {WIDTH} pixels, {SEEDS} seeds; "
        f"hot pixels: the top {TOP:.0%} by `independent`'s per-pixel variance; {{seconds}} s):",
        "",
        "| scene | spp | hot pixels' share of the MSE: dpc / ldsampler / multijitter "
        "| dpc over ldsampler: hot / rest | dpc over multijitter: hot / rest |",
        "|---|---:|---|---:|---:|",
    ]
    for scene in SCENES:
        ref, _ = reference(mi, scene, WIDTH)
        for spp in (16, 64):
            var = np.mean(
                [((render(mi, scene, "independent", spp, 100 + k, WIDTH)[0] - ref) ** 2).mean(-1) for k in range(4)], 0
            )
            hot = var >= np.quantile(var, 1 - TOP)
            err = {
                s: np.mean([((render(mi, scene, s, spp, k, WIDTH)[0] - ref) ** 2).mean(-1) for k in range(SEEDS)], 0)
                for s in SAMPLERS
            }
            share = " / ".join(f"{err[s][hot].sum() / err[s].sum():.2f}" for s in SAMPLERS)
            ratios = [
                f"x{err['dpc'][hot].sum() / err[s][hot].sum():.2f} / x{err['dpc'][~hot].sum() / err[s][~hot].sum():.2f}"
                for s in SAMPLERS[1:]
            ]
            lines.append(f"| {scene} | {spp} | {share} | {ratios[0]} | {ratios[1]} |")
            print(lines[-1], f"({time.time() - t0:.0f} s)", flush=True)
    body = "\n".join(lines).replace("{seconds}", f"{time.time() - t0:.0f}")
    replace_section(DOC, "error_share", body)
    print(f"wrote {DOC} (error_share)")


if __name__ == "__main__":
    main()
