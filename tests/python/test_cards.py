"""A sample of docs/reports/models.md's numbers, recomputed the way lab/models/model_cards.py makes them
(100 sets: generate_batch(100, seed=0) on the CPU, whose ISA paths all give the same bits), so
a card that no longer follows its model or its stated definition fails here."""

from pathlib import Path

import dpc
from dpc import analysis

PAGE = (Path(__file__).resolve().parents[2] / "docs" / "reports" / "models.md").read_text()


def card_row(model: str, label: str) -> list[str]:
    """The cells of the row starting with label in model's card."""
    section = PAGE.split(f"\n## {model}\n", 1)[1].split("\n## ", 1)[0]
    row = next(line for line in section.splitlines() if line.startswith(f"| {label} "))
    return [c.strip() for c in row.strip().strip("|").split("|")]


def test_repulsion_2d_card():
    cells = card_row("repulsion-2d", "**repulsion-2d**")
    sets = dpc.load("repulsion-2d", backend="cpu").generate_batch(100, seed=0)
    r = analysis.radial_spectrum(sets, nu_max=4.0)
    md = analysis.min_distance(sets)
    peak, nu = r.peak()
    assert cells[1:5] == [
        "100",
        f"{r.low_frequency_energy(0.5):.4f}",
        f"{r.low_frequency_energy(0.75):.4f}",
        f"{peak:.2f} (ν = {nu:.2f})",
    ], cells
    assert cells[6] == f"{md.mean_ratio:.3f} / {md.min_ratio:.3f}", cells


def test_bnot_4d_card_elow_is_the_mean_over_the_integer_ball():
    """The n-D E_low is the stated definition (every integer frequency with 0 < nu < nu0), not a
    ring average (which counted the whole ring straddling nu0: 0.054 instead of 0.020 for the first
    file, now models/previous/bnot-4d.onnx)."""
    cells = card_row("bnot-4d", "**bnot-4d**")
    sets = dpc.load("bnot-4d", backend="cpu").generate_batch(100, seed=0)
    md = analysis.min_distance(sets)
    assert cells[1:4] == [
        "100",
        f"{analysis.low_frequency_energy(sets, 0.5):.4f}",
        f"{analysis.low_frequency_energy(sets, 0.75):.4f}",
    ], cells
    assert cells[5] == f"{md.mean_ratio:.3f} / {md.min_ratio:.3f}", cells
