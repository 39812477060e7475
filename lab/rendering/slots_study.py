"""Which of the sampler's dimension slots should hold nets, per integrand: the Mitsuba bench's
scenes rendered with the first `net_dims` slots as nets and the rest as dpc's shifted sets.

    python -m lab.rendering.slots_study          # about a minute on 2 cores

libdpc's default puts a net in every slot at power-of-two counts (docs/rendering.md, "Net
dimensions"); the Mitsuba plugin's, from this study, in slots 0 and 1. Mitsuba's integrators
consume one slot per next_1d / next_2d call: the film position (slot 0), then the direct
integrator's light sample and the BSDF's two samples, the path tracer's the same per bounce.
Here the first k slots are nets and the others the sets (net_dims = k; "all" is libdpc's
default, 0 none), at 2, 4, 8 and 16 spp, 6 seeds, 128 x 128 pixels, against bench_rendering's
cached references (run `python -m lab.rendering.bench_rendering` first): image MSE over the
default's. A row equal to "all" from some k on says the scene uses no slot from k on.
Writes the section `slots_study` of docs/reports/rendering-studies.md.
"""

from __future__ import annotations

import argparse
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from lab.common import REPORTS, cpu_name, reference, replace_section
from lab.rendering import bench_rendering as br

DOC = REPORTS / "rendering-studies.md"
COUNTS = (2, 4, 8, 16)
NET_DIMS = ("all", 0, 1, 2, 3, 4)


def scene_rows(job) -> dict:
    """{(net_dims, spp): (MSE, its standard error)} of one scene."""
    scene, seeds, width = job
    mi, anchors = br._mitsuba()
    ref, ref_mse = reference(mi, scene, width)
    out = {}
    for k in NET_DIMS:
        extra = {"net_dims": -1 if k == "all" else k}  # -1: libdpc's default, every slot
        for spp in COUNTS:
            m = [
                float(((br.render(mi, anchors, scene, "dpc", spp, seed, width, extra)[0] - ref) ** 2).mean()) - ref_mse
                for seed in range(seeds)
            ]
            out[(k, spp)] = (float(np.mean(m)), float(np.std(m, ddof=1) / np.sqrt(seeds)))
        print(f"{scene:12s} net_dims {k!s:4s}: " + " ".join(f"{out[(k, n)][0]:.3e}" for n in COUNTS), flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--width", type=int, default=128)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    scenes = list(br.SCENES)
    with ProcessPoolExecutor(args.jobs) as ex:
        rows = dict(zip(scenes, ex.map(scene_rows, [(s, args.seeds, args.width) for s in scenes])))
    L = [
        f"Measured by `python -m lab.rendering.slots_study` on {cpu_name()}: {args.width} x {args.width} pixels, "
        f"{args.seeds} seeds; image MSE with the first net_dims slots as nets, over that of libdpc's default "
        "(every slot a net; its own MSE in the first rows).",
        "",
        "| scene | net_dims | " + " | ".join(f"{n} spp" for n in COUNTS) + " |",
        "|---|---|" + "---:|" * len(COUNTS),
    ]
    for scene in scenes:
        r = rows[scene]
        L.append(
            f"| {scene} | all (libdpc's default) | " + " | ".join(f"{r[('all', n)][0]:.2e}" for n in COUNTS) + " |"
        )
        for k in NET_DIMS[1:]:
            cells = [f"{r[(k, n)][0] / r[('all', n)][0]:.2f} ± {r[(k, n)][1] / r[('all', n)][0]:.2f}" for n in COUNTS]
            L.append(f"| {scene} | {k} | " + " | ".join(cells) + " |")
    replace_section(DOC, "slots_study", "\n".join(L) + "\n")
    print("\n".join(L))
    print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
