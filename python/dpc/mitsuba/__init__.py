"""dpc in Mitsuba 3: the sampler plugin ``"dpc"``.

    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    import dpc.mitsuba                      # builds the plugin once, then registers it

    scene = mi.load_dict({..., "sensor": {..., "sampler": {"type": "dpc", "sample_count": 16}}})

Plugin properties, as for Mitsuba's own samplers: ``sample_count`` (default 4), ``seed``
(default 0), and ``model`` (default ``bnot-2d-stratified``; a bundled name or a ``.onnx`` path,
several separated by commas), ``dimensions`` (tables, default 16), ``block_size`` (the
integrator's block size when it is not Mitsuba's default 32), ``fold_from`` (the first dimension
folded by the baker's transform, default -1: none; 1: all but Mitsuba's film position;
docs/rendering.md) and ``net_dims`` (the first dimensions served by blue-noise (0,m,2)-nets when
``sample_count`` is a power of two; not given: 2, the film position and the integrators' first
sample, the light sample, or 3 in spectral variants, whose wavelength sample comes between them,
with dpc's sets for the BSDF samples and later bounces, where they had up to 1.6 times lower MSE
in Mitsuba, lab/rendering/slots_study.py and spectral_study.py; libdpc's default for
progressive models and frames; -1: libdpc's default, every dimension; 0 for none) and ``net_layout``
(``"screen"``: nets shared by a 32 x 32 tile of pixels in a randomised Morton order, errors blue
across pixels; ``"pixel"``: each pixel's net digitally shifted; default ``"auto"``: screen below
64 spp). In XML::

    <sampler type="dpc"><integer name="sample_count" value="16"/></sampler>

The plugin is C++ (a Python sampler costs Mitsuba a Python call per value: 10x slower renders
on two threads here). :func:`build` compiles ``dpc_sampler.cpp`` against the installed Mitsuba
and the libdpc inside this package, once per Mitsuba and dpc version, into a cache folder
(``$DPC_CACHE_DIR``, else ``$XDG_CACHE_HOME/dpc``, else ``~/.cache/dpc``); it needs a C++17
compiler (``$CXX``, else ``c++``) and the ``nanobind`` headers (``pip install .[mitsuba]``
installs them with Mitsuba). Scalar variants only: see docs/rendering.md for why.
"""

from __future__ import annotations

import hashlib
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from .._core import __version__ as _dpc_version
from ..errors import UnsupportedError

_SOURCE = "dpc_sampler.cpp"
_PLUGIN = "dpc.so"


def _package_dir() -> Path:
    """The installed package's folder: the one holding the extension, lib/libdpc.so.N, include/
    and models/ (an editable install keeps the Python files elsewhere)."""
    from .. import _core  # noqa: PLC0415

    return Path(_core.__file__).parent


def cache_root() -> Path:
    """Where built plugins are kept."""
    if os.environ.get("DPC_CACHE_DIR"):
        return Path(os.environ["DPC_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "dpc"


def _mitsuba():
    try:
        import mitsuba  # noqa: PLC0415  (optional dependency)
    except ImportError as e:
        raise UnsupportedError(
            "dpc.mitsuba needs Mitsuba 3: pip install 'mitsuba>=3.5' nanobind "
            "(or pip install .[mitsuba] from the dpc repository)"
        ) from e
    return mitsuba


def _source() -> Path:
    return Path(__file__).with_name(_SOURCE)


def plugin_folder() -> Path:
    """The folder to put on Mitsuba's search path: it holds ``plugins/dpc.so`` once built.
    One per (Mitsuba version, dpc version, plugin source, the dpc headers)."""
    mi = _mitsuba()
    pkg = _package_dir()
    h = hashlib.sha256()
    for part in (mi.__version__, _dpc_version, sys.version, str(pkg)):
        h.update(part.encode())
    h.update(_source().read_bytes())
    for header in sorted((pkg / "include" / "dpc").glob("*.h")):
        h.update(header.read_bytes())
    return cache_root() / f"mitsuba-{mi.__version__}-dpc-{_dpc_version}-{h.hexdigest()[:12]}"


def _compile_command(output: Path) -> list[str]:
    mi = _mitsuba()
    try:
        import nanobind  # noqa: PLC0415
    except ImportError as e:
        raise UnsupportedError(
            "building the dpc Mitsuba plugin needs the nanobind headers: pip install nanobind"
        ) from e
    import drjit  # noqa: PLC0415  (installed with mitsuba)

    mi_dir, dr_dir, pkg = Path(mi.__file__).parent, Path(drjit.__file__).parent, _package_dir()
    libdpc = pkg / "lib" / "libdpc.so.0"
    cxx = shlex.split(os.environ.get("CXX", "c++"))
    return [
        *cxx,
        "-std=c++17",
        "-O2",
        "-fPIC",
        "-shared",
        "-fvisibility=hidden",
        "-w",
        f"-I{mi_dir / 'include'}",
        f"-I{dr_dir / 'include'}",
        f"-I{nanobind.include_dir()}",
        f"-I{pkg / 'include'}",
        str(_source()),
        "-o",
        str(output),
        f"-L{mi_dir}",
        "-lmitsuba",
        f"-L{dr_dir}",
        "-ldrjit-core",
        "-ldrjit-extra",
        str(libdpc),
        f"-Wl,-rpath,{mi_dir}:{dr_dir}:{libdpc.parent}",
    ]


def build(force: bool = False) -> Path:
    """Compile the plugin if this Mitsuba/dpc pair has none yet; returns its folder."""
    folder = plugin_folder()
    target = folder / "plugins" / _PLUGIN
    if target.is_file() and not force:
        return folder
    target.parent.mkdir(parents=True, exist_ok=True)
    cmd0 = shlex.split(os.environ.get("CXX", "c++"))[0]
    if not shutil.which(cmd0):
        raise UnsupportedError(
            f"building the dpc Mitsuba plugin needs a C++17 compiler; '{cmd0}' is not on PATH (set CXX)"
        )
    # Compile next to the target and rename: a concurrent or interrupted build never leaves a
    # half-written plugin where Mitsuba looks.
    fd, tmp = tempfile.mkstemp(prefix=".dpc-", suffix=".so", dir=target.parent)
    os.close(fd)
    try:
        cmd = _compile_command(Path(tmp))
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            raise UnsupportedError(
                "compiling the dpc Mitsuba plugin failed:\n" + shlex.join(cmd) + "\n" + (r.stderr or r.stdout)[-4000:]
            )
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return folder


def register(force_build: bool = False) -> Path:
    """Build if needed and put the plugin on Mitsuba's search path (``mi.file_resolver()``), so
    scenes can use ``{"type": "dpc"}``. Idempotent; returns the plugin folder."""
    mi = _mitsuba()
    folder = build(force=force_build)
    resolver = mi.file_resolver()
    if str(folder) not in [str(p) for p in resolver]:
        resolver.prepend(str(folder))
    return folder


register()
