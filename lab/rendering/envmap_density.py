"""Irradiance from an HDR environment map in Mitsuba 3: dpc's blue noise that follows a density
against Mitsuba's own envmap importance sampling.

    python -m lab.rendering.envmap_density        # about 2 minutes on 2 cores

Two procedural 256 x 128 latitude-longitude maps, each a Mitsuba `envmap` emitter
(`scalar_rgb`): "clear" (a sun disc of radius 2.5 degrees and radiance 1000, a sky gradient, a
dim ground; the sun holds 60 % of the sampling density) and "overcast" (the same sky and ground,
a soft glow instead of the sun; 1 : 60 dynamic range). For 64 random normals n the luminance
irradiance E(n) = integral of L(w) max(0, n.w) dw is estimated with N = 16 ... 1024 directions by

- Mitsuba: `emitter.sample_direction` driven by its samplers (`independent`, `multijitter`,
  `ldsampler`, one pixel of N samples); the estimate is mean luminance(weight) max(0, n.d), with
  weight = L / pdf by Mitsuba's own (bilinear) pdf;
- the density luminance x sin(theta), piecewise constant on 256 x 128 cells (Mitsuba's radiance
  averaged over each cell), sampled by `dpc.importance`: its inverse CDF applied to white noise,
  to a jittered grid and to dpc's uniform blue noise randomly shifted (`sample_density`,
  method "warp"), and dpc's density-following set (`Model.generate_density`, method "filter");
  directions by `latlong_to_direction`, radiance by `emitter.eval`, the estimate
  mean L max(0, n.d) jacobian / pdf;
- the jittered grid's inverse CDF with the map's bitmap rows taken as cells (Mitsuba puts them
  on r / (H - 1), not on cell centres): what ignoring the convention costs.

Last, the mean error of both dpc methods on docs/density.md's ramp and step (64 seeds), which
tells bias from noise on densities without a sun.

The reference is E(n) of Mitsuba's bilinear radiance by a midpoint rule aligned with its
bilinear cells (16 x 16 nodes per cell; checked against 8 x 8). Writes the section
`envmap_density` of docs/reports/envmap-density.md and docs/figures/envmap-density/error.png.
"""

from __future__ import annotations

import time

import numpy as np

from lab.common import REPORTS, ROOT, cpu_name, replace_section

DOC = REPORTS / "envmap-density.md"
FIG = ROOT / "docs" / "figures" / "envmap-density"

W, H = 256, 128
COUNTS = (16, 64, 256, 1024)
SEEDS = 32
NORMALS = 64
BIAS_SEEDS = 64
LUMA = np.array([0.212671, 0.715160, 0.072169])  # Mitsuba's luminance() (Rec. 709 / sRGB)

SUN_ELEVATION, SUN_AZIMUTH = np.radians(35.0), np.radians(60.0)  # azimuth: phi of the lat-long map
SUN_RADIUS = np.radians(2.5)
SUN_RGB = np.array([1.0, 0.93, 0.82]) * 1000.0
GLOW, GLOW_WIDTH = 4.0, np.radians(20.0)
ZENITH_RGB, HORIZON_RGB = np.array([0.18, 0.32, 0.75]), np.array([0.85, 0.9, 1.0])
GROUND_RGB = np.array([0.12, 0.10, 0.08])

MAPS = ("clear", "overcast")
MITSUBA = {"Mitsuba independent": "independent", "Mitsuba multijitter": "multijitter", "Mitsuba ldsampler": "ldsampler"}
DPC_MITSUBA = "Mitsuba's warp of dpc's set"
WHITE, JITTER, SOBOL = "inverse CDF, white noise", "inverse CDF, jittered", "inverse CDF, Sobol' (Owen)"
DPC_WARP, DPC_FILTER = "dpc warp (uniform set, inverse CDF)", "dpc filter (generate_density)"
NAIVE = "jittered, bitmap rows as cells"
METHODS = (*MITSUBA, DPC_MITSUBA, WHITE, JITTER, SOBOL, DPC_WARP, DPC_FILTER, NAIVE)


