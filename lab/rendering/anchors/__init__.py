"""The samplers the rendering bench measures dpc against, as Mitsuba 3 plugins (C++, compiled like
dpc's own, so that render times compare): ZSobol (Ahmed and Wonka 2020), Owen-scrambled Sobol'
across dimensions, padded Sobol' (2-D pairs), PMJ02BN (Christensen et al. 2018) and Heitz et al.
2019's screen-space sampler. Bench code, not the package (anchor_samplers.cpp says what each is).

    import mitsuba as mi; mi.set_variant("scalar_rgb")
    from lab.rendering import anchors
    anchors.register()                                   # builds once, then registers the five
    {"type": "zsobol", "sample_count": 16, **anchors.properties("zsobol")}

Tables: Sobol' direction numbers from scipy (Joe and Kuo 2008's new-joe-kuo-6.21201, which
scipy.stats.qmc.Sobol uses), PMJ02BN points from dpc.baselines.pmj02 (written from the paper),
and Heitz et al.'s published keys (heitz2019.npz: MIT, see HEITZ2019-LICENSE.md beside it).
"""

from __future__ import annotations

import hashlib
import os
import shlex
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from lab.common import CACHE

HERE = Path(__file__).parent
SOURCE = HERE / "anchor_samplers.cpp"
HEITZ = HERE / "heitz2019.npz"
ANCHORS = ["zsobol", "owen_sobol", "padded_sobol", "pmj02bn", "heitz2019"]
HEITZ_COUNTS = [1, 2, 4, 8, 16, 32, 64, 128, 256]
SOBOL_DIMS, PMJ_TABLES, PMJ_POINTS = 256, 16, 256  # as anchor_samplers.cpp reads them


def _folder(mi) -> Path:
    h = hashlib.sha256(SOURCE.read_bytes() + mi.__version__.encode()).hexdigest()[:12]
    return CACHE / f"anchors-{mi.__version__}-{h}"


def sobol_directions(dims: int = SOBOL_DIMS) -> np.ndarray:
    """(dims, 32) uint32: column k of dimension d is the 32-bit value that bit k of the index
    XORs in (scipy's direction numbers; the tests check them against scipy's points)."""
    from scipy.stats import _sobol  # noqa: PLC0415  (its direction numbers; no public accessor)

    v = np.zeros((dims, 32), dtype=np.uint64)
    _sobol._initialize_v(v, dims, 32)
    return v.astype(np.uint32)


def pmj02bn_tables(tables: int = PMJ_TABLES, points: int = PMJ_POINTS) -> np.ndarray:
    """(tables, points, 2) uint32 fixed point: PMJ02BN sequences, 100 best candidates per point."""
    from dpc.baselines import pmj02  # noqa: PLC0415

    out = np.stack([pmj02(points, np.random.default_rng(7000 + t), candidates=100) for t in range(tables)])
    return np.minimum(np.floor(out * 2.0**32), 2.0**32 - 1).astype(np.uint32)


def heitz_blob() -> bytes:
    """Heitz et al.'s tables in the layout anchor_samplers.cpp reads: the Sobol' bytes, then for
    each count the scrambling and ranking keys."""
    z = np.load(HEITZ)
    parts = [z["sobol"].astype(np.uint8).tobytes()]
    for n in HEITZ_COUNTS:
        parts += [z[f"scrambling_{n}spp"].astype(np.uint8).tobytes(), z[f"ranking_{n}spp"].astype(np.uint8).tobytes()]
    return b"".join(parts)


def _write(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent)
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def build(mi) -> Path:
    """Compile the plugins and write their tables once per source and Mitsuba version."""
    folder = _folder(mi)
    plugins = folder / "plugins"
    if all((plugins / f"{n}.so").is_file() for n in ANCHORS):
        return folder
    plugins.mkdir(parents=True, exist_ok=True)
    import drjit  # noqa: PLC0415
    import nanobind  # noqa: PLC0415

    mi_dir, dr_dir = Path(mi.__file__).parent, Path(drjit.__file__).parent
    lib = folder / "anchors.so"
    cmd = [
        *shlex.split(os.environ.get("CXX", "c++")),
        "-std=c++17",
        "-O2",
        "-fPIC",
        "-shared",
        "-fvisibility=hidden",
        "-w",
        f"-I{mi_dir / 'include'}",
        f"-I{dr_dir / 'include'}",
        f"-I{nanobind.include_dir()}",
        str(SOURCE),
        "-o",
        str(lib),
        f"-L{mi_dir}",
        "-lmitsuba",
        f"-L{dr_dir}",
        "-ldrjit-core",
        "-ldrjit-extra",
        f"-Wl,-rpath,{mi_dir}:{dr_dir}",
    ]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError("compiling the anchor samplers failed:\n" + shlex.join(cmd) + "\n" + r.stderr[-4000:])
    _write(folder / "sobol.bin", sobol_directions().astype("<u4").tobytes())
    _write(folder / "pmj02bn.bin", pmj02bn_tables().astype("<u4").tobytes())
    _write(folder / "heitz2019.bin", heitz_blob())
    for n in ANCHORS:  # one library, registered under each name (init_plugin picks the class)
        _write(plugins / f"{n}.so", lib.read_bytes())
    return folder


def register(mi=None) -> Path:
    """Build if needed and put the plugins on Mitsuba's search path; returns their folder."""
    if mi is None:
        import mitsuba as mi  # noqa: PLC0415
    folder = build(mi)
    resolver = mi.file_resolver()
    if str(folder) not in [str(p) for p in resolver]:
        resolver.prepend(str(folder))
    return folder


def properties(name: str, mi=None) -> dict:
    """The plugin properties an anchor needs besides sample_count and seed (its tables)."""
    if mi is None:
        import mitsuba as mi  # noqa: PLC0415
    files = {"owen_sobol": "sobol.bin", "pmj02bn": "pmj02bn.bin", "heitz2019": "heitz2019.bin"}
    return {"tables": str(_folder(mi) / files[name])} if name in files else {}
