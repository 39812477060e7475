"""The options and option values the commands share: seeds, threads, model input kinds, output
and pixel limits, earlier option spellings, and the inputs of analyze and compare
(:func:`input_options`)."""

from __future__ import annotations

import dataclasses
import functools
import sys
from pathlib import Path

import click

from .. import _atomic, pointio
from .._model import DEFAULT_THREADS

MODEL_HELP = "a bundled model name (see 'dpc list'; the folders of $DPC_MODEL_PATH are searched first) or a .onnx file"
PLOT_FORMATS = ("png", "pdf", "svg")
# = dpc.analysis.DISCREPANCY_METHODS (not imported here: scipy makes start-up slow)
DISC_DEFAULT = "CD,WD,MD,L2-star,GL2,UL2"
FORMAT_CHOICE = click.Choice(list(pointio.FORMAT_NAMES), case_sensitive=False)
SEED = click.IntRange(min=0, max=(1 << 64) - 1)


def count_of(k: int, noun: str = "set") -> str:
    """'1 set', '16 sets' (dpc.analysis._common has the same; importing it here would pull in
    scipy at start-up)."""
    return f"{k} {noun}" if k == 1 else f"{k} {noun}s"


class OldNamesOption(click.Option):
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


def max_pixels_option(what: str):
    return click.option(
        "--max-pixels",
        type=click.IntRange(min=1),
        default=None,
        metavar="N",
        help=f"Largest {what} in pixels, checked before any work: default 67108864 (8192 x 8192; "
        "$DPC_MAX_PIXELS), and 65536 (256 x 256; $DPC_MAX_DESIGN_PIXELS) for masks designed on the "
        "spot (void-and-cluster, stbn, annealed), whose time grows with the square of the pixels.",
    )


def mask_options(dest: str, model_help: str, size_help: str):
    """-m/--model (the mask source; --mask still accepted) and -n/--size, as dpc mask and dpc
    dither name them."""

    def decorate(f):
        f = click.option("-n", "--size", type=click.IntRange(min=2), default=None, help=size_help)(f)
        return click.option(
            "-m",
            "--model",
            "--mask",
            dest,
            cls=OldNamesOption,
            old_names=("--mask",),
            default="annealed",
            show_default=True,
            help=model_help,
        )(f)

    return decorate


def check_output(path) -> None:
    """A missing or unwritable output folder, reported before the work (dpc._atomic)."""
    if path is not None:
        _atomic.check_output(path)


def progress_bar(iterable, desc: str, total: int | None = None):
    from tqdm import tqdm

    return tqdm(iterable, desc=desc, total=total, delay=1.0, leave=False, dynamic_ncols=True, file=sys.stderr)


def max_output_option(f):
    return click.option(
        "--max-output",
        "max_output",
        default=None,
        metavar="SIZE",
        help="Largest output one model call may allocate (sets x points x dims floats), e.g. "
        "16G; default 4G or $DPC_MAX_OUTPUT_BYTES. Bigger requests stop with an error "
        "before allocating.",
    )(f)


def max_bytes(text: str | None) -> float | None:
    if text is None:
        return None
    from .._model import parse_size

    return float(parse_size(text))


stratified_option = click.option(
    "--stratified/--uniform",
    default=None,
    help="Input points of models: stratified (one per grid cell, docs/model-format.md §5; "
    "blue-noise models stay blue at the largest scales for large -n) or uniform. Default: "
    "what each model was trained on (its metadata dpc.input, uniform without it; of the "
    "bundled models bnot-2d-stratified says stratified).",
)


def input_kind(stratified: bool | None) -> str:
    return "auto" if stratified is None else ("stratified" if stratified else "uniform")


def parse_list(text: str | None, what: str, cast=str) -> list | None:
    if text is None:
        return None
    if text.strip().lower() in ("", "none"):
        return []
    try:
        return [cast(t.strip()) for t in text.split(",") if t.strip()]
    except ValueError:
        raise click.BadParameter(f"expected a comma-separated list of {what}, got {text!r}") from None


threads_option = click.option(
    "-t",
    "--threads",
    type=click.IntRange(min=0),
    default=DEFAULT_THREADS,
    show_default=True,
    help="Worker threads for models: 1 runs on the calling thread (libdpc's default), 0 = one per "
    "CPU. The points do not depend on it.",
)


def output_dir(path: str) -> Path:
    """The output folder, created inside the command's transaction (removed again if the
    command fails)."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise click.BadParameter(f"{path} exists and is not a folder", param_hint="-o")
    return _atomic.make_dir(out)


def plot_formats(text: str) -> list[str]:
    fmts = parse_list(text, "plot formats") or []
    bad = [f for f in fmts if f.lower() not in PLOT_FORMATS]
    if bad or not fmts:
        raise click.BadParameter(f"{text!r}: choose from {', '.join(PLOT_FORMATS)}", param_hint="--plot-format")
    return list(dict.fromkeys(f.lower() for f in fmts))


def one_line(text: str) -> str:
    return " ".join(str(text).split())


@dataclasses.dataclass
class Inputs:
    """What analyze and compare share (:func:`input_options`): the inputs (point files, models or
    baselines), the output folder, how generated inputs are made and the analysis settings."""

    specs: list  # -i/--input, then the arguments
    output: str
    nu_max: float
    max_size: int
    subspace: str
    disc: str
    disc_budget: float
    n_points: int | None
    dims: int | None
    count: int
    seed: int
    bin_dtype: str | None
    plot_formats: str
    max_output: str | None
    threads: int
    stratified: bool | None


_ANALYSIS_OPTIONS = [
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
    click.option("--subspace", default="0,1", show_default=True, help="Two axes for the 2-D spectrum of n-D points."),
    click.option(
        "--discrepancy",
        "disc",
        default=DISC_DEFAULT,
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
        type=SEED,
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
    threads_option,
]


def input_options(input_help: str, output_help: str, *own):
    """The options of analyze and compare, in their help's order: -i/--input (``input_help``)
    with more inputs as arguments, -o/--output (a folder; ``output_help``), the command's ``own``
    options, the analysis settings, how generated inputs are made, --stratified/--uniform. The
    command gets the shared ones as one :class:`Inputs`, its first argument, and its own by name."""
    shared = [f.name for f in dataclasses.fields(Inputs) if f.name != "specs"]

    def decorate(f):
        @functools.wraps(f)
        def command(inputs, more, **kw):
            return f(Inputs(specs=[*inputs, *more], **{k: kw.pop(k) for k in shared}), **kw)

        opts = [
            click.option("-i", "--input", "inputs", multiple=True, help=input_help),
            click.argument("more", nargs=-1),
            click.option("-o", "--output", required=True, type=click.Path(file_okay=False), help=output_help),
            *own,
            *_ANALYSIS_OPTIONS,
            stratified_option,
        ]
        for o in reversed(opts):
            command = o(command)
        return command

    return decorate
