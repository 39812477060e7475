"""The ``dpc`` command line: list, generate, analyze, compare, mask, dither.

UTK-style short flags: -m model (in mask and dither: the mask's source, a model or baseline;
--mask is still accepted there), -n points (mask, dither: pixels per side), -d dims, -s seed,
-c sets, -i input, -o output.
Models are bundled names (``dpc list``; more in the folders of $DPC_MODEL_PATH) or ``.onnx``
paths, in every command. Errors print one line ``dpc: error: ...`` and exit with 2 (bad usage)
or 1 (anything else); set DPC_DEBUG=1 to get the traceback instead. Ctrl-C stops any command
at once (exit 130). Every file is written atomically and a command that fails or is
interrupted leaves no output behind and every existing file as it was (``dpc._atomic``).
"""

from __future__ import annotations

import json
import os
import re
import sys
import textwrap
from pathlib import Path

import click
import numpy as np

from . import _atomic, baselines, pointio
from ._model import _BACKEND, _ISA, DEFAULT_THREADS
from ._model import balance as balance_set
from .errors import DpcError, InvalidArgumentError, ModelNotFoundError

_POINT_EXTS = pointio.EXTENSIONS
_MODEL_HELP = "a bundled model name (see 'dpc list'; the folders of $DPC_MODEL_PATH are searched first) or a .onnx file"
_PLOT_FORMATS = ("png", "pdf", "svg")
# = dpc.analysis.DISCREPANCY_METHODS (not imported here: scipy makes start-up slow)
_DISC_DEFAULT = "CD,WD,MD,L2-star,GL2,UL2"
_NO_ARGS_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())
_FORMAT_CHOICE = click.Choice(list(pointio.FORMAT_NAMES), case_sensitive=False)
_SEED = click.IntRange(min=0, max=(1 << 64) - 1)


# ---------------------------------------------------------------- helpers
def count_of(k: int, noun: str = "set") -> str:
    """'1 set', '16 sets' (dpc.analysis._common has the same; importing it here would pull in
    scipy at start-up)."""
    return f"{k} {noun}" if k == 1 else f"{k} {noun}s"


class _Option(click.Option):
    """An option that also accepts ``old_names`` (earlier spellings, kept so that scripts keep
    working) without showing them in the help."""

    def __init__(self, *args, old_names=(), **kwargs):
        super().__init__(*args, **kwargs)
        self._old_names = set(old_names)

    def get_help_record(self, ctx):
        shown, self.opts = self.opts, [o for o in self.opts if o not in self._old_names]
        try:
            return super().get_help_record(ctx)
        finally:
            self.opts = shown


def _max_pixels_option(what: str):
    return click.option(
        "--max-pixels",
        type=click.IntRange(min=1),
        default=None,
        metavar="N",
        help=f"Largest {what} in pixels, checked before any work: default 67108864 (8192 x 8192; "
        "$DPC_MAX_PIXELS), and 65536 (256 x 256; $DPC_MAX_DESIGN_PIXELS) for masks designed on the "
        "spot (void-and-cluster, stbn, annealed), whose time grows with the square of the pixels.",
    )


def _check_output(path) -> None:
    """A missing or unwritable output folder, reported before the work (dpc._atomic)."""
    if path is not None:
        _atomic.check_output(path)


def _progress(iterable, desc: str, total: int | None = None):
    from tqdm import tqdm

    return tqdm(iterable, desc=desc, total=total, delay=1.0, leave=False, dynamic_ncols=True, file=sys.stderr)


def _load_model(
    name: str, threads: int = DEFAULT_THREADS, isa: str = "auto", backend: str = "auto", input: str = "auto"
):  # noqa: A002
    import dpc

    return dpc.load(name, threads=threads, isa=isa, backend=backend, input=input)


def _is_model(spec: str) -> bool:
    import dpc

    if Path(spec).suffix.lower() == ".onnx":
        return True  # a model path; a missing file is reported by dpc.load
    try:
        path = dpc.model_path(spec)
    except ModelNotFoundError:
        return False
    return Path(path).is_file()


def _max_output_option(f):
    return click.option(
        "--max-output",
        "max_output",
        default=None,
        metavar="SIZE",
        help="Largest output one model call may allocate (sets x points x dims floats), e.g. "
        "16G; default 4G or $DPC_MAX_OUTPUT_BYTES. Bigger requests stop with an error "
        "before allocating.",
    )(f)


def _max_bytes(text: str | None) -> float | None:
    if text is None:
        return None
    from ._model import parse_size

    return float(parse_size(text))


