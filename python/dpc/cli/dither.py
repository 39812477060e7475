"""dpc dither: ordered dithering of an image with a blue-noise mask."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from .. import _atomic
from .options import check_output, mask_options, max_pixels_option


@click.command("dither")
@click.argument("image", type=click.Path(exists=True, dir_okay=False))
@mask_options(
    "model",
    "Mask: annealed (dpc's designed masks), a gridded mask model (bundled name or .onnx) or "
    "a baseline (void-and-cluster, stbn, white, bayer; see 'dpc mask --list').",
    "Mask pixels per side (default: the model's grid; baselines need it).",
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
@max_pixels_option("image or mask")
def dither_cmd(image, model, size, channel, frame, seed, output, mask_output, white_noise, max_pixels):
    """Ordered dithering of IMAGE with a blue-noise mask (tiled): a gridded mask model or a
    baseline mask."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image as mpimg

    from .. import masks as M
    from ..analysis import dither as D

    if Path(output).suffix.lower() != ".png":
        raise click.UsageError("the output image must be a .png file")
    if mask_output is not None and Path(mask_output).suffix.lower() not in (".npy", ".png"):
        raise click.UsageError("--mask-output must end in .npy or .png")
    check_output(output)
    check_output(mask_output)
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
