"""Nets in every slot against sets in every slot but the first, in Mitsuba 3.

    python -m lab.rendering.nets_study            # about 10 minutes on 2 cores

The default sampler has nets in every slot at power-of-two counts; the alternative this study
measures is a (0,m,2)-net in dimension 0 (the pixel position) and folded blue-noise sets in the
other slots (`net_dims = 1`, `fold_from = 1`). It renders bench_rendering's soft-shadow scene and
path-traced Cornell box with those and with nets in all 16 slots, unfolded
(`net_dims = 16`, `fold_from = -1`), 32 seeds each (the sampler's `seed` property 0 ... 31), against
bench_rendering's cached references (run `python -m lab.rendering.bench_rendering` first): image MSE,
the ratio with its standard error, and the screen-space low-frequency error energy (white = 1).
Writes the section `nets_study` of docs/reports/rendering-studies.md.
"""

from __future__ import annotations

import time

import numpy as np

from lab import common
from lab.common import REPORTS, replace_section
from lab.rendering import bench_rendering as br

DOC = REPORTS / "rendering-studies.md"

SEEDS = 32
SCENES = ("soft-shadow", "cornell-path")
COUNTS = (2, 4, 16, 32, 64, 256)
SETS = {"net_dims": 1, "fold_from": 1}
NETS = {"net_dims": 16, "fold_from": -1}


def main() -> None:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    import dpc.mitsuba  # noqa: F401  (registers the plugin)

    t0 = time.time()
    lines = [
        f"Measured by `python -m lab.rendering.nets_study` (Mitsuba {mi.__version__} `scalar_rgb`, 128 x 128 "
        f"pixels, {SEEDS} seeds; {{seconds}} s): dpc with folded sets in every slot but dimension 0 "
        "(`net_dims = 1`, `fold_from = 1`) against nets in all 16 slots, unfolded (`net_dims = 16`, "
        "`fold_from = -1`, the default's nets).",
        "",
        "| scene | spp | MSE: sets | MSE: nets everywhere | nets / sets | E_low: sets | E_low: nets |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for scene in SCENES:
        ref = np.load(common.CACHE / f"ref-{scene}-128-{common.REF_SPP}.npz")["ref"]
        for spp in COUNTS:
            stats = []
            for extra in (SETS, NETS):
                mse, el = [], []
                for seed in range(SEEDS):
                    err = common.render(mi, scene, "dpc", spp, seed, 128, extra)[0] - ref
                    mse.append(float((err**2).mean()))
                    el.append(br.low_band_energy(err.mean(-1)))
                stats.append(
                    {
                        "mse": float(np.mean(mse)),
                        "mse_se": float(np.std(mse, ddof=1) / np.sqrt(SEEDS)),
                        "elow": float(np.mean(el)),
                    }
                )
            a, b = stats
            r, se = common.ratio_se(b["mse"], b["mse_se"], a["mse"], a["mse_se"])
            line = (
                f"| {scene} | {spp} | {a['mse']:.3e} | {b['mse']:.3e} | x{r:.3f} ± {se:.3f} | "
                f"{a['elow']:.3f} | {b['elow']:.3f} |"
            )
            lines.append(line)
            print(line, flush=True)
    body = "\n".join(lines).replace("{seconds}", f"{time.time() - t0:.0f}")
    replace_section(DOC, "nets_study", body)
    print(f"wrote {DOC} (nets_study)")


if __name__ == "__main__":
    main()