def _generate(
    spec: str,
    n_points: int | None,
    dims: int | None,
    count: int,
    seed: int,
    threads: int = DEFAULT_THREADS,
    isa: str = "auto",
    backend: str = "auto",
    input: str = "auto",
    max_bytes: float | None = None,  # noqa: A002
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
        for c in _progress(range(count), f"{spec}"):
            out.append(base.generate_batch(1, n_points, 2 if dims is None else dims, seed + c)[0])
        return np.stack(out), spec, None
    if not _is_model(spec):
        if Path(spec).suffix.lower() in _POINT_EXTS:
            raise click.ClickException(f"no such file: {spec}")
        raise click.ClickException(f"{spec!r} is neither a file, a baseline nor a model (see 'dpc list')")
    model = _load_model(spec, threads, isa, backend, input)
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


def _ran_on(model) -> str:
    """What ran a model, for the closing line: backend and ISA path or device, input kind."""
    where = f"cpu, {model.isa}" if model.backend == "cpu" else f"vulkan, {model.device}"
    return f"{where}; {model.input} input"


_stratified_option = click.option(
    "--stratified/--uniform",
    default=None,
    help="Input points of models: stratified (one per grid cell, docs/model-format.md §5; "
    "blue-noise models stay blue at the largest scales for large -n) or uniform. Default: "
    "what each model was trained on (its metadata dpc.input, uniform without it; of the "
    "bundled models bnot-2d-stratified says stratified).",
)


def _input_kind(stratified: bool | None) -> str:
    return "auto" if stratified is None else ("stratified" if stratified else "uniform")


def _read_inputs(
    specs,
    n_points,
    dims,
    count,
    seed,
    bin_dtype,
    stratified: bool | None = None,
    max_bytes: float | None = None,
    threads: int = DEFAULT_THREADS,
) -> list[tuple[str, np.ndarray, object]]:
    """Each input: a point file, or a model (bundled name or .onnx file) or baseline to generate
    from (a model from stratified input points is labelled "NAME (stratified)"). Returns
    (label, sets, the model or None)."""
    out = []
    for spec in specs:
        p = Path(spec)
        if p.suffix.lower() != ".onnx" and (p.is_file() or (p.exists() and not p.is_dir())):
            # a FIFO or device too: read_points refuses it at once, naming it
            out.append(
                (Path(spec).stem, pointio.read_points(spec, dims=dims, bin_dtype=bin_dtype, progress_bar=True), None)
            )
        else:
            sets, name, model = _generate(
                spec, n_points, dims, count, seed, threads, input=_input_kind(stratified), max_bytes=max_bytes
            )
            label = name + (" (stratified)" if model and model.input == "stratified" else "")
            out.append((label, sets.astype(np.float64), model))
    return out


def _parse_list(text: str | None, what: str, cast=str) -> list | None:
    if text is None:
        return None
    if text.strip().lower() in ("", "none"):
        return []
    try:
        return [cast(t.strip()) for t in text.split(",") if t.strip()]
    except ValueError:
        raise click.BadParameter(f"expected a comma-separated list of {what}, got {text!r}") from None


def _dump_json(doc, path: Path) -> None:
    text = json.dumps(doc, indent=2, allow_nan=False)
    # Keep arrays of numbers on one line: readable metrics, small files.
    text = re.sub(r"\[\s+([-+0-9.eE,\s]|null)+?\s*\]", lambda mt: "[" + " ".join(mt.group(0)[1:-1].split()) + "]", text)
    _atomic.write_text(path, text + "\n")


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _table(rows: list[dict], cols: list[str]) -> str:
    cells = [[_fmt(r.get(c)) for c in cols] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(cols)]

    def line(vals):
        return "| " + " | ".join(v.rjust(w) for v, w in zip(vals, widths)) + " |"

    out = [line(cols), "|" + "|".join("-" * (w + 2) for w in widths) + "|"]
    out += [line(row) for row in cells]
    return "\n".join(out)


_threads_option = click.option(
    "-t",
    "--threads",
    type=click.IntRange(min=0),
    default=DEFAULT_THREADS,
    show_default=True,
    help="Worker threads for models: 1 runs on the calling thread (libdpc's default), 0 = one per "
    "CPU. The points do not depend on it.",
)


def _analysis_options(f):
    opts = [
        click.option(
            "--nu-max",
            type=click.FloatRange(min=0.1),
            default=4.0,
            show_default=True,
            help="Largest normalised frequency analysed.",
        ),
        click.option(
            "--max-size",
            type=click.IntRange(min=17),
            default=513,
            show_default=True,
            help="Largest 2-D spectrum grid per axis (beyond it: frequency stride).",
        ),
        click.option(
            "--subspace", default="0,1", show_default=True, help="Two axes for the 2-D spectrum of n-D points."
        ),
        click.option(
            "--discrepancy",
            "disc",
            default=_DISC_DEFAULT,
            show_default=True,
            help="Discrepancies to compute ('none' for none).",
        ),
        click.option(
            "--disc-budget",
            type=click.FloatRange(min=0),
            default=2.0**26,
            show_default=True,
            help="Pair terms allowed for all discrepancies (O(m^2) per set).",
        ),
        click.option(
            "-n",
            "--points",
            "n_points",
            type=click.IntRange(min=1),
            default=None,
            help="Points per set, for inputs generated from a model or baseline.",
        ),
        click.option(
            "-d",
            "--dims",
            type=click.IntRange(min=1),
            default=None,
            help="Dimension of generated inputs; hint for UTK .bin files.",
        ),
        click.option(
            "-c",
            "--sets",
            "count",
            type=click.IntRange(min=1),
            default=16,
            show_default=True,
            help="Sets for generated inputs.",
        ),
        click.option(
            "-s",
            "--seed",
            type=_SEED,
            default=0,
            show_default=True,
            help="Seed of generated inputs, 0 .. 2^64-1 (set c from seed + c mod 2^64).",
        ),
        click.option(
            "--bin-dtype",
            type=click.Choice(["float64", "float32"]),
            default=None,
            help="Float type of UTK .bin inputs (default: detect).",
        ),
        click.option(
            "--plot-format",
            "plot_formats",
            default="png,pdf",
            show_default=True,
            help="Formats of the plots, comma-separated: png, pdf, svg.",
        ),
        click.option(
            "--max-output",
            "max_output",
            default=None,
            metavar="SIZE",
            help="Largest output one model call may allocate, e.g. 16G (default 4G or $DPC_MAX_OUTPUT_BYTES).",
        ),
        _threads_option,
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def _run_analysis(points, label, nu_max, max_size, subspace, disc, disc_budget, seed):
    from .analysis import analyze

    sub = _parse_list(subspace, "axes", int)
    methods = _parse_list(disc, "discrepancy names")
    return analyze(
        points,
        label=label,
        nu_max=nu_max,
        max_size=max_size,
        dims=tuple(sub) if sub else (0, 1),
        discrepancies=methods,
        discrepancy_budget=disc_budget,
        seed=seed,
        progress_bar=True,
    )


def _output_dir(path: str) -> Path:
    """The output folder, created inside the command's transaction (removed again if the
    command fails)."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise click.BadParameter(f"{path} exists and is not a folder", param_hint="-o")
    return _atomic.make_dir(out)


def _plot_formats(text: str) -> list[str]:
    fmts = _parse_list(text, "plot formats") or []
    bad = [f for f in fmts if f.lower() not in _PLOT_FORMATS]
    if bad or not fmts:
        raise click.BadParameter(f"{text!r}: choose from {', '.join(_PLOT_FORMATS)}", param_hint="--plot-format")
    return list(dict.fromkeys(f.lower() for f in fmts))


# ---------------------------------------------------------------- commands
@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(version=None, package_name="deep-point-correlation", prog_name="dpc")
def cli():
    """dpc: point patterns from Deep Point Correlation Design (Leimkuehler et al. 2019)."""


@cli.command("list")
def list_cmd():
    """List the models (bundled, and those in the folders of $DPC_MODEL_PATH, which come first)
    with their whole descriptions and input kinds, and the baselines."""
    import shutil

    import dpc

    width = max(60, min(shutil.get_terminal_size((100, 24)).columns, 120))
    click.echo(
        "models:" + (f" (DPC_MODEL_PATH={os.environ['DPC_MODEL_PATH']})" if os.environ.get("DPC_MODEL_PATH") else "")
    )
    names = dpc.available_models()
    if not names:
        click.echo("  (none bundled; set DPC_MODEL_PATH or pass a .onnx file)")
    for name in names:
        try:
            m = dpc.load(name)
        except DpcError as e:
            click.echo(f"  {name:22s} (cannot load: {_one_line(e)})")
            continue
        click.echo(
            f"  {name:22s} {m.dims}-D, trained m={m.n_points}, {m.layers} layers, "
            f"{m.input} input"
            + (f", grid {'x'.join(map(str, m.grid_shape))}" if m.grid_shape else "")
            + (f", output balanced at |q| <= {m.balance}" if m.balance else "")
        )
        desc = " ".join(m.metadata.get("dpc.description", "").split())
        if desc:
            click.echo(
                textwrap.fill(
                    desc, width=width, initial_indent=" " * 4, subsequent_indent=" " * 4, break_on_hyphens=False
                )
            )
    click.echo("baselines:")
    for name, b in baselines.BASELINES.items():
        extra = ""
        if isinstance(b, baselines.ReferenceBaseline):
            extra = "  [" + ", ".join(f"m={m} d={d}: {count_of(k)}" for m, d, k in b.available()) + "]"
        click.echo(f"  {name:22s} {b.description}{extra}")


@cli.command("generate")
@click.option("-m", "--model", required=True, help="Model: " + _MODEL_HELP + "; or a baseline name (see 'dpc list').")
@click.option(
    "-n",
    "--points",
    "n_points",
    type=click.IntRange(min=1),
    default=None,
    help="Points per set (default: the model's trained count).",
)
@click.option(
    "-d",
    "--dims",
    type=click.IntRange(min=1),
    default=None,
    help="Dimension (baselines; default 2; must match a model).",
)
@click.option(
    "-s",
    "--seed",
    type=_SEED,
    default=0,
    show_default=True,
    help="Seed, 0 .. 2^64-1; set c comes from seed + c (mod 2^64).",
)
@click.option("-c", "--sets", "count", type=click.IntRange(min=1), default=1, show_default=True, help="Number of sets.")
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Output file: " + pointio.describe_extensions() + "; default: text on stdout. "
    "Written atomically (an existing file stays as it was if anything fails).",
)
@click.option(
    "-f",
    "--format",
    "fmt",
    type=_FORMAT_CHOICE,
    default=None,
    help="File format (default: from the extension): npy; dat (UTK's text format; "
    "txt, text: the same); csv (commas); bin (UTK's binary format).",
)
@click.option(
    "--bin-dtype",
    type=click.Choice(["float64", "float32"]),
    default="float64",
    show_default=True,
    help="Float type of UTK .bin output.",
)
@_threads_option
@click.option(
    "--isa",
    type=click.Choice(list(_ISA)),  # dpc_isa's members (dpc.Isa), in lower case
    default="auto",
    show_default=True,
    help="CPU code path for models. Every path gives the same bits (a canonical "
    "order of float operations); only speed differs.",
)
@click.option(
    "--backend",
    type=click.Choice(list(_BACKEND)),  # dpc_backend's members (dpc.Backend)
    default="auto",
    show_default=True,
    help="What runs a model: auto (a Vulkan GPU if there is one, else the CPU), cpu, "
    "or vulkan (an error where no Vulkan device is usable).",
)
@_stratified_option
@click.option(
    "--balance",
    type=click.IntRange(0, 32),
    default=None,
    help="Balance every set at the integer frequencies 0 < |q| <= K afterwards (dpc.balance, "
    "docs/model-format.md §5.1: no power left at the torus scale; float32 output). Models "
    "with metadata dpc.balance (blue-2d) are balanced already; not for progressive models.",
)
@_max_output_option
def generate_cmd(
    model, n_points, dims, seed, count, output, fmt, bin_dtype, threads, isa, backend, stratified, balance, max_output
):
    """Generate point sets from a model or a baseline. A model's sets are float32 (kept so in
    .npy and float32 .bin files; text has 17 significant digits)."""
    if output is not None:
        pointio.resolve_format(output, fmt)  # fail on a bad name or folder before the work
        _check_output(output)
    if stratified is not None and model in baselines.BASELINES:
        raise click.UsageError("--stratified/--uniform apply to models, not to baselines")
    sets, name, loaded = _generate(
        model, n_points, dims, count, seed, threads, isa, backend, _input_kind(stratified), _max_bytes(max_output)
    )
    if balance:
        if loaded is not None and loaded.order == "progressive":
            raise click.UsageError(
                f"--balance moves every point, so {name}'s prefixes would no longer be its smaller sets; "
                "a progressive model balances level by level through its own dpc.balance "
                "(progressive-2d-balanced, docs/progressive.md)"
            )
        sets = np.stack([balance_set(s, balance) for s in sets])
    if output is None:
        kind = pointio.resolve_format("-.dat", fmt)
        if kind not in ("dat", "csv"):
            raise click.UsageError("stdout output is text (dat or csv); give -o FILE for other formats")
        sep = "," if kind == "csv" else " "
        for s in range(sets.shape[0]):
            if s:
                click.echo("#")
            click.echo("\n".join(sep.join(f"{float(v):.17g}" for v in row) for row in sets[s]))
        return
    pointio.write_points(output, sets, fmt, bin_dtype=bin_dtype, progress_bar=True)
    click.echo(
        f"wrote {count_of(sets.shape[0])} of {sets.shape[1]} {sets.shape[2]}-D points "
        f"from {name}{f' ({_ran_on(loaded)})' if loaded else ''} to {output}",
        err=True,
    )


@cli.command("analyze")
@click.option(
    "-i",
    "--input",
    "inputs",
    multiple=True,
    help="Point file(s) ("
    + pointio.describe_extensions()
    + "), or a model ("
    + _MODEL_HELP
    + ") or baseline to generate from; more may follow as arguments. All inputs "
    "form one batch of sets.",
)
@click.argument("more", nargs=-1)
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(file_okay=False),
    help="Folder for metrics.json and the plots (PNG and PDF by default, see "
    "--plot-format); a model's design target is drawn dashed where its metadata "
    "has one.",
)
@click.option("--label", default=None, help="Name used in titles (default: first input).")
@click.option("--no-plots", is_flag=True, help="Only write metrics.json.")
@_analysis_options
@_stratified_option
def analyze_cmd(
    inputs,
    more,
    output,
    label,
    no_plots,
    nu_max,
    max_size,
    subspace,
    disc,
    disc_budget,
    n_points,
    dims,
    count,
    seed,
    bin_dtype,
    plot_formats,
    max_output,
    threads,
    stratified,
):
    """Measure point sets: spectra, anisotropy, PCF, minimum distance, discrepancy."""
    specs = list(inputs) + list(more)
    if not specs:
        raise click.UsageError("give at least one input with -i")
    formats = _plot_formats(plot_formats)
    with _atomic.transaction():  # all outputs, or (on any failure) none and no new folder
        out = _output_dir(output)
        loaded = _read_inputs(
            specs, n_points, dims, count, seed, bin_dtype, stratified, _max_bytes(max_output), threads
        )
        shapes = {a.shape[1:] for _, a, _ in loaded}
        if len(shapes) > 1:
            raise click.ClickException(
                "inputs differ in points or dimension: "
                + ", ".join(f"{n}: {a.shape[1]}x{a.shape[2]}" for n, a, _ in loaded)
                + " (use 'dpc compare' for different inputs)"
            )
        sets = np.concatenate([a for _, a, _ in loaded])
        name = label or loaded[0][0]
        res = _run_analysis(sets, name, nu_max, max_size, subspace, disc, disc_budget, seed)
        doc = res.to_json()
        doc["input"]["sources"] = specs
        models = list(dict.fromkeys(m for _, _, m in loaded if m is not None))
        targets = _targets(models)
        if targets:
            doc["targets"] = [{"label": t.label, "dims": t.dims} for t in targets]
        _dump_json(doc, out / "metrics.json")
        written = ["metrics.json"]
        if not no_plots:
            written += _analysis_plots(res, sets, out, nu_max, formats, targets)
    s = res.summary()
    click.echo(f"{name}: {count_of(res.n_sets)} of {res.n_points} {res.dims}-D points")
    for key in ("E_low<0.5", "E_low<0.75", "peak", "peak_nu", "delta_min", *res.discrepancy.keys()):
        if key in s and s[key] is not None:
            click.echo(f"  {key:12s} {_fmt(s[key])}")
    for note in res.notes:
        click.echo(f"  note: {note}")
    click.echo(f"wrote {', '.join(written)} to {out}")


def _targets(models) -> list:
    """The design targets of the models (metadata; dpc.analysis.targets), one per distinct one."""
    from .analysis.targets import model_target

    out, seen = [], set()
    for m in models:
        t = model_target(m)
        if t is not None and t.label not in seen:
            seen.add(t.label)
            out.append(t)
    return out


def _refs(targets, dims: int, sub: tuple) -> list:
    """References for a radial plot of a ``dims``-D spectrum: 2-D targets belong to the
    subspace (0, 1) the models were trained on; n-D ones to the n-D radial spectrum."""
    return [t.as_reference() for t in targets if t.dims == dims and (dims != 2 or tuple(sub) in ((0, 1), (1, 0)))]


def _analysis_plots(res, sets, out: Path, nu_max: float, formats=("png",), targets=()) -> list[str]:
    from .analysis import plots

    title = f"{res.label}: m={res.n_points}, {count_of(res.n_sets)}"
    sub = tuple(res.spectrum.dims) if res.spectrum is not None else (0,)
    names: list[str] = []

    def save(fn, name, *args, **kw):
        fn(out / name, *args, formats=formats, **kw)
        names.extend(plots.written(out / name, formats))

    save(
        plots.save_points,
        "points.png",
        sets[0],
        dims=sub,
        title=f"{res.label}: set 0 of {res.n_sets}, m={res.n_points}",
    )
    if res.spectrum is not None:
        save(plots.save_spectrum2d, "spectrum.png", res.spectrum, title=title)
    curves = [(f"{res.label} (axes {sub[0]},{sub[1]})" if res.dims > 2 else res.label, res.radial)]
    save(
        plots.save_radial,
        "radial.png",
        curves,
        title=f"radial mean and anisotropy, {title}",
        nu_max=nu_max,
        reference=_refs(targets, len(sub) if res.spectrum is not None else 1, sub) or None,
    )
    if res.radial_nd is not None:
        save(
            plots.save_radial,
            "radial_nd.png",
            [(f"{res.label} ({res.dims}-D, MC)", res.radial_nd)],
            title=f"{res.dims}-D radial mean (Monte Carlo), {title}",
            nu_max=nu_max,
            reference=_refs(targets, res.dims, sub) or None,
        )
    if res.pcf is not None:
        save(plots.save_pcf, "pcf.png", [(res.label, res.pcf)], title=f"PCF, {title}")
    if res.projections:
        save(
            plots.save_projections,
            "projections.png",
            [(f"axis {p.dim}", p) for p in res.projections],
            title=f"1-D projections, {title}",
            nu_max=nu_max,
        )
    return names


@cli.command("compare")
@click.option(
    "-i",
    "--input",
    "inputs",
    multiple=True,
    help="A point file ("
    + pointio.describe_extensions()
    + "), or a model ("
    + _MODEL_HELP
    + ") or baseline generated with -n/-c/-s; repeat, or list more as arguments.",
)
@click.argument("more", nargs=-1)
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(file_okay=False),
    help="Folder for compare.json, compare.md and the plots (PNG and PDF by default); "
    "the models' design targets are drawn dashed where their metadata has them.",
)
@click.option(
    "--integration/--no-integration",
    default=True,
    show_default=True,
    help="Relative variance of MC integration over each input's sets.",
)
@_analysis_options
@_stratified_option
def compare_cmd(
    inputs,
    more,
    output,
    integration,
    nu_max,
    max_size,
    subspace,
    disc,
    disc_budget,
    n_points,
    dims,
    count,
    seed,
    bin_dtype,
    plot_formats,
    max_output,
    threads,
    stratified,
):
    """Compare several inputs (files, models, baselines) in one table and plots."""
    specs = list(inputs) + list(more)
    if len(specs) < 1:
        raise click.UsageError("give inputs with -i")
    formats = _plot_formats(plot_formats)
    with _atomic.transaction():  # all outputs, or (on any failure) none and no new folder
        out = _output_dir(output)
        loaded = _read_inputs(
            specs, n_points, dims, count, seed, bin_dtype, stratified, _max_bytes(max_output), threads
        )
        labels, seen = [], {}
        for name, _, _ in loaded:  # unique labels
            seen[name] = seen.get(name, 0) + 1
            labels.append(name if seen[name] == 1 else f"{name}#{seen[name]}")
        results, rows = [], []
        for (_, sets, _), label in zip(loaded, labels):
            res = _run_analysis(sets, label, nu_max, max_size, subspace, disc, disc_budget, seed)
            row = res.summary()
            if integration:
                row.update(_integration_row(sets, res, seed))
            results.append((res, sets))
            rows.append(row)
        cols = list(dict.fromkeys(k for r in rows for k in r))
        table = _table(rows, cols)
        click.echo(table)
        _atomic.write_text(out / "compare.md", table + "\n")
        targets = _targets(list(dict.fromkeys(m for _, _, m in loaded if m is not None)))
        doc = {
            "dpc_compare": 1,
            "inputs": specs,
            "rows": rows,
            "analyses": [r.to_json() for r, _ in results],
            "targets": [{"label": t.label, "dims": t.dims} for t in targets],
        }
        _dump_json(doc, out / "compare.json")
        names = _compare_plots(results, out, nu_max, formats, targets)
    click.echo(f"wrote compare.md, compare.json, {', '.join(names)} to {out}")


def _integration_row(sets: np.ndarray, res, seed: int) -> dict:
    from .analysis.integration import FAMILIES, integrands, relative_variance

    if sets.shape[0] < 2 or sets.shape[2] < 2:
        return {}
    d = tuple(res.spectrum.dims) if res.spectrum is not None else (0, 1)
    row = {}
    for i, fam in enumerate(FAMILIES):
        f = integrands(fam, 10, dims=2, seed=seed + i)
        row[f"relvar_{fam}"] = float(relative_variance(sets[:, :, d], f).mean())
    return row


def _compare_plots(results, out: Path, nu_max: float, formats=("png",), targets=()) -> list[str]:
    from matplotlib.figure import Figure

    from .analysis import plots

    names: list[str] = []
    radial = [(r.label, r.radial) for r, _ in results if r.radial is not None]
    r0 = results[0][0]
    sub = tuple(r0.spectrum.dims) if r0.spectrum is not None else (0,)
    plots.save_radial(
        out / "radial.png",
        radial,
        title="radial mean power",
        anisotropy=False,
        nu_max=nu_max,
        formats=formats,
        reference=_refs(targets, len(sub) if r0.spectrum is not None else 1, sub) or None,
    )
    names += plots.written(out / "radial.png", formats)
    pcfs = [(r.label, r.pcf) for r, _ in results if r.pcf is not None]
    if pcfs:
        plots.save_pcf(out / "pcf.png", pcfs, title="pair correlation", formats=formats)
        names += plots.written(out / "pcf.png", formats)
    k = len(results)
    fig = Figure(figsize=(3.2 * k, 3.4))
    axes = np.atleast_1d(fig.subplots(1, k))
    for ax, (r, sets) in zip(axes, results):
        pts = sets[0]
        if pts.shape[1] >= 2:
            d = r.spectrum.dims
            ax.scatter(pts[:, d[0]], pts[:, d[1]], s=float(np.clip(2000 / len(pts), 0.2, 6)), c="k", linewidths=0)
            ax.set_aspect("equal")
            ax.set_ylim(0, 1)
        else:
            ax.eventplot(pts[:, 0], colors="k", linewidths=0.5)
        ax.set_xlim(0, 1)
        ax.set_xticks([0, 1])
        ax.set_yticks([0, 1] if pts.shape[1] >= 2 else [])
        d = r.spectrum.dims if r.spectrum is not None else (0, 1)
        ax.set_xlabel(f"x{d[0]}", fontsize=8)
        if pts.shape[1] >= 2:
            ax.set_ylabel(f"x{d[1]}", fontsize=8)
        ax.set_title(f"{r.label} (m={r.n_points})", fontsize=9)
    for fmt in formats:
        _atomic.save_figure(fig, out / f"points.{fmt}", dpi=110, bbox_inches="tight", format=fmt)
    names += plots.written(out / "points.png", formats)
    return names


@cli.command("mask")
@click.option(
    "-m",
    "--model",
    "--mask",
    "name",
    cls=_Option,
    old_names=("--mask",),
    default="annealed",
    show_default=True,
    help="annealed (dpc's designed masks, the best here), a gridded mask model (bundled name or "
    ".onnx) or a baseline: void-and-cluster, stbn, white, bayer (see 'dpc mask --list').",
)
@click.option(
    "-n",
    "--size",
    type=click.IntRange(min=2),
    default=None,
    help="Pixels per side (default: a model's trained grid; baselines need it).",
)
@click.option(
    "--frames",
    type=click.IntRange(min=1),
    default=None,
    help="Frames of a spatiotemporal mask (default: the model's; stbn needs it, annealed takes it).",
)
@click.option(
    "--channels",
    type=click.IntRange(min=1, max=4),
    default=None,
    help="Values per pixel, for baselines (white, void-and-cluster) and annealed (2).",
)
@click.option(
    "-s", "--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Seed of the mask realisation."
)
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Output: .npy (float64), .png (8/16-bit codes; R, G for 2 values) or .exr "
    '(float32; needs OpenEXR: pip install "deep-point-correlation[masks]"). Spatiotemporal '
    "masks: one .npy, or stem_000.png ... per frame.",
)
@click.option("--bits", type=click.Choice(["8", "16"]), default="16", show_default=True, help="PNG bit depth.")
@_max_pixels_option("mask (frames x size^2 x channels)")
@click.option("--list", "list_", is_flag=True, help="List the mask sources and exit.")
def mask_cmd(name, size, frames, channels, seed, output, bits, max_pixels, list_):
    """Write a blue-noise threshold mask (scalar, vector or spatiotemporal) and print its
    low-band energies (white noise = 1; docs/masks.md)."""
    from . import masks as M
    from .analysis import masks as AM

    if list_:
        for k, v in M.available().items():
            click.echo(f"  {k:22s} {v}")
        return
    if output is None:
        raise click.UsageError("give -o/--output (.npy, .png or .exr)")
    if Path(output).suffix.lower() not in M.MASK_EXTENSIONS:
        raise click.UsageError("-o/--output must end in .npy, .png or .exr")
    M.check_mask_path(output)  # EXR's package and the output folder, before the work
    from tqdm import tqdm

    bar_args = {"delay": 1.0, "leave": False, "dynamic_ncols": True, "file": sys.stderr, "unit": " swaps tried"}
    with tqdm(desc=f"designing {name}", **bar_args) as bar:

        def progress(done, total):  # annealed designs made on the spot take seconds to minutes
            bar.total = total
            bar.update(done - bar.n)

        arr = M.mask(
            name, size=size, seed=seed, frames=frames, channels=channels, progress=progress, max_pixels=max_pixels
        )
    st = arr.ndim == 3 and (frames is not None or name == "stbn" or M.kind_of(arr) == "spatiotemporal")
    kind = M.kind_of(arr, st)
    paths = M.write_mask(output, arr, bits=int(bits), spatiotemporal=st)
    if kind == "scalar":
        q = AM.scalar_quality(arr)
        summary = (
            f"mask E_low {q['mask_elow']:.5f}, thresholded 1/8..7/8 mean "
            f"{q['levels_elow_mean']:.4f} worst {q['levels_elow_max']:.4f}"
        )
    elif kind == "vector":
        q = AM.vector_quality(arr)
        summary = (
            f"per channel: mask E_low <= {q['mask_elow_max']:.5f}, thresholded mean <= "
            f"{q['levels_elow_mean_max']:.4f}; joint boxes mean {q['joint_elow_mean']:.4f}"
        )
    else:
        q = AM.spatiotemporal_quality(arr)
        summary = (
            f"frames: mask E_low mean {q['mask_elow_mean']:.5f}, thresholded mean "
            f"{q['levels_elow_mean']:.4f}; temporal E_low {q['temporal_elow']:.3f}; "
            f"accumulated RMSE after {q['frames']} frames {q['accumulated_rmse'][-1]:.4f}"
        )
    where = str(paths[0]) if len(paths) == 1 else f"{paths[0]} ... {paths[-1]} ({len(paths)} files)"
    click.echo(
        f"wrote {where}: {kind} mask {'x'.join(str(d) for d in arr.shape)} from {name} (seed {seed}); {summary}",
        err=True,
    )


@cli.command("dither")
@click.argument("image", type=click.Path(exists=True, dir_okay=False))
@click.option(
    "-m",
    "--model",
    "--mask",
    "model",
    cls=_Option,
    old_names=("--mask",),
    default="annealed",
    show_default=True,
    help="Mask: annealed (dpc's designed masks), a gridded mask model (bundled name or .onnx) or "
    "a baseline (void-and-cluster, stbn, white, bayer; see 'dpc mask --list').",
)
@click.option(
    "-n",
    "--size",
    type=click.IntRange(min=2),
    default=None,
    help="Mask pixels per side (default: the model's grid; baselines need it).",
)
@click.option(
    "--channel", type=click.IntRange(min=0), default=0, show_default=True, help="Value channel of a vector mask."
)
@click.option(
    "--frame", type=click.IntRange(min=0), default=0, show_default=True, help="Frame of a spatiotemporal mask."
)
@click.option(
    "-s", "--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Seed of the mask realisation."
)
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, writable=True),
    help="Dithered image (.png): black and white.",
)
@click.option(
    "--mask-output",
    type=click.Path(dir_okay=False, writable=True),
    default=None,
    help="Also write the mask: .npy (values in (0, 1)) or .png (8-bit grey).",
)
@click.option("--white-noise", is_flag=True, help="Use a white-noise mask of the same size instead (for comparison).")
@_max_pixels_option("image or mask")
def dither_cmd(image, model, size, channel, frame, seed, output, mask_output, white_noise, max_pixels):
    """Ordered dithering of IMAGE with a blue-noise mask (tiled): a gridded mask model or a
    baseline mask."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image as mpimg

    from . import masks as M
    from .analysis import dither as D

    if Path(output).suffix.lower() != ".png":
        raise click.UsageError("the output image must be a .png file")
    if mask_output is not None and Path(mask_output).suffix.lower() not in (".npy", ".png"):
        raise click.UsageError("--mask-output must end in .npy or .png")
    _check_output(output)
    _check_output(mask_output)
    img = D.read_image(image, max_pixels)  # regular files only; size checked before decoding
    frames = None
    if model == "stbn":
        frames = frame + 1
    arr = M.mask(model, size=size, seed=seed, frames=frames, max_pixels=max_pixels)
    kind = M.kind_of(arr, model == "stbn")
    if kind == "vector":
        if channel >= arr.shape[2]:
            raise click.UsageError(f"--channel {channel}: the mask has {arr.shape[2]} channels")
        mask = arr[:, :, channel]
    elif kind == "spatiotemporal":
        if frame >= arr.shape[0]:
            raise click.UsageError(f"--frame {frame}: the mask has {arr.shape[0]} frames")
        mask = arr[frame]
    else:
        mask = arr
    if white_noise:
        mask = D.rank_normalise(np.random.default_rng(seed).random(mask.shape))
    out = D.dither(img, mask)
    with _atomic.transaction():  # the image and the mask, or (on any failure) neither
        with _atomic.atomic_file(output, "wb") as fh:
            mpimg.imsave(fh, out.astype(np.uint8) * 255, cmap="gray", vmin=0, vmax=255, format="png")
        if mask_output is not None:
            with _atomic.atomic_file(mask_output, "wb") as fh:
                if mask_output.lower().endswith(".npy"):
                    np.save(fh, mask)
                else:
                    mpimg.imsave(fh, mask, cmap="gray", vmin=0.0, vmax=1.0, format="png")
    click.echo(
        f"wrote {output} ({out.shape[1]} x {out.shape[0]}, {out.mean():.3f} white) with a "
        f"{mask.shape[1]} x {mask.shape[0]} mask from "
        f"{'white noise' if white_noise else model}",
        err=True,
    )


# ---------------------------------------------------------------- entry point
def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def main(argv=None) -> int:
    """Console entry point: runs the CLI and turns every error into one line + exit code."""
    debug = os.environ.get("DPC_DEBUG", "") not in ("", "0")
    try:
        rv = cli.main(args=argv, prog_name="dpc", standalone_mode=False)
    except _NO_ARGS_HELP as e:  # bare 'dpc' (click >= 8.2): show the help
        click.echo(e.ctx.get_help())
        return 0
    except click.UsageError as e:
        hint = f" (see '{e.ctx.command_path} --help')" if e.ctx is not None else ""
        click.echo(f"dpc: error: {_one_line(e.format_message())}{hint}", err=True)
        return 2
    except click.ClickException as e:
        click.echo(f"dpc: error: {_one_line(e.format_message())}", err=True)
        return 1 if e.exit_code in (0, None) else e.exit_code
    except (click.exceptions.Abort, KeyboardInterrupt):
        click.echo("dpc: interrupted", err=True)
        return 130
    except (DpcError, OSError, ValueError, MemoryError) as e:
        if debug:
            raise
        msg = str(e)
        if isinstance(e, OSError) and not isinstance(e, DpcError) and e.strerror:
            msg = e.strerror + (f": {e.filename}" if e.filename else "")  # no "[Errno 28]"
        click.echo(f"dpc: error: {_one_line(msg) or type(e).__name__}", err=True)
        return 1
    except Exception as e:  # a bug, not bad input: still one line, and how to see more
        if debug:
            raise
        click.echo(
            f"dpc: error: internal error ({type(e).__name__}: {_one_line(e)}); rerun with DPC_DEBUG=1 "
            "for the traceback and please report it",
            err=True,
        )
        return 1
    return rv if isinstance(rv, int) else 0


if __name__ == "__main__":
    sys.exit(main())
