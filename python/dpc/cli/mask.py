"""dpc mask: a blue-noise threshold mask, written with its low-band energies."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from .options import mask_options, max_pixels_option


@click.command("mask")
@mask_options(
    "name",
    "annealed (dpc's designed masks, the best here), a gridded mask model (bundled name or "
    ".onnx) or a baseline: void-and-cluster, stbn, white, bayer (see 'dpc mask --list').",
    "Pixels per side (default: a model's trained grid; baselines need it).",
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
@max_pixels_option("mask (frames x size^2 x channels)")
@click.option("--list", "list_", is_flag=True, help="List the mask sources and exit.")
def mask_cmd(name, size, frames, channels, seed, output, bits, max_pixels, list_):
    """Write a blue-noise threshold mask (scalar, vector or spatiotemporal) and print its
    low-band energies (white noise = 1; docs/masks.md)."""
    from .. import masks as M
    from ..analysis import masks as AM

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