def importance():
    """dpc.importance, the helper measured."""
    from dpc import importance as imp

    return imp


def direction(u, v):
    """Mitsuba's envmap frame: phi = 2 pi u, theta = pi v, d = (sin phi sin theta, cos theta, -cos phi sin theta)."""
    phi, theta = np.broadcast_arrays(
        2 * np.pi * np.asarray(u, dtype=np.float64), np.pi * np.asarray(v, dtype=np.float64)
    )
    return np.stack([np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)], -1)


SUN = direction(SUN_AZIMUTH / (2 * np.pi), 0.5 - SUN_ELEVATION / np.pi)


def sky(d: np.ndarray, kind: str) -> np.ndarray:
    """The analytic environment: RGB radiance of unit directions (..., 3)."""
    y = d[..., 1:2]
    t = (1.0 - np.clip(y, 0.0, 1.0)) ** 3
    up = ZENITH_RGB + (HORIZON_RGB - ZENITH_RGB) * t
    down = GROUND_RGB * (1.0 + 0.3 * np.clip(-y, 0.0, 1.0))
    cos_sun = (d @ SUN)[..., None]
    if kind == "clear":
        return np.where(y >= 0, up, down) + SUN_RGB * (cos_sun >= np.cos(SUN_RADIUS))
    glow = 1.0 + GLOW * np.exp(-(np.arccos(np.clip(cos_sun, -1, 1)) ** 2) / (2 * GLOW_WIDTH**2))
    return np.where(y >= 0, up * glow, down)


def bitmap(kind: str) -> np.ndarray:
    """The (H, W, 3) float32 map: each pixel the mean of 8 x 8 samples around the point where
    Mitsuba puts it (u = (c + 1/2) / W, v = r / (H - 1))."""
    k = 8
    off = (np.arange(k) + 0.5) / k - 0.5
    r, c = np.mgrid[0:H, 0:W]
    acc = np.zeros((H, W, 3))
    for a in off:
        for b in off:
            acc += sky(direction((c + 0.5 + a) / W, np.clip((r + b) / (H - 1), 0.0, 1.0)), kind)
    return (acc / k**2).astype(np.float32)


def radiance_np(data: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Mitsuba's envmap lookup in numpy (envmap.cpp eval_spectrum: the map padded with its first
    column, bilinear between pixels at u = (c + 1/2) / W, v = r / (H - 1)); RGB (..., 3)."""
    pad = np.concatenate([data, data[:, :1]], axis=1).astype(np.float64)
    u = np.arctan2(d[..., 0], -d[..., 2]) / (2 * np.pi) - 0.5 / W
    u = (u - np.floor(u)) * W
    v = np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi * (H - 1)
    x0 = np.minimum(u.astype(np.int64), W - 1)
    y0 = np.minimum(v.astype(np.int64), H - 2)
    fx, fy = (u - x0)[..., None], (v - y0)[..., None]
    top = pad[y0, x0] * (1 - fx) + pad[y0, x0 + 1] * fx
    bot = pad[y0 + 1, x0] * (1 - fx) + pad[y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bot * fy


def reference(data: np.ndarray, normals: np.ndarray, k: int) -> np.ndarray:
    """E(n) of Mitsuba's bilinear radiance: k x k midpoint nodes in each bilinear cell."""
    nu, nv = W * k, (H - 1) * k
    v = (np.arange(nv) + 0.5) / nv
    u = 0.5 / W + (np.arange(nu) + 0.5) / nu
    e = np.zeros(len(normals))
    for rows in np.array_split(np.arange(nv), 64):
        d = direction(u[None, :], v[rows][:, None]).reshape(-1, 3)
        w = (radiance_np(data, d) @ LUMA) * np.sqrt(np.maximum(0.0, 1.0 - d[:, 1] ** 2))
        e += (w[:, None] * np.maximum(0.0, d @ normals.T)).sum(0)
    return e * 2 * np.pi**2 / (nu * nv)


