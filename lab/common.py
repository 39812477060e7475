"""What the lab's studies share: the repository root, the CPU's description, builds of the
benchmark programs and the replacement of a docs page's generated section (one copy each, in
bench/common.py, which the benchmarks use too), where the reports go, and the Mitsuba scenes with
their cached references that the rendering and progressive studies render.

Run a study from the repository root: python -m lab.<topic>.<name>."""

from __future__ import annotations

import time

import numpy as np

from bench.common import ROOT, build, cpu_name, replace_section

__all__ = [
    "ROOT",
    "build",
    "cpu_name",
    "replace_section",
    "REPORTS",
    "CACHE",
    "REF_SPP",
    "SCENES",
    "DIRECT_SCENES",
    "scene_dict",
    "render",
    "reference",
]

# The measured pages (docs/reports/): measurements, not the manual.
REPORTS = ROOT / "docs" / "reports"
# The rendering studies' cached references and results.
CACHE = ROOT / "build" / "bench-rendering"
REF_SPP = 8192


def ratio_se(a: float, a_se: float, b: float, b_se: float) -> tuple[float, float]:
    """a / b and its standard error for independent estimates (first-order propagation)."""
    r = a / b
    return r, r * float(np.hypot(a_se / a, b_se / b))


def report_header(command: str) -> list[str]:
    """The lines under a report page's title: what made it, on which machine."""
    return [
        f"> Measurements, not the manual: made by `{command}`; machine: {cpu_name()}. "
        "The manual is [docs/](../architecture.md).",
        "",
    ]


def scene_dict(mi, name: str, width: int) -> dict:
    film = {"type": "hdrfilm", "width": width, "height": width, "rfilter": {"type": "box"}}
    if name in ("cornell-direct", "cornell-path"):
        d = mi.cornell_box()
        d["sensor"]["film"] = film
        d["integrator"] = {"type": "direct"} if name == "cornell-direct" else {"type": "path", "max_depth": 5}
        return d
    if name == "soft-shadow":
        T = mi.ScalarTransform4f
        return {
            "type": "scene",
            "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
            "sensor": {
                "type": "perspective",
                "fov": 40,
                "to_world": T().look_at(origin=[0, -1.5, 4], target=[0, 0, 0], up=[0, 1, 0]),
                "film": film,
            },
            "floor": {"type": "rectangle", "to_world": T().scale([3, 3, 1]), "bsdf": {"type": "diffuse"}},
            "occluder": {"type": "sphere", "center": [0, 0, 0.6], "radius": 0.5, "bsdf": {"type": "diffuse"}},
            "light": {
                "type": "rectangle",
                "to_world": T().translate([1.0, 1.0, 2.2]).rotate([1, 0, 0], 180).scale([1.2, 1.2, 1]),
                "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 2.0}},
            },
        }
    T = mi.ScalarTransform4f
    if name == "hidden-light":
        # the Cornell box lit only by a small emitter under the ceiling that faces up: everything
        # the camera sees is light that bounced at least twice
        d = mi.cornell_box()
        d["sensor"]["film"] = film
        d["integrator"] = {"type": "path", "max_depth": 6}
        d["light"]["to_world"] = T().translate([0.0, 0.9, 0.0]).rotate([1, 0, 0], -90).scale([0.12, 0.12, 1])
        d["light"]["emitter"]["radiance"]["value"] = [150.0, 120.0, 90.0]
        d["baffle"] = {
            "type": "rectangle",
            "to_world": T().translate([0.0, 0.88, 0.0]).rotate([1, 0, 0], 90).scale([0.3, 0.3, 1]),
            "bsdf": {"type": "diffuse"},
        }
        return d
    if name == "aliasing":
        # what the camera sees is emission (no light sampling): the pixel footprint is the only
        # integral; a checkerboard of 1/8-pixel squares at the horizon and thin bright rods
        rods = {
            f"rod{k}": {
                "type": "cylinder",
                "p0": [-0.95 + 0.25 * k, -0.5, 0.3],
                "p1": [-0.75 + 0.25 * k, 1.0, -0.3],
                "radius": 0.0015 + 0.0012 * k,
                "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 1.5}},
            }
            for k in range(8)
        }
        return {
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 1},
            "sensor": {
                "type": "perspective",
                "fov": 45,
                "to_world": T().look_at(origin=[0, 0.35, 2.5], target=[0, -0.15, 0], up=[0, 1, 0]),
                "film": film,
            },
            "ground": {
                "type": "rectangle",
                "to_world": T().translate([0, -0.5, -6]).rotate([1, 0, 0], -90).scale([8, 8, 1]),
                "emitter": {
                    "type": "area",
                    "radiance": {
                        "type": "checkerboard",
                        "color0": 0.05,
                        "color1": 1.0,
                        "to_uv": mi.ScalarTransform3f().scale([120, 120]),
                    },
                },
            },
            **rods,
        }
    if name == "ao-env":
        # visibility under a uniform sky, BSDF sampling only (ambient occlusion's integrand)
        return {
            "type": "scene",
            "integrator": {"type": "direct", "emitter_samples": 0, "bsdf_samples": 1},
            "sensor": {
                "type": "perspective",
                "fov": 40,
                "to_world": T().look_at(origin=[0, -2.2, 2.6], target=[0, 0, 0.3], up=[0, 0, 1]),
                "film": film,
            },
            "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
            "floor": {"type": "rectangle", "to_world": T().scale([4, 4, 1]), "bsdf": {"type": "diffuse"}},
            "ball": {"type": "sphere", "center": [-0.5, 0.2, 0.45], "radius": 0.45, "bsdf": {"type": "diffuse"}},
            "box": {
                "type": "cube",
                "to_world": T().translate([0.55, 0.1, 0.3]).rotate([0, 0, 1], 25).scale([0.3, 0.3, 0.3]),
                "bsdf": {"type": "diffuse"},
            },
            "slab": {
                "type": "cube",
                "to_world": T().translate([0.0, 0.9, 0.05]).scale([1.2, 0.08, 0.05]),
                "bsdf": {"type": "diffuse"},
            },
        }
    if name == "glossy":
        # a rough metal floor reflecting a bright rectangle light and a dim sky (light and BSDF
        # sampling, combined by MIS)
        return {
            "type": "scene",
            "integrator": {"type": "direct"},
            "sensor": {
                "type": "perspective",
                "fov": 40,
                "to_world": T().look_at(origin=[0, -3.0, 1.2], target=[0, 0.5, 0.2], up=[0, 0, 1]),
                "film": film,
            },
            "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.05}},
            "floor": {
                "type": "rectangle",
                "to_world": T().scale([4, 4, 1]),
                "bsdf": {"type": "roughconductor", "material": "Al", "distribution": "ggx", "alpha": 0.12},
            },
            "ball": {"type": "sphere", "center": [0.6, 0.3, 0.35], "radius": 0.35, "bsdf": {"type": "diffuse"}},
            "light": {
                "type": "rectangle",
                "to_world": T().translate([-0.3, 2.0, 1.0]).rotate([1, 0, 0], 80).scale([0.8, 0.4, 1]),
                "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 12.0}},
            },
        }
    raise ValueError(name)


