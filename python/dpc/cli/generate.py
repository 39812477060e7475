"""dpc generate: point sets from a model or a baseline."""

from __future__ import annotations

import click
import numpy as np

from .. import baselines, pointio
from .._model import _BACKEND, _ISA
from .._model import balance as balance_set
from .options import (
    FORMAT_CHOICE,
    MODEL_HELP,
    SEED,
    check_output,
    count_of,
    input_kind,
    max_bytes,
    max_output_option,
    progress_bar,
    stratified_option,
    threads_option,
)
from .sources import generate_sets, ran_on
from .stipple import density_model, image_density


@click.command("generate")
@click.option("-m", "--model", required=True, help="Model: " + MODEL_HELP + "; or a baseline name (see 'dpc list').")
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
    type=SEED,
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
    type=FORMAT_CHOICE,
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
@threads_option
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
@stratified_option
@click.option(
    "--balance",
    type=click.IntRange(0, 32),
    default=None,
    help="Balance every set at the integer frequencies 0 < |q| <= K afterwards (dpc.balance, "
    "docs/model-format.md §5.1: no power left at the torus scale; float32 output). Models "
    "with metadata dpc.balance (blue-2d) are balanced already; not for progressive models.",
)
@max_output_option
@click.option(
    "--density",
    type=click.Path(exists=True, dir_okay=False),
    default=None,
    metavar="IMAGE",
    help="Blue noise that follows an image (any format Pillow reads; Model.generate_density): "
    "bright is dense, density tone^gamma; transparent pixels get no points. Image rows run "
    "down the second coordinate. 2-D models whose layers filter the plane as a whole only "
    "(bnot-2d-stratified, bnot-2d, blue-2d, ...); it runs on the CPU. See also 'dpc stipple'.",
)
@click.option("--invert", is_flag=True, help="With --density: dark is dense, density (1 - tone)^gamma.")
@click.option(
    "--gamma",
    type=click.FloatRange(min=0, min_open=True),
    default=None,
    help="With --density: the exponent of the density (default 1).",
)
def generate_cmd(
    model,
    n_points,
    dims,
    seed,
    count,
    output,
    fmt,
    bin_dtype,
    threads,
    isa,
    backend,
    stratified,
    balance,
    max_output,
    density,
    invert,
    gamma,
):
    """Generate point sets from a model or a baseline. A model's sets are float32 (kept so in
    .npy and float32 .bin files; text has 17 significant digits). With --density IMAGE a 2-D
    model's points follow the image (bright is dense)."""
    if density is None and (invert or gamma is not None):
        raise click.UsageError("--invert and --gamma apply with --density only")
    if density is not None and balance:
        raise click.UsageError("--balance would undo --density (it evens out the low frequencies a density has)")
    if output is not None:
        pointio.resolve_format(output, fmt)  # fail on a bad name or folder before the work
        check_output(output)
    if stratified is not None and model in baselines.BASELINES:
        raise click.UsageError("--stratified/--uniform apply to models, not to baselines")
    if density is not None:
        sets, name, loaded = density_sets(
            model, density, invert, gamma, n_points, dims, count, seed, threads, isa, backend, stratified, max_output
        )
    else:
        sets, name, loaded = generate_sets(
            model, n_points, dims, count, seed, threads, isa, backend, input_kind(stratified), max_bytes(max_output)
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
        f"from {name}{f' ({ran_on(loaded)})' if loaded else ''}{f' following {density}' if density else ''} "
        f"to {output}",
        err=True,
    )


def density_sets(
    spec, image, invert, gamma, n_points, dims, count, seed, threads, isa, backend, stratified, max_output
) -> tuple[np.ndarray, str, object]:
    """``count`` sets that follow the density of ``image`` (bright is dense; dark with
    ``invert``), set c from seed + c (mod 2^64), as generate_sets makes them without a density."""
    from .._model import _max_bytes
    from ..errors import InvalidArgumentError, LimitError

    if backend == "vulkan":
        raise click.UsageError("--density runs on the CPU (dpc_generate_density); leave out --backend vulkan")
    loaded = density_model(spec, threads, isa, input_kind(stratified))
    if dims is not None and dims != loaded.dims:
        raise InvalidArgumentError(f"model {loaded.name} makes {loaded.dims}-D points, not {dims}-D")
    n = loaded.n_points if n_points is None else n_points
    size, limit = count * n * 2 * 4, _max_bytes(max_bytes(max_output))
    if size > limit:
        raise LimitError(
            f"the output would take {size / 2**30:.3g} GiB, more than the limit of {limit / 2**30:.3g} GiB: "
            "raise it with --max-output or DPC_MAX_OUTPUT_BYTES"
        )
    grid, _ = image_density(
        image,
        ink=invert,
        gamma=1.0 if gamma is None else gamma,
        empty_hint=" (the image is white: leave out --invert)" if invert else " (the image is black: try --invert)",
    )
    sets = [
        loaded.generate_density(grid, n, (seed + c) % (1 << 64))
        for c in progress_bar(range(count), f"{loaded.name} (density)")
    ]
    return np.stack(sets), loaded.name, loaded