def stats(e: np.ndarray) -> tuple[float, float, float]:
    """e: (seeds, normals) relative errors. The relative RMSE over normals and seeds, its
    standard error over seeds, and the bias statistic: the RMS over normals of the mean error
    over seeds in units of its noise, sqrt(mse / seeds) (about 1 when unbiased)."""
    per_seed = (e**2).mean(-1)
    mse = per_seed.mean()
    rmse = float(np.sqrt(mse))
    se = float(per_seed.std(ddof=1) / np.sqrt(len(per_seed)) / (2 * rmse))
    bias = float(np.sqrt((e.mean(0) ** 2).mean() / (mse / len(per_seed))))
    return rmse, se, bias


def simple_bias(imp, model) -> list[str]:
    """The estimator's mean error on docs/density.md's densities (64 x 64 cells): f = cos(3x)(1 + y) + 1."""
    y, x = (np.mgrid[0:64, 0:64] + 0.5) / 64
    densities = {"ramp 0.1 + x": 0.1 + x, "step 1 : 16 at x = 1/2": np.where(x < 0.5, 1.0, 16.0)}
    yy, xx = (np.mgrid[0:2048, 0:2048] + 0.5) / 2048
    exact = float((np.cos(3 * xx) * (1 + yy) + 1).mean())
    rows = []
    for name, density in densities.items():
        for method in ("warp", "filter"):
            cells = []
            for n in COUNTS:
                e = []
                for seed in range(BIAS_SEEDS):
                    p, pdf = imp.sample_density(density, n, seed, model, method=method)
                    p = p.astype(np.float64)
                    e.append(np.mean((np.cos(3 * p[:, 0]) * (1 + p[:, 1]) + 1) / pdf) / exact - 1)
                cells.append(f"{np.mean(e):+.1e} ± {np.std(e, ddof=1) / np.sqrt(len(e)):.0e}")
            rows.append(f"| {name}, {method} | " + " | ".join(cells) + " |")
    return rows


def table(rows: list[str]) -> list[str]:
    return ["| method | " + " | ".join(f"N = {n}" for n in COUNTS) + " |", "|---|" + "---:|" * len(COUNTS), *rows]


