"""The bundled model zoo: every model loads by name from the installed package, generates valid
points, has a card spec (models/model_cards.py), a card in docs/models.md and a row in
models/README.md; models derived from the authors' targets ship with their licence."""

import sys
from pathlib import Path

import numpy as np
import pytest

import dpc

REPO = Path(__file__).resolve().parents[2]
NAMES = sorted(p.stem for p in (REPO / "models").glob("*.onnx"))


def test_the_package_bundles_every_model_in_the_repo():
    assert NAMES and set(NAMES) <= set(dpc.available_models())
    pkg = Path(dpc.model_path(NAMES[0])).parent
    assert (pkg / "LICENSE-deepsampling").is_file()


@pytest.mark.parametrize("name", NAMES)
def test_model_loads_generates_and_is_documented(name):
    model = dpc.load(name)
    pts = model.generate(seed=7)
    assert pts.shape == (model.n_points, model.dims)
    assert np.all((pts >= 0) & (pts < 1))
    assert np.array_equal(pts, model.generate(seed=7))
    assert model.metadata.get("dpc.description")
    sys.path.insert(0, str(REPO / "models"))
    try:
        import model_cards
    finally:
        sys.path.pop(0)
    assert name in model_cards.CARDS, "add a card spec to models/model_cards.py"
    assert f"\n## {name}\n" in (REPO / "docs" / "models.md").read_text()
    assert f"`{name}.onnx`" in (REPO / "models" / "README.md").read_text()
