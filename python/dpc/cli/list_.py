"""dpc list: the models and baselines."""

from __future__ import annotations

import os
import textwrap

import click

from .. import baselines
from ..errors import DpcError
from .options import count_of, one_line


@click.command("list")
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
            click.echo(f"  {name:22s} (cannot load: {one_line(e)})")
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