def main() -> None:
    import matplotlib
    import mitsuba as mi
    from scipy.stats import qmc

    mi.set_variant("scalar_rgb")
    import dpc

    imp = importance()
    model = dpc.load("bnot-2d-stratified")
    t0 = time.time()
    rng = np.random.default_rng(1)
    normals = rng.normal(size=(NORMALS, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    facing = normals @ SUN > 0
    rr, cc = np.mgrid[0:H, 0:W]
    si, it = mi.SurfaceInteraction3f(), mi.Interaction3f()
    results, notes, shares = {}, [], {}

    for kind in MAPS:
        data = bitmap(kind)
        emitter = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(data)})

        def lum_eval(dirs: np.ndarray, emitter=emitter) -> np.ndarray:
            out = np.empty(len(dirs))
            for i, x in enumerate(dirs):
                si.wi = mi.Vector3f(-x)
                out[i] = mi.luminance(emitter.eval(si))
            return out

        # the convention, checked: pixel (c, r) at u = (c + 1/2) / W, v = r / (H - 1), bilinear between
        lum_map = data @ LUMA
        at_pixels = lum_eval(direction((cc + 0.5) / W, np.clip(rr / (H - 1), 1e-7, 1 - 1e-7)).reshape(-1, 3))
        conv_err = np.abs(at_pixels - lum_map.ravel()).max() / lum_map.max()
        probe = rng.normal(size=(20000, 3))
        probe /= np.linalg.norm(probe, axis=1, keepdims=True)
        probe_lum = radiance_np(data, probe) @ LUMA
        np_err = np.max(np.abs(lum_eval(probe) - probe_lum) / np.maximum(probe_lum, 1e-3))
        ref = reference(data, normals, 16)
        ref_check = np.max(np.abs(reference(data, normals, 8) / ref - 1))

        # the sampling density: Mitsuba's radiance averaged over each cell (4 x 4 nodes), x sin(theta)
        lum_cells = np.zeros((H, W))
        for a in (np.arange(4) + 0.5) / 4:
            for b in (np.arange(4) + 0.5) / 4:
                lum_cells += radiance_np(data, direction((cc + a) / W, (rr + b) / H)) @ LUMA
        grid = dpc.density.as_density(imp.latlong_density(lum_cells / 16))
        naive = dpc.density.as_density(imp.latlong_density(lum_map))  # bitmap rows as cells
        bright = grid > 0.02 * grid.max()
        bright_mass = float(grid[bright].sum(dtype=np.float64) / grid.sum(dtype=np.float64))
        notes.append(
            f"{kind}: `eval` at Mitsuba's pixel positions against the bitmap {conv_err:.1e} (of the largest "
            f"luminance); numpy bilinear lookup against `eval` at 20000 random directions {np_err:.1e} "
            f"(relative); reference 8 x 8 against 16 x 16 nodes {ref_check:.1e}; E(n) spans "
            f"{ref.min():.3g} ... {ref.max():.3g}; luminance 1 : {lum_map.max() / lum_map.min():.0f}; "
            f"{bright_mass:.1%} of the density's mass in cells above 2 % of its largest value, "
            f"{bright.sum()} of {H * W}."
        )
        print(notes[-1], flush=True)

        def square_estimate(pts: np.ndarray, pdf: np.ndarray, lum_eval=lum_eval) -> np.ndarray:
            d, jac = imp.latlong_to_direction(pts)
            f = lum_eval(d) * jac / pdf
            return (f[:, None] * np.maximum(0.0, d @ normals.T)).mean(0)

        err = {m: np.zeros((len(COUNTS), SEEDS, NORMALS)) for m in METHODS}
        share = {m: np.zeros((len(COUNTS), SEEDS)) for m in (DPC_WARP, DPC_FILTER)}
        for ci, n in enumerate(COUNTS):
            side = int(round(np.sqrt(n)))
            strata = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)
            for seed in range(SEEDS):
                for name, sampler_type in MITSUBA.items():
                    sampler = mi.load_dict({"type": sampler_type, "sample_count": n})
                    sampler.seed(seed)
                    d, f = np.empty((n, 3)), np.empty(n)
                    for i in range(n):
                        ds, w = emitter.sample_direction(it, sampler.next_2d())
                        d[i], f[i] = ds.d, mi.luminance(w)
                        sampler.advance()
                    err[name][ci, seed] = (f[:, None] * np.maximum(0.0, d @ normals.T)).mean(0) / ref - 1
                # dpc's uniform set, randomly shifted, through Mitsuba's own warp and pdf
                u = (model.generate(seed, n).astype(np.float64) + np.random.default_rng(seed).random(2)) % 1.0
                d, f = np.empty((n, 3)), np.empty(n)
                for i in range(n):
                    ds, w = emitter.sample_direction(it, mi.Point2f(u[i]))
                    d[i], f[i] = ds.d, mi.luminance(w)
                err[DPC_MITSUBA][ci, seed] = (f[:, None] * np.maximum(0.0, d @ normals.T)).mean(0) / ref - 1
                srng = np.random.default_rng([seed, n])
                sobol = qmc.Sobol(2, scramble=True, seed=srng).random(n)
                for name, density, u in (
                    (WHITE, grid, srng.random((n, 2))),
                    (JITTER, grid, (strata + srng.random((n, 2))) / side),
                    (SOBOL, grid, sobol),
                    (NAIVE, naive, (strata + srng.random((n, 2))) / side),
                ):
                    pts = imp.warp_to_density(density, u)
                    err[name][ci, seed] = square_estimate(pts, imp.pdf_of(density, pts)) / ref - 1
                for name, method in ((DPC_WARP, "warp"), (DPC_FILTER, "filter")):
                    pts, pdf = imp.sample_density(grid, n, seed, model, method=method)
                    err[name][ci, seed] = square_estimate(pts, pdf) / ref - 1
                    p = pts.astype(np.float64)
                    share[name][ci, seed] = bright[(p[:, 1] * H).astype(int), (p[:, 0] * W).astype(int)].mean()
            print(f"{kind}, N = {n}: {time.time() - t0:.0f} s", flush=True)
        results[kind] = ({m: [stats(err[m][ci]) for ci in range(len(COUNTS))] for m in METHODS}, err)
        shares[kind] = (bright_mass, share)

    lines = [
        f"Measured by `python -m lab.rendering.envmap_density` (Mitsuba {mi.__version__} `scalar_rgb`; "
        f"{cpu_name()}; {{seconds}} s): relative RMSE of E(n) over {NORMALS} random normals "
        f"({facing.sum()} face the sun) and {SEEDS} seeds, ± its standard error over seeds. Checks:",
        "",
        *[f"- {note}" for note in notes],
    ]
    for kind in MAPS:
        tab, err = results[kind]
        lines += ["", f"**{kind}**: relative RMSE", ""]
        lines += table([f"| {m} | " + " | ".join(f"{r:.2e} ± {se:.1e}" for r, se, _ in tab[m]) + " |" for m in METHODS])
        lines += ["", f"**{kind}**: relative RMSE over the normals facing the sun / the others", ""]
        rows = []
        for m in METHODS:
            cells = []
            for ci in range(len(COUNTS)):
                a, b = (np.sqrt((err[m][ci][:, sel] ** 2).mean()) for sel in (facing, ~facing))
                cells.append(f"{a:.2e} / {b:.2e}")
            rows.append(f"| {m} | " + " | ".join(cells) + " |")
        lines += table(rows)
        lines += [
            "",
            f"**{kind}**: bias statistic: about 1 when unbiased (noisy, since the normals share each seed's "
            f"directions), sqrt({SEEDS}) = {np.sqrt(SEEDS):.2f} when every seed has the same error",
            "",
        ]
        lines += table([f"| {m} | " + " | ".join(f"{b:.2f}" for _, _, b in tab[m]) + " |" for m in METHODS])
        mass, share = shares[kind]
        lines += [
            "",
            f"**{kind}**: share of the points in the cells above 2 % of the largest density ({mass:.1%} of the mass)",
            "",
        ]
        lines += table([f"| {m} | " + " | ".join(f"{s:.1%}" for s in share[m].mean(1)) + " |" for m in share])
    lines += [
        "",
        f"**Simple densities** (docs/density.md's ramp and step on 64 x 64 cells): mean relative error of "
        f"the estimate of the integral of f = cos(3x) (1 + y) + 1 ± its standard error, {BIAS_SEEDS} seeds",
        "",
        *table(simple_bias(imp, model)),
    ]
    body = "\n".join(lines).replace("{seconds}", f"{time.time() - t0:.0f}")
    print(body)
    if not DOC.exists():
        title = "# Environment maps: blue noise that follows a density"
        DOC.write_text(f"{title}\n\n<!-- envmap_density:begin -->\n<!-- envmap_density:end -->\n")
    replace_section(DOC, "envmap_density", body)

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    FIG.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, len(MAPS), figsize=(11, 4.2), sharey=True)
    for ax, kind in zip(axes, MAPS):
        tab = results[kind][0]
        for m in METHODS:
            r, se = np.array([t[0] for t in tab[m]]), np.array([t[1] for t in tab[m]])
            style = "-" if m in (DPC_WARP, DPC_FILTER, DPC_MITSUBA) else "--" if m in MITSUBA else ":"
            ax.errorbar(COUNTS, r, yerr=se, marker="o", ms=3, capsize=2, ls=style, label=m)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xlabel("directions N")
        ax.set_title(f"{kind}: {NORMALS} normals x {SEEDS} seeds")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("relative RMSE of E(n)")
    axes[-1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(FIG / "error.png", dpi=72)
    print(f"wrote {DOC} (envmap_density) and {FIG / 'error.png'}")


if __name__ == "__main__":
    main()