SCENES = ["cornell-direct", "soft-shadow", "cornell-path"]
DIRECT_SCENES = ["cornell-direct", "soft-shadow"]


def render(mi, scene: str, sampler: str, spp: int, seed: int, width: int, props: dict | None = None):
    """One render: (image, seconds, samples per pixel the sampler used); props: the sampler's other
    properties."""
    d = scene_dict(mi, scene, width)
    d["sensor"]["sampler"] = {"type": sampler, "sample_count": spp, "seed": seed, **(props or {})}
    sc = mi.load_dict(d)
    used = sc.sensors()[0].sampler().sample_count()
    t = time.perf_counter()
    img = np.array(mi.render(sc), dtype=np.float64)
    return img, time.perf_counter() - t, used


def reference(mi, scene: str, width: int, spp: int = REF_SPP):
    """The scene's reference image at spp samples per pixel (ldsampler, two halves of other seeds,
    cached in CACHE) and the squared error of that mean, from the halves' difference."""
    CACHE.mkdir(parents=True, exist_ok=True)
    path = CACHE / f"ref-{scene}-{width}-{spp}.npz"
    if path.is_file():
        z = np.load(path)
        return z["ref"], float(z["ref_mse"])
    halves = [render(mi, scene, "ldsampler", spp // 2, 1000 + k, width)[0] for k in range(2)]
    ref = 0.5 * (halves[0] + halves[1])
    ref_mse = float(((halves[0] - halves[1]) ** 2).mean() / 4)  # error of the mean of two halves
    np.savez(path, ref=ref, ref_mse=ref_mse)
    return ref, ref_mse
