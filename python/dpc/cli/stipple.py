"""dpc stipple: an image drawn as blue-noise dots whose local count follows its darkness
(Model.generate_density); also the image densities of ``dpc generate --density``."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np

from .. import _atomic, baselines, pointio
from .options import SEED, check_output, threads_option

DRAWINGS = (".png", ".svg")
DEFAULT_POINTS = 4096
DEFAULT_LONG_SIDE = 1024  # the drawing's longer side without --width
SUPERSAMPLE = 4  # PNG antialiasing: dots drawn on a 4x finer canvas, then box-averaged
_MAX_SUPERSAMPLED = 1 << 28  # bytes of the fine canvas (8-bit) before the factor is lowered


def image_density(path, *, ink: bool, gamma: float, max_pixels=None, empty_hint: str = "") -> tuple[np.ndarray, tuple]:
    """The density of an image file and its (width, height) in pixels. Tone t in [0, 1]
    (dpc.density.image_tone) gives (1 - t) ** gamma with ``ink`` (dark is dense) or t ** gamma
    (bright is dense); transparent pixels get none (times alpha). The file is read as
    ``dpc dither`` reads it (a regular file, its pixel count checked against ``max_pixels``
    before decoding); a grid beyond dpc.density.MAX_CELLS is box-averaged down to it."""
    from PIL import Image

    from ..analysis.dither import read_image
    from ..density import MAX_CELLS, image_tone

    arr = read_image(path, max_pixels)
    tone = image_tone(arr).astype(np.float64)
    dens = (1.0 - tone if ink else tone) ** gamma
    if arr.ndim == 3 and arr.shape[2] == 4:
        alpha = arr[..., 3].astype(np.float64)
        dens *= alpha / float(np.iinfo(arr.dtype).max) if arr.dtype.kind in "ui" else np.clip(alpha, 0.0, 1.0)
    height, width = dens.shape
    if dens.size > MAX_CELLS:
        k = math.sqrt(dens.size / MAX_CELLS)
        size = (max(1, int(width / k)), max(1, int(height / k)))
        dens = np.asarray(Image.fromarray(dens.astype(np.float32)).resize(size, Image.Resampling.BOX))
    if not dens.max() > 0:
        raise click.ClickException(f"{path}: the density is zero everywhere{empty_hint}")
    return np.ascontiguousarray(dens, dtype=np.float32), (width, height)


def density_model(spec: str, threads: int, isa: str = "auto", input: str = "auto"):  # noqa: A002
    """A model for Model.generate_density (it runs on the CPU whatever the backend); a baseline
    is a usage error."""
    from .sources import is_model, load_model

    if spec in baselines.BASELINES:
        raise click.UsageError(
            f"{spec} is a baseline; only a 2-D model can follow a density (e.g. bnot-2d-stratified, bnot-2d, blue-2d)"
        )
    if not is_model(spec):
        raise click.ClickException(f"{spec!r} is neither a baseline nor a model (see 'dpc list')")
    return load_model(spec, threads, isa, "cpu", input)


def drawing_size(image_size: tuple, width: int | None) -> tuple[int, int]:
    """(width, height) of the drawing: the image's aspect ratio, ``width`` wide, else the longer
    side DEFAULT_LONG_SIDE."""
    w, h = image_size
    if width is None:
        scale = DEFAULT_LONG_SIDE / max(w, h)
        return max(1, round(w * scale)), max(1, round(h * scale))
    return width, max(1, round(width * h / w))


def dot_diameter(density: np.ndarray, n: int, size: tuple, dot_size: float) -> float:
    """``dot_size`` times the mean spacing of the densest area in drawing units: there the dots
    have n / (mean(density) / max(density)) per drawing area, spacing sqrt(area / that)."""
    w, h = size
    fill = float(np.mean(density, dtype=np.float64) / np.max(density))
    return dot_size * math.sqrt(fill * w * h / n)


def write_png(fh, xy: np.ndarray, size: tuple, diameter: float, invert: bool) -> None:
    """Antialiased dots: drawn on a canvas SUPERSAMPLE times finer, then box-averaged."""
    from PIL import Image, ImageDraw

    w, h = size
    s = SUPERSAMPLE
    while s > 1 and w * h * s * s > _MAX_SUPERSAMPLED:
        s //= 2
    ink, paper = (255, 0) if invert else (0, 255)
    canvas = Image.new("L", (w * s, h * s), paper)
    draw = ImageDraw.Draw(canvas)
    r = diameter * s / 2
    # a drawing coordinate u lies in pixel floor(u); Pillow puts pixel i's centre at i
    for x, y in (xy * s - 0.5).tolist():
        draw.ellipse((x - r, y - r, x + r, y + r), fill=ink)
    if s > 1:
        canvas = canvas.reduce(s)
    canvas.save(fh, format="PNG")


def svg_text(xy: np.ndarray, size: tuple, diameter: float, invert: bool) -> str:
    w, h = size
    ink, paper = ("white", "black") if invert else ("black", "white")
    r = f"{diameter / 2:.4g}"
    circles = "".join(f'<circle cx="{x:.3f}" cy="{y:.3f}" r="{r}"/>\n' for x, y in xy.tolist())
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}">\n'
        f'<rect width="{w}" height="{h}" fill="{paper}"/>\n'
        f'<g fill="{ink}">\n{circles}</g>\n</svg>\n'
    )


@click.command("stipple")
@click.argument("image", type=click.Path(exists=True, dir_okay=False))
@click.option(
    "-n",
    "--points",
    "n_points",
    type=click.IntRange(min=1),
    default=DEFAULT_POINTS,
    show_default=True,
    help="Dots in all.",
)
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, writable=True),
    help="A drawing, .png (antialiased) or .svg (one <circle> per dot), or the points: "
    + pointio.describe_extensions()
    + ", in [0,1)^2 with x to the right and y down the image (not stretched). Written atomically.",
)
@click.option(
    "-m",
    "--model",
    default="bnot-2d-stratified",
    show_default=True,
    help="A 2-D blue-noise model whose layers filter the plane as a whole (bnot-2d-stratified, bnot-2d, "
    "blue-2d, ...): a bundled name or a .onnx file.",
)
@click.option("-s", "--seed", type=SEED, default=0, show_default=True, help="Seed, 0 .. 2^64-1.")
@click.option(
    "--invert",
    is_flag=True,
    help="Bright areas get the dots: density tone^gamma, drawn as white dots on black. Default: "
    "density (1 - tone)^gamma, black dots on white, as ink.",
)
@click.option(
    "--gamma",
    type=click.FloatRange(min=0, min_open=True),
    default=1.0,
    show_default=True,
    help="Exponent of the density: above 1 thins the dots where it is low (the light greys).",
)
@click.option(
    "--dot-size",
    type=click.FloatRange(min=0, min_open=True),
    default=0.7,
    show_default=True,
    help="Dot diameter in units of the mean dot spacing in the densest area of the drawing, "
    "sqrt(drawing area x mean(density) / max(density) / N); at 0.7 the dots cover at most "
    "38% of the darkest area (pi x 0.7^2 / 4). Every dot has the same size; drawings only.",
)
@click.option(
    "--width",
    type=click.IntRange(min=1),
    default=None,
    help=f"Width of the drawing: PNG pixels, SVG user units (CSS px, 1/96 in). Default: the "
    f"image's longer side scaled to {DEFAULT_LONG_SIDE}. The height keeps the image's aspect "
    "ratio: the points, in [0,1)^2, are stretched to it.",
)
@threads_option
@click.option(
    "--max-pixels",
    type=click.IntRange(min=1),
    default=None,
    metavar="N",
    help="Largest input image and PNG drawing in pixels, checked before any work: default "
    "67108864 (8192 x 8192; $DPC_MAX_PIXELS).",
)
def stipple_cmd(image, n_points, output, model, seed, invert, gamma, dot_size, width, threads, max_pixels):
    """Stipple IMAGE (any format Pillow reads): N blue-noise dots whose local count follows the
    image's darkness (dpc's Model.generate_density), drawn as a PNG or SVG or written as points.
    Tone t in [0, 1] is Rec. 709 luminance; transparent pixels get no dots."""
    from ..masks.baselines import check_pixels

    ext = Path(output).suffix.lower()
    if ext not in DRAWINGS:
        try:
            pointio.resolve_format(output)
        except pointio.PointFileError:
            raise click.UsageError(
                f"{output}: the output must end in .png or .svg (a drawing) or "
                f"{', '.join(pointio.EXTENSIONS)} (the points)"
            ) from None
    check_output(output)
    hint = " (the image is white: --invert puts dots on the bright areas)" if not invert else " (the image is black)"
    density, image_size = image_density(image, ink=not invert, gamma=gamma, max_pixels=max_pixels, empty_hint=hint)
    size = drawing_size(image_size, width)
    if ext == ".png":
        check_pixels(size[0] * size[1], f"the drawing ({size[0]} x {size[1]})", max_pixels)
    loaded = density_model(model, threads)
    points = loaded.generate_density(density, n_points, seed)
    diameter = dot_diameter(density, points.shape[0], size, dot_size)
    xy = points.astype(np.float64) * np.array(size, dtype=np.float64)
    if ext not in DRAWINGS:
        pointio.write_points(output, points)
        click.echo(f"wrote {points.shape[0]} points from {loaded.name} following {image} to {output}", err=True)
        return
    with _atomic.atomic_file(output, "wb") as fh:
        if ext == ".png":
            write_png(fh, xy, size, diameter, invert)
        else:
            fh.write(svg_text(xy, size, diameter, invert).encode("ascii"))
    unit = "px" if ext == ".png" else "units"
    click.echo(
        f"wrote {output} ({size[0]} x {size[1]}): {points.shape[0]} dots of diameter {diameter:.3g} {unit} "
        f"from {loaded.name} following {image}",
        err=True,
    )
