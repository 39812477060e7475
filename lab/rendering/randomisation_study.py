"""What randomising every value per seed costs the screen-space error: Heitz et al. 2019's sampler
as published (its tile moved per seed, its values fixed) against the same sampler with each
dimension's values rotated toroidally per seed, as dpc's set slots are so that every value is
uniform over seeds, and dpc's default, in Mitsuba 3.

    python -m lab.rendering.randomisation_study       # about 5 minutes on 2 cores

Renders bench_rendering's soft-shadow, ao-env and glossy scenes at 1, 2, 4 and 8 spp, 8 seeds
each, against bench_rendering's cached references (run `python -m lab.rendering.bench_rendering`
first): E_low (bench_rendering's, |nu| <= 1/8) and image MSE. Writes the section
`randomisation_study` of docs/reports/rendering-studies.md.
"""

from __future__ import annotations

import numpy as np

from lab.common import REPORTS, reference, replace_section
from lab.rendering import bench_rendering as br

DOC = REPORTS / "rendering-studies.md"
SEEDS = 8
SCENES = ("soft-shadow", "ao-env", "glossy")
COUNTS = (1, 2, 4, 8)
VARIANTS = {
    "heitz2019 (published: values fixed, tile moved per seed)": ("heitz2019", {}),
    "heitz2019, values rotated per seed": ("heitz2019", {"rotate": True}),
    "dpc (default)": ("dpc", {}),
}


def main() -> None:
    mi, anchors = br._mitsuba()
    width = 128
    rows = {}
    for scene in SCENES:
        ref, ref_mse = reference(mi, scene, width)
        for label, (sampler, extra) in VARIANTS.items():
            for spp in COUNTS:
                el, mse = [], []
                for seed in range(SEEDS):
                    img = br.render(mi, anchors, scene, sampler, spp, seed, width, extra)[0]
                    el.append(br.low_band_energy((img - ref).mean(-1), br.ISSUE_BAND))
                    mse.append(float(((img - ref) ** 2).mean()) - ref_mse)
                rows[(scene, label, spp)] = (float(np.mean(el)), float(np.mean(mse)))
                print(f"{scene:12s} {label:58s} {spp:2d} spp: E_low {rows[(scene, label, spp)][0]:.3f}", flush=True)
    L = [
        f"Measured by `python -m lab.rendering.randomisation_study`: {width} x {width} pixels, one block, "
        f"{SEEDS} seeds per cell; E_low (white = 1) and image MSE.",
        "",
        "| scene | sampler | "
        + " | ".join(f"E_low {n}" for n in COUNTS)
        + " | "
        + " | ".join(f"MSE {n}" for n in COUNTS)
        + " |",
        "|---|---|" + "---:|" * (2 * len(COUNTS)),
    ]
    for scene in SCENES:
        for label in VARIANTS:
            el = [f"{rows[(scene, label, n)][0]:.2f}" for n in COUNTS]
            ms = [f"{rows[(scene, label, n)][1]:.2e}" for n in COUNTS]
            L.append(f"| {scene} | {label} | " + " | ".join(el + ms) + " |")
    replace_section(DOC, "randomisation_study", "\n".join(L) + "\n")
    print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
