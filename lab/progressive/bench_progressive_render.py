"""Progressive samplers in Mitsuba 3: image error against samples per pixel (docs/progressive.md).

    python -m lab.progressive.bench_progressive_render           # docs/reports/progressive.md's rendering section
    python -m lab.progressive.bench_progressive_render --quick   # smaller, prints only

The soft-shadow scene of lab/rendering/bench_rendering.py (direct lighting, a large area light) at
`--width`^2 pixels, rendered at 1, 2, 4, ..., `--max-spp` samples per pixel over `--seeds` seeds
with: the dpc plugin on progressive-2d (progressive tables: a pixel's first n samples are
the table's prefix), on progressive-2d-balanced (the same, each level balanced: dpc.balance)
and on progressive-2d-relaxed (the same levels, then every prefix relaxed jointly: dpc.relax),
the dpc plugin on bnot-2d-stratified (a set made for each count), Mitsuba's
ldsampler and independent, and PMJ02BN. Mitsuba has no PMJ sampler, so the bench brings its
own (`PoolSampler`, a Python mitsuba.Sampler): pixel p's dimension pair d reads sequence
h(p, d) mod 32 of a pool of 32 PMJ02BN sequences (dpc.baselines, Christensen et al. 2018) at
the sample index, Cranley-Patterson-rotated by a second hash of (p, d); 1-D values are the x
coordinates. Being Python, it is the slow one; its error does not depend on that. The same
sampler on a pool of 32 progressive-2d-relaxed sets is the row "dpc progressive, relaxed"; "dpc
progressive, pool" is that sampler on progressive-2d's sets (the same levels, unrelaxed), so the
two rows show what the relaxation does in one sampler, without the dpc plugin's screen-space
shifts and folding.
Image MSE against bench_rendering.py's reference (ldsampler at 8,192 spp, two halves of other seeds),
mean over seeds; a figure of MSE against spp goes to docs/reports/figures/progressive/.

    python -m lab.progressive.bench_progressive_render --stop     # a renderer that stops early: own section, ~30 min

The stop-early study: the pool sampler on sequences of 128 points rendered at n < 128 samples
per pixel reads each sequence's first n points, also between the levels (24, 40, 48, ... spp),
for progressive-2d and progressive-2d-relaxed as generated and with each level's points in a
random order (the order before the levels had one), and PMJ02BN.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from lab import common as BR  # the scenes and the reference of the rendering study
from lab.common import REPORTS, replace_section

DOC = REPORTS / "progressive.md"
FIG = REPORTS / "figures" / "progressive" / "render-mse.png"
SCENE = "soft-shadow"
SAMPLERS = [
    "dpc progressive",
    "dpc progressive balanced",
    "dpc progressive relaxed",
    "dpc progressive, relaxed",
    "dpc progressive, pool",
    "dpc set",
    "pmj02bn",
    "ldsampler",
    "independent",
]
POOL = 32
M64 = (1 << 64) - 1


def mix64(z: int) -> int:
    z &= M64
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
    return z ^ (z >> 31)


def pool_points(kind: str, max_spp: int) -> np.ndarray:
    """The pool of POOL sequences of max_spp points a pool sampler reads: PMJ02BN, or the sets of
    progressive-2d or progressive-2d-relaxed (its levels relaxed jointly), seeds 0 .. POOL-1;
    kind "... shuffled": the same sets with each level's points in a random order (the order
    before docs/model-format.md §6 ordered the levels)."""
    import dpc
    from dpc import baselines
    from lab.progressive.bench_progressive_between import shuffled_levels

    if kind == "pmj02bn":
        return baselines.generate("pmj02bn", max_spp, 2, POOL, seed=0)
    model = "progressive-2d" if kind.startswith("progressive") else "progressive-2d-relaxed"
    sets = dpc.load(model, backend="cpu").generate_batch(POOL, 0, max_spp).astype(np.float64)
    return shuffled_levels(sets, 1) if kind.endswith("shuffled") else sets


def pool_sampler_class(mi, pool_array: np.ndarray):
    pool = pool_array.astype(np.float32).tolist()
    max_spp = pool_array.shape[1]

    class PoolSampler(mi.Sampler):
        def __init__(self, props):
            mi.Sampler.__init__(self, props)
            self.base = mix64(props.get("seed", 0) + 0x5EED)
            self.pixel = self.index = self.dim = 0

        def seed(self, seed, wavefront_size=1):
            mi.Sampler.seed(self, seed, wavefront_size)
            self.pixel, self.index, self.dim = int(seed), 0, 0

        def advance(self):
            mi.Sampler.advance(self)
            self.index += 1
            self.dim = 0

        def _point(self):
            h = mix64(self.base ^ mix64((self.pixel << 16) + self.dim))
            self.dim += 1
            p = pool[h % POOL][self.index % max_spp]
            u = (h >> 16 & 0xFFFFFF) / 16777216.0
            v = (h >> 40 & 0xFFFFFF) / 16777216.0
            return (p[0] + u) % 1.0, (p[1] + v) % 1.0

        def next_1d(self, active=True):
            return self._point()[0]

        def next_2d(self, active=True):
            return mi.Point2f(*self._point())

        def clone(self):
            s = PoolSampler(mi.Properties())
            s.base = self.base
            s.set_sample_count(self.sample_count())
            return s

        def fork(self):
            return self.clone()

        def to_string(self):
            return "PoolSampler"

    return PoolSampler


# The dpc plugin as this section measures it: every dimension after the pixel position folded,
# nets laid out per pixel, and for the set model a net in the pixel position below 32 spp and in
# every slot from 32 on (the sampler's defaults are now no fold, screen-ordered nets below 64 spp
# and nets in every slot: docs/rendering.md).
PINNED = {"fold_from": 1, "net_layout": "pixel"}


def render(mi, sampler: str, spp: int, seed: int, width: int) -> np.ndarray:
    d = BR.scene_dict(mi, SCENE, width)
    kind, extra = {
        "dpc progressive": ("dpc", {"model": "progressive-2d", **PINNED}),
        "dpc progressive balanced": ("dpc", {"model": "progressive-2d-balanced", **PINNED}),
        "dpc progressive relaxed": ("dpc", {"model": "progressive-2d-relaxed", **PINNED}),
        "dpc set": ("dpc", {"model": "bnot-2d-stratified", "net_dims": 16 if spp >= 32 else 1, **PINNED}),
        "pmj02bn": ("pmj02bn_bench", {}),
        "dpc progressive, relaxed": ("relaxed_bench", {}),
        "dpc progressive, pool": ("progressive_bench", {}),
    }.get(sampler, (sampler, {}))
    d["sensor"]["sampler"] = {"type": kind, "sample_count": spp, "seed": seed, **extra}
    sc = mi.load_dict(d)
    if sc.sensors()[0].sampler().sample_count() != spp:
        return None  # ldsampler takes at least 4 samples: no value at 1 and 2 spp
    return np.array(mi.render(sc), dtype=np.float64)


def run(width: int, seeds: int, max_spp: int) -> dict:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    import dpc.mitsuba  # noqa: F401  (registers the dpc plugin)

    pools = (("pmj02bn_bench", "pmj02bn"), ("relaxed_bench", "relaxed"), ("progressive_bench", "progressive"))
    for name, kind in pools:
        cls = pool_sampler_class(mi, pool_points(kind, max_spp))
        mi.register_sampler(name, lambda props, cls=cls: cls(props))
    ref, ref_mse = BR.reference(mi, SCENE, width)
    counts = [1 << k for k in range(max_spp.bit_length()) if 1 << k <= max_spp]
    mse: dict[str, list[float]] = {}
    for s in SAMPLERS:
        t = time.perf_counter()
        mse[s] = []
        for n in counts:
            imgs = [render(mi, s, n, k, width) for k in range(seeds)]
            mse[s].append(float("nan") if imgs[0] is None else float(np.mean([((i - ref) ** 2).mean() for i in imgs])))
        print(f"{s:16s} " + " ".join(f"{v:.2e}" for v in mse[s]) + f"   ({time.perf_counter() - t:.0f} s)")
    return {"counts": counts, "mse": mse, "ref_mse": ref_mse, "width": width, "seeds": seeds, "cpu": BR.cpu_name()}


STOP_TABLE = 128  # the pool sequences' length in the stop-early study
STOP_COUNTS = [24, 32, 40, 48, 64, 80, 96]
STOP_WIDTH, STOP_SEEDS = 32, 8  # a Python sampler: 32 x 32 pixels and 8 seeds keep it near 30 minutes
STOP_SAMPLERS = {  # row: pool kind
    "dpc progressive, pool": "progressive",
    "dpc progressive, pool, levels shuffled": "progressive shuffled",
    "dpc progressive, relaxed": "relaxed",
    "dpc progressive, relaxed, levels shuffled": "relaxed shuffled",
    "pmj02bn": "pmj02bn",
}


def run_stop(width: int, seeds: int) -> dict:
    """A renderer that stops early: pool samplers on sequences of STOP_TABLE points rendered at
    n < STOP_TABLE samples per pixel read each sequence's first n points (between the levels,
    too)."""
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    for kind in STOP_SAMPLERS.values():
        cls = pool_sampler_class(mi, pool_points(kind, STOP_TABLE))
        mi.register_sampler("stop_" + kind.replace(" ", "_"), lambda props, cls=cls: cls(props))
    ref, ref_mse = BR.reference(mi, SCENE, width)
    mse: dict[str, list[float]] = {}
    for row, kind in STOP_SAMPLERS.items():
        t = time.perf_counter()
        mse[row] = []
        for n in STOP_COUNTS:
            imgs = [render(mi, "stop_" + kind.replace(" ", "_"), n, k, width) for k in range(seeds)]
            mse[row].append(float(np.mean([((i - ref) ** 2).mean() for i in imgs])))
        print(f"{row:42s} " + " ".join(f"{v:.2e}" for v in mse[row]) + f"   ({time.perf_counter() - t:.0f} s)")
    return {"mse": mse, "ref_mse": ref_mse, "width": width, "seeds": seeds, "cpu": BR.cpu_name()}


def stop_section(res: dict) -> str:
    rows = list(STOP_SAMPLERS)
    lines = [
        f"Measured by `python -m lab.progressive.bench_progressive_render --stop` on {res['cpu']}: Mitsuba 3 "
        "`scalar_rgb`, "
        f"the {SCENE} scene at {res['width']} x {res['width']} pixels, {res['seeds']} seeds per cell; the pool "
        f"sampler of the table above on sequences of {STOP_TABLE} points, stopped at n samples per pixel (each "
        'pixel\'s first n points of its sequences). Image MSE; "levels shuffled": the same sets with each '
        "level's points in a random order.",
        "",
        "| sampler | " + " | ".join(f"{n} spp" for n in STOP_COUNTS) + " |",
        "|---|" + "---:|" * len(STOP_COUNTS),
    ]
    for row in rows:
        lines.append(f"| {row} | " + " | ".join(f"{v:.2e}" for v in res["mse"][row]) + " |")
    between = [i for i, n in enumerate(STOP_COUNTS) if n & (n - 1)]
    levels = [i for i, n in enumerate(STOP_COUNTS) if not n & (n - 1)]

    def ratios(a: str, b: str, at: list[int] = between) -> str:
        r = [res["mse"][a][i] / res["mse"][b][i] for i in at]
        return f"×{min(r):.2f} .. ×{max(r):.2f}"

    lines += [
        "",
        "Between the levels ("
        + ", ".join(str(STOP_COUNTS[i]) for i in between)
        + " spp), MSE over the same sets with shuffled levels: progressive-2d "
        + ratios("dpc progressive, pool", "dpc progressive, pool, levels shuffled")
        + ", progressive-2d-relaxed "
        + ratios("dpc progressive, relaxed", "dpc progressive, relaxed, levels shuffled")
        + "; over PMJ02BN's: progressive-2d "
        + ratios("dpc progressive, pool", "pmj02bn")
        + ", progressive-2d-relaxed "
        + ratios("dpc progressive, relaxed", "pmj02bn")
        + " (at the level sizes, "
        + ", ".join(str(STOP_COUNTS[i]) for i in levels)
        + " spp: "
        + ratios("dpc progressive, pool", "pmj02bn", levels)
        + " and "
        + ratios("dpc progressive, relaxed", "pmj02bn", levels)
        + ").",
    ]
    return "\n".join(lines)


def figure(res: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    FIG.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for s in SAMPLERS:
        ok = ~np.isnan(res["mse"][s])
        marker = "o-" if s.startswith("dpc") else "s--"
        ax.loglog(np.array(res["counts"])[ok], np.array(res["mse"][s])[ok], marker, label=s, ms=4)
    ax.set_xlabel("samples per pixel")
    ax.set_ylabel("image MSE")
    ax.set_title(f"{SCENE}, {res['width']}x{res['width']} px, mean of {res['seeds']} seeds")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(FIG, dpi=110)
    plt.close(fig)


def section(res: dict) -> str:
    counts = res["counts"]
    lines = [
        f"Measured by `python -m lab.progressive.bench_progressive_render` on {res['cpu']}: Mitsuba 3 `scalar_rgb`, "
        f"the {SCENE} scene at {res['width']} x {res['width']} pixels, {res['seeds']} seeds per cell; reference "
        f"ldsampler at {BR.REF_SPP:,} spp (its own MSE {res['ref_mse']:.1e}).",
        "",
        "| sampler | " + " | ".join(f"{n} spp" for n in counts) + " |",
        "|---|" + "---:|" * len(counts),
    ]
    for s in SAMPLERS:
        lines.append(f"| {s} | " + " | ".join("—" if np.isnan(v) else f"{v:.2e}" for v in res["mse"][s]) + " |")
    others = [s for s in SAMPLERS if not s.startswith("dpc progressive")]
    best = {n: np.nanmin([res["mse"][s][i] for s in others]) for i, n in enumerate(counts)}
    bal = [res["mse"]["dpc progressive balanced"][i] / res["mse"]["dpc progressive"][i] for i in range(len(counts))]
    ratio = [res["mse"]["dpc progressive"][i] / res["mse"]["pmj02bn"][i] for i in range(len(counts))]
    lines += [
        "",
        "MSE of progressive dpc over PMJ02BN's: " + ", ".join(f"{n}: x{r:.2f}" for n, r in zip(counts, ratio)) + ".",
        "Over the best of the others at that count (ldsampler renders only 4, 16 and 64): "
        + ", ".join(f"{n}: x{res['mse']['dpc progressive'][i] / best[n]:.2f}" for i, n in enumerate(counts))
        + ".",
        "MSE of progressive-2d-relaxed in the dpc plugin over PMJ02BN's: "
        + ", ".join(
            f"{n}: x{res['mse']['dpc progressive relaxed'][i] / res['mse']['pmj02bn'][i]:.2f}"
            for i, n in enumerate(counts)
        )
        + "; over progressive-2d's in the plugin: "
        + ", ".join(
            f"{n}: x{res['mse']['dpc progressive relaxed'][i] / res['mse']['dpc progressive'][i]:.2f}"
            for i, n in enumerate(counts)
        )
        + ".",
        "MSE of the relaxed progressive sets over PMJ02BN's (the same pool sampler): "
        + ", ".join(
            f"{n}: x{res['mse']['dpc progressive, relaxed'][i] / res['mse']['pmj02bn'][i]:.2f}"
            for i, n in enumerate(counts)
        )
        + ".",
        "MSE of the relaxed sets over the same sets unrelaxed (the same pool sampler): "
        + ", ".join(
            f"{n}: x{res['mse']['dpc progressive, relaxed'][i] / res['mse']['dpc progressive, pool'][i]:.2f}"
            for i, n in enumerate(counts)
        )
        + ".",
        "MSE of the balanced levels over progressive dpc's: "
        + ", ".join(f"{n}: x{r:.2f}" for n, r in zip(counts, bal))
        + ".",
        "",
        f"![MSE against samples per pixel](figures/progressive/{FIG.name})",
    ]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--width", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--max-spp", type=int, default=64)
    ap.add_argument("--quick", action="store_true", help="24 x 24 pixels, 2 seeds, up to 16 spp; prints only")
    ap.add_argument("--stop", action="store_true", help="the stop-early study instead (pool samplers, n < 128 spp)")
    args = ap.parse_args()
    if args.stop:
        res = run_stop(24 if args.quick else STOP_WIDTH, 2 if args.quick else STOP_SEEDS)
        if not args.quick:
            replace_section(DOC, "bench_progressive_stop", stop_section(res))
            print(f"wrote {DOC}")
        return
    if args.quick:
        args.width, args.seeds, args.max_spp = 24, 2, 16
    res = run(args.width, args.seeds, args.max_spp)
    if args.quick:
        return
    figure(res)
    replace_section(DOC, "bench_progressive_render", section(res))
    print(f"wrote {DOC} and {FIG}")


if __name__ == "__main__":
    main()
