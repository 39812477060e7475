"""dpc analyze: measure a batch of point sets (spectra, anisotropy, PCF, minimum distance,
discrepancy); with what compare shares: running the analysis, the models' design targets and the
JSON files."""

from __future__ import annotations

import json
import re
from pathlib import Path

import click
import numpy as np

from .. import _atomic, pointio
from .options import MODEL_HELP, Inputs, count_of, input_options, output_dir, parse_list, plot_formats
from .sources import read_inputs


@click.command("analyze")
@input_options(
    "Point file(s) ("
    + pointio.describe_extensions()
    + "), or a model ("
    + MODEL_HELP
    + ") or baseline to generate from; more may follow as arguments. All inputs "
    "form one batch of sets.",
    "Folder for metrics.json and the plots (PNG and PDF by default, see "
    "--plot-format); a model's design target is drawn dashed where its metadata "
    "has one.",
    click.option("--label", default=None, help="Name used in titles (default: first input)."),
    click.option("--no-plots", is_flag=True, help="Only write metrics.json."),
)
def analyze_cmd(inp: Inputs, label, no_plots):
    """Measure point sets: spectra, anisotropy, PCF, minimum distance, discrepancy."""
    if not inp.specs:
        raise click.UsageError("give at least one input with -i")
    formats = plot_formats(inp.plot_formats)
    with _atomic.transaction():  # all outputs, or (on any failure) none and no new folder
        out = output_dir(inp.output)
        loaded = read_inputs(inp)
        shapes = {a.shape[1:] for _, a, _ in loaded}
        if len(shapes) > 1:
            raise click.ClickException(
                "inputs differ in points or dimension: "
                + ", ".join(f"{n}: {a.shape[1]}x{a.shape[2]}" for n, a, _ in loaded)
                + " (use 'dpc compare' for different inputs)"
            )
        sets = np.concatenate([a for _, a, _ in loaded])
        name = label or loaded[0][0]
        res = run_analysis(inp, sets, name)
        doc = res.to_json()
        doc["input"]["sources"] = inp.specs
        models = list(dict.fromkeys(m for _, _, m in loaded if m is not None))
        targets = targets_of(models)
        if targets:
            doc["targets"] = [{"label": t.label, "dims": t.dims} for t in targets]
        dump_json(doc, out / "metrics.json")
        written = ["metrics.json"]
        if not no_plots:
            written += analysis_plots(res, sets, out, inp.nu_max, formats, targets)
    s = res.summary()
    click.echo(f"{name}: {count_of(res.n_sets)} of {res.n_points} {res.dims}-D points")
    for key in ("E_low<0.5", "E_low<0.75", "peak", "peak_nu", "delta_min", *res.discrepancy.keys()):
        if key in s and s[key] is not None:
            click.echo(f"  {key:12s} {fmt_value(s[key])}")
    for note in res.notes:
        click.echo(f"  note: {note}")
    click.echo(f"wrote {', '.join(written)} to {out}")


def run_analysis(inp: Inputs, points, label):
    """dpc.analysis.analyze of ``points`` with the command's analysis settings."""
    from ..analysis import analyze

    sub = parse_list(inp.subspace, "axes", int)
    methods = parse_list(inp.disc, "discrepancy names")
    return analyze(
        points,
        label=label,
        nu_max=inp.nu_max,
        max_size=inp.max_size,
        dims=tuple(sub) if sub else (0, 1),
        discrepancies=methods,
        discrepancy_budget=inp.disc_budget,
        seed=inp.seed,
        progress_bar=True,
    )


def dump_json(doc, path: Path) -> None:
    text = json.dumps(doc, indent=2, allow_nan=False)
    # Keep arrays of numbers on one line: readable metrics, small files.
    text = re.sub(r"\[\s+([-+0-9.eE,\s]|null)+?\s*\]", lambda mt: "[" + " ".join(mt.group(0)[1:-1].split()) + "]", text)
    _atomic.write_text(path, text + "\n")


def fmt_value(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def targets_of(models) -> list:
    """The design targets of the models (metadata; dpc.analysis.targets), one per distinct one."""
    from ..analysis.targets import model_target

    out, seen = [], set()
    for m in models:
        t = model_target(m)
        if t is not None and t.label not in seen:
            seen.add(t.label)
            out.append(t)
    return out


def references(targets, dims: int, sub: tuple) -> list:
    """References for a radial plot of a ``dims``-D spectrum: 2-D targets belong to the
    subspace (0, 1) the models were trained on; n-D ones to the n-D radial spectrum."""
    return [t.as_reference() for t in targets if t.dims == dims and (dims != 2 or tuple(sub) in ((0, 1), (1, 0)))]


def analysis_plots(res, sets, out: Path, nu_max: float, formats=("png",), targets=()) -> list[str]:
    from ..analysis import plots

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
        reference=references(targets, len(sub) if res.spectrum is not None else 1, sub) or None,
    )
    if res.radial_nd is not None:
        save(
            plots.save_radial,
            "radial_nd.png",
            [(f"{res.label} ({res.dims}-D, MC)", res.radial_nd)],
            title=f"{res.dims}-D radial mean (Monte Carlo), {title}",
            nu_max=nu_max,
            reference=references(targets, res.dims, sub) or None,
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
