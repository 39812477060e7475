"""Where the commands' points come from: point files, dpc models (bundled names or .onnx files)
and baselines."""

from __future__ import annotations

import sys
from pathlib import Path

import click
import numpy as np

from .. import baselines, pointio
from .._model import DEFAULT_THREADS
from ..errors import InvalidArgumentError, ModelNotFoundError
from .options import Inputs, input_kind, max_bytes, progress_bar

POINT_EXTS = pointio.EXTENSIONS


def load_model(
    name: str, threads: int = DEFAULT_THREADS, isa: str = "auto", backend: str = "auto", input: str = "auto"
):  # noqa: A002
    import dpc

    return dpc.load(name, threads=threads, isa=isa, backend=backend, input=input)


def is_model(spec: str) -> bool:
    import dpc

    if Path(spec).suffix.lower() == ".onnx":
        return True  # a model path; a missing file is reported by dpc.load
    try:
        path = dpc.model_path(spec)
    except ModelNotFoundError:
        return False
    return Path(path).is_file()


def generate_sets(
    spec: str,
    n_points: int | None,
    dims: int | None,
    count: int,
    seed: int,
    threads: int = DEFAULT_THREADS,
    isa: str = "auto",
    backend: str = "auto",
    input: str = "auto",
    max_bytes: float | None = None,
) -> tuple[np.ndarray, str, object]:
    """Sets from a dpc model (bundled name or .onnx path) or a baseline name, with a progress
    bar (set c always comes from seed + c, modulo 2^64); returns (sets, name, the loaded model
    or None for a baseline). ``input`` applies to models only. Model sets stay float32."""
    if spec in baselines.BASELINES:
        base = baselines.get(spec)
        if n_points is None and not isinstance(base, baselines.ReferenceBaseline):
            raise click.UsageError(f"baseline {spec} needs -n/--points")
        if isinstance(base, baselines.ReferenceBaseline):
            return base.generate_batch(count, n_points, dims, seed), spec, None
        baselines.check_output_size(count, n_points, 2 if dims is None else dims, max_bytes)  # before the work
        out = []
        for c in progress_bar(range(count), f"{spec}"):
            out.append(base.generate_batch(1, n_points, 2 if dims is None else dims, seed + c)[0])
        return np.stack(out), spec, None
    if not is_model(spec):
        if Path(spec).suffix.lower() in POINT_EXTS:
            raise click.ClickException(f"no such file: {spec}")
        raise click.ClickException(f"{spec!r} is neither a file, a baseline nor a model (see 'dpc list')")
    model = load_model(spec, threads, isa, backend, input)
    if dims is not None and dims != model.dims:
        raise InvalidArgumentError(f"model {model.name} makes {model.dims}-D points, not {dims}-D")
    from tqdm import tqdm

    # One call (the size limit applies to the whole request, before anything is allocated);
    # libdpc reports layers of sets, shown once the run has taken a second.
    with tqdm(
        total=count * model.layers,
        desc=model.name,
        unit="layer",
        delay=1.0,
        leave=False,
        dynamic_ncols=True,
        file=sys.stderr,
    ) as bar:

        def progress(done, total):
            bar.update(done - bar.n)

        sets = model.generate_batch(count, seed=seed, n_points=n_points, max_bytes=max_bytes, progress=progress)
    return sets, model.name, model


def ran_on(model) -> str:
    """What ran a model, for the closing line: backend and ISA path or device, input kind."""
    where = f"cpu, {model.isa}" if model.backend == "cpu" else f"vulkan, {model.device}"
    return f"{where}; {model.input} input"


def read_inputs(inp: Inputs) -> list[tuple[str, np.ndarray, object]]:
    """Each input of analyze or compare: a point file, or a model (bundled name or .onnx file) or
    baseline to generate from (a model from stratified input points is labelled "NAME
    (stratified)"). Returns (label, sets, the model or None)."""
    out = []
    for spec in inp.specs:
        p = Path(spec)
        if p.suffix.lower() != ".onnx" and (p.is_file() or (p.exists() and not p.is_dir())):
            # a FIFO or device too: read_points refuses it at once, naming it
            sets = pointio.read_points(spec, dims=inp.dims, bin_dtype=inp.bin_dtype, progress_bar=True)
            out.append((p.stem, sets, None))
        else:
            sets, name, model = generate_sets(
                spec,
                inp.n_points,
                inp.dims,
                inp.count,
                inp.seed,
                inp.threads,
                input=input_kind(inp.stratified),
                max_bytes=max_bytes(inp.max_output),
            )
            label = name + (" (stratified)" if model and model.input == "stratified" else "")
            out.append((label, sets.astype(np.float64), model))
    return out
