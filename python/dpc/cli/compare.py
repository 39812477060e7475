"""dpc compare: several inputs (files, models, baselines) in one table and plots."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from .. import _atomic, pointio
from .analyze import dump_json, fmt_value, references, run_analysis, targets_of
from .options import MODEL_HELP, Inputs, input_options, output_dir, plot_formats
from .sources import read_inputs


@click.command("compare")
@input_options(
    "A point file ("
    + pointio.describe_extensions()
    + "), or a model ("
    + MODEL_HELP
    + ") or baseline generated with -n/-c/-s; repeat, or list more as arguments.",
    "Folder for compare.json, compare.md and the plots (PNG and PDF by default); "
    "the models' design targets are drawn dashed where their metadata has them.",
    click.option(
        "--integration/--no-integration",
        default=True,
        show_default=True,
        help="Relative variance of MC integration over each input's sets.",
    ),
)
def compare_cmd(inp: Inputs, integration):
    """Compare several inputs (files, models, baselines) in one table and plots."""
    if len(inp.specs) < 1:
        raise click.UsageError("give inputs with -i")
    formats = plot_formats(inp.plot_formats)
    with _atomic.transaction():  # all outputs, or (on any failure) none and no new folder
        out = output_dir(inp.output)
        loaded = read_inputs(inp)
        labels, seen = [], {}
        for name, _, _ in loaded:  # unique labels
            seen[name] = seen.get(name, 0) + 1
            labels.append(name if seen[name] == 1 else f"{name}#{seen[name]}")
        results, rows = [], []
        for (_, sets, _), label in zip(loaded, labels):
            res = run_analysis(inp, sets, label)
            row = res.summary()
            if integration:
                row.update(integration_row(sets, res, inp.seed))
            results.append((res, sets))
            rows.append(row)
        cols = list(dict.fromkeys(k for r in rows for k in r))
        table = markdown_table(rows, cols)
        click.echo(table)
        _atomic.write_text(out / "compare.md", table + "\n")
        targets = targets_of(list(dict.fromkeys(m for _, _, m in loaded if m is not None)))
        doc = {
            "dpc_compare": 1,
            "inputs": inp.specs,
            "rows": rows,
            "analyses": [r.to_json() for r, _ in results],
            "targets": [{"label": t.label, "dims": t.dims} for t in targets],
        }
        dump_json(doc, out / "compare.json")
        names = compare_plots(results, out, inp.nu_max, formats, targets)
    click.echo(f"wrote compare.md, compare.json, {', '.join(names)} to {out}")


def markdown_table(rows: list[dict], cols: list[str]) -> str:
    cells = [[fmt_value(r.get(c)) for c in cols] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(cols)]

    def line(vals):
        return "| " + " | ".join(v.rjust(w) for v, w in zip(vals, widths)) + " |"

    out = [line(cols), "|" + "|".join("-" * (w + 2) for w in widths) + "|"]
    out += [line(row) for row in cells]
    return "\n".join(out)


def integration_row(sets: np.ndarray, res, seed: int) -> dict:
    from ..analysis.integration import FAMILIES, integrands, relative_variance

    if sets.shape[0] < 2 or sets.shape[2] < 2:
        return {}
    d = tuple(res.spectrum.dims) if res.spectrum is not None else (0, 1)
    row = {}
    for i, fam in enumerate(FAMILIES):
        f = integrands(fam, 10, dims=2, seed=seed + i)
        row[f"relvar_{fam}"] = float(relative_variance(sets[:, :, d], f).mean())
    return row


def compare_plots(results, out: Path, nu_max: float, formats=("png",), targets=()) -> list[str]:
    from matplotlib.figure import Figure

    from ..analysis import plots

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
        reference=references(targets, len(sub) if r0.spectrum is not None else 1, sub) or None,
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
