"""The bundled model zoo: every model loads by name from the installed package, generates valid
points, has a card spec (lab/models/model_cards.py), a card in docs/reports/models.md and a row in
models/README.md; models derived from the authors' targets ship with their licence."""

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
    from lab.models import model_cards

    assert name in model_cards.CARDS, "add a card spec to lab/models/model_cards.py"
    assert f"\n## {name}\n" in (REPO / "docs" / "reports" / "models.md").read_text()
    assert f"`{name}.onnx`" in (REPO / "models" / "README.md").read_text()


@pytest.mark.parametrize("name", NAMES)
def test_card_names_the_shipped_file(name):
    """The card's sha256 is the file's: a model retrained without redoing its card fails here."""
    import hashlib
    import re

    page = (REPO / "docs" / "reports" / "models.md").read_text()
    section = page.split(f"\n## {name}\n", 1)[1].split("\n## ", 1)[0]
    found = re.search(r"sha256 `([0-9a-f]{64})`", section)
    assert found, f"no sha256 in the card of {name}"
    assert found.group(1) == hashlib.sha256((REPO / "models" / f"{name}.onnx").read_bytes()).hexdigest(), (
        f"docs/reports/models.md describes another {name}.onnx: run python -m lab.models.model_cards {name}"
    )


def test_headline_quality_of_the_2d_blue_noise_models():
    """README's claims, on 16 sets (the cards use 100): bnot-2d within the BNOT bounds,
    bnot-2d-wide far below bnot-2d at the torus-scale frequencies."""
    from dpc import analysis

    narrow = dpc.load("bnot-2d").generate_batch(16, seed=0)
    wide = dpc.load("bnot-2d-wide").generate_batch(16, seed=0)
    for sets in (narrow, wide):
        r = analysis.radial_spectrum(sets, nu_max=4.0)
        assert r.low_frequency_energy(0.5) <= 0.005
        assert r.low_frequency_energy(0.75) <= 0.04
        assert 2.0 <= r.peak()[0] <= 3.5
    lowest = np.array([[1, 0], [0, 1], [1, 1], [1, -1]])  # the torus-scale frequencies
    p_narrow, p_wide = (float(np.mean(analysis.power_spectrum_direct(s, lowest))) for s in (narrow, wide))
    assert p_wide < 0.01 and p_wide < p_narrow / 10, (p_narrow, p_wide)


def test_blue_2d_is_below_bnot():
    """docs/reports/beyond-bnot.md on 16 sets (the page uses 100): blue-2d's low band a fraction of
    bnot-2d-stratified's (which matches the authors' BNOT sets), with BNOT's peak height and a
    larger minimum distance, also at 16 m; its tables end at 0 at the radius (continuous = true)."""
    from dpc import analysis
    from dpc.model_file import read_model

    blue = dpc.load("blue-2d").generate_batch(16, seed=0)
    bnot = dpc.load("bnot-2d-stratified").generate_batch(16, seed=0)
    r, rb = (analysis.radial_spectrum(s, nu_max=4.0) for s in (blue, bnot))
    assert r.low_frequency_energy(0.5) <= 0.0006 and r.low_frequency_energy(0.5) < rb.low_frequency_energy(0.5) / 3
    assert r.low_frequency_energy(0.75) <= 0.015 and r.low_frequency_energy(0.75) < rb.low_frequency_energy(0.75) / 2
    assert r.peak()[0] <= 3.2
    assert analysis.min_distance(blue).mean_ratio >= 0.79  # the hard-core term: 0.821 on the page
    big = dpc.load("blue-2d").generate_batch(2, seed=0, n_points=16384)
    assert analysis.min_distance(big).min_ratio >= 0.77  # 0.797 worst of 10 sets on the page
    assert all(np.all(L.kernels[:, -1] == 0) for L in read_model(dpc.model_path("blue-2d")).layers)


def test_bnot_10d_keeps_no_coincident_pair():
    """High-dimensional goals: the seeds whose sets kept a pair about 1e-5 spacings apart before
    max_attraction (docs/training.md §2; python -m lab.models.close_pairs bnot-10d counts 10,000
    seeds) keep every pair apart, and every table respects the cap of its config (0.4 d)."""
    from dpc.model_file import read_model
    from lab.models.close_pairs import closest_in_spacings

    model = dpc.load("bnot-10d")
    for seed in (1050, 3890, 9487):
        assert closest_in_spacings(model.generate(seed=seed)) > 0.5, seed
    for layer in read_model(dpc.model_path("bnot-10d")).layers:
        b = layer.kernels.shape[1]
        d = np.arange(b) * (layer.radius[0] / (b - 1))
        assert np.all(layer.kernels[0] <= 0.4 * d + 1e-6)


def test_projective_3d_is_blue_in_every_projection_and_in_3d():
    """Projective goals on 16 sets (docs/reports/high-dimensions.md uses 100): every 2-D projection's
    E_low nu<0.5 near 0.0094 (goal 0.01) and the 3-D set's near 0.018 (goal 0.02); the trained file
    it replaced had 0.060 and 0.028."""
    from dpc.analysis.spectrum import low_frequency_energy

    sets = dpc.load("projective-3d").generate_batch(16, seed=0)
    for d in ((0, 1), (0, 2), (1, 2)):
        assert low_frequency_energy(sets, 0.5, dims=d) <= 0.0115, d
    assert low_frequency_energy(sets, 0.5) <= 0.022


def test_projective_4d_is_blue_in_all_six_projections():
    """docs/reports/high-dimensions.md on 16 sets: each of the six projections near 0.035 (the trained file
    it replaced: 0.11; Owen-scrambled Sobol' 0.32)."""
    from dpc.analysis.spectrum import low_frequency_energy

    sets = dpc.load("projective-4d").generate_batch(16, seed=0)
    for d in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)):
        assert low_frequency_energy(sets, 0.5, dims=d) <= 0.045, d


@pytest.mark.parametrize("name, floor", [("bnot-4d", 0.74), ("bnot-5d", 0.70)])
def test_bnot_4d_and_5d_keep_points_further_apart_than_dart_throwing(name, floor):
    """High-dimensional goals on 16 sets: delta_min above relaxed dart throwing's (0.68 in 4-D, 0.69 in
    5-D at m = 1,024, docs/reports/high-dimensions.md); the files they replaced had 0.43 and 0.34."""
    from dpc import analysis

    assert analysis.min_distance(dpc.load(name).generate_batch(16, seed=0)).mean_ratio >= floor


def test_blue_10d_has_a_low_band_at_8192_points():
    """High-dimensional goals on 2 sets: at m = 8,192 blue-10d's E_low nu<0.75 near 0.04 (goal 0.1;
    bnot-10d there about 0.3) and delta_min near 0.85 (dart throwing: 0.71)."""
    from dpc import analysis
    from dpc.analysis.spectrum import low_frequency_energy

    sets = dpc.load("blue-10d").generate_batch(2, seed=0)
    assert sets.shape == (2, 8192, 10)
    assert low_frequency_energy(sets, 0.75) <= 0.06
    assert analysis.min_distance(sets).mean_ratio >= 0.8


@pytest.mark.parametrize("name", ["projective-3d", "projective-4d", "blue-10d"])
def test_hand_designed_models_only_repel_and_match_their_script(name):
    """models/make_highdim.py remakes each file's layers exactly, and every table is <= 0 and
    ends at 0 at the radius: no layer pulls two points together (the cause of bnot-10d's
    coincident pairs), and no layer jumps at the radius."""
    from dpc.model_file import read_model
    from models import make_highdim

    spec = make_highdim.MODELS[name]()
    layers = read_model(dpc.model_path(name)).layers
    assert len(layers) == len(spec.layers)
    for got, want in zip(layers, spec.layers):
        assert got.subspaces == want.subspaces and np.allclose(got.radius, want.radius)
        assert np.array_equal(got.kernels, want.kernels)
        assert np.all(got.kernels <= 0) and np.all(got.kernels[:, -1] == 0)


def test_dither_mask_beats_white_noise():
    from dpc.analysis import dither as D

    model = dpc.load("dither-32")
    levels = [D.mask_quality(D.model_mask(model, seed=s))["levels_elow_mean"] for s in range(8)]
    assert np.mean(levels) < 0.25, levels  # white-noise masks: 1.0 (docs/reports/models.md)


def _cpu_isas() -> list[str]:
    out = []
    for isa in ("scalar", "avx2", "avx512"):
        try:
            dpc.load("repulsion-2d", isa=isa, backend="cpu")
            out.append(isa)
        except dpc.UnsupportedError:
            pass  # this CPU lacks the instructions
    return out


@pytest.mark.parametrize("name", sorted(dpc.available_models()))
def test_every_cpu_path_gives_the_same_bits_on_every_bundled_model(name):
    """dpc.h: the CPU ISA paths evaluate one canonical order (docs/model-format.md §3), so every
    bundled model gives the same bits on each, at the trained count and others, for 1 or 3
    threads."""
    isas = _cpu_isas()
    if len(isas) < 2:
        pytest.skip("this CPU runs only the scalar path: nothing to compare")
    ref = dpc.load(name, isa="scalar", backend="cpu", threads=1)
    counts = [None] if ref.grid_axes else [None, 200, 3000]
    want = {n: ref.generate(seed=11, n_points=n) for n in counts}
    for isa in isas[1:]:
        for threads in (1, 3):
            model = dpc.load(name, isa=isa, backend="cpu", threads=threads)
            for n in counts:
                got = model.generate(seed=11, n_points=n)
                assert np.array_equal(got, want[n]), (name, isa, threads, n)


def test_vulkan_gives_the_same_quality_not_the_same_points():
    """The trained 40-layer cascade amplifies float32 rounding (docs/training.md, "Precision
    sensitivity"): the Vulkan backend rounds in the GPU's order, so it returns other points for
    one seed than the CPU, but point sets of the same quality. Prints the numbers with -s."""
    from dpc import analysis

    try:
        gpu = dpc.load("bnot-2d", backend="vulkan")
    except dpc.UnsupportedError as e:
        pytest.skip(f"no Vulkan device: {e}")
    rows = {}
    for label, model in [("cpu", dpc.load("bnot-2d", backend="cpu")), ("vulkan", gpu)]:
        sets = model.generate_batch(16, seed=0)
        elow = np.array([analysis.radial_spectrum(s[None], nu_max=4.0).low_frequency_energy(0.5) for s in sets])
        rows[label] = (sets, elow, analysis.min_distance(sets).ratios)
    ref_sets, ref_elow, ref_dmin = rows["cpu"]
    for label, (sets, elow, dmin) in rows.items():
        d = np.abs(sets.astype(np.float64) - ref_sets)
        d = np.minimum(d, 1.0 - d)
        print(
            f"[ info ] bnot-2d {label}: E_low(0.5) {elow.mean():.5f}, delta_min {dmin.mean():.4f}, "
            f"vs cpu max |diff| {d.max():.3g}, median {np.median(d):.3g}"
        )
        se = lambda a, b: 4.0 * np.hypot(a.std(ddof=1), b.std(ddof=1)) / np.sqrt(len(a))  # noqa: E731
        assert abs(elow.mean() - ref_elow.mean()) <= se(elow, ref_elow), (label, elow.mean(), ref_elow.mean())
        assert abs(dmin.mean() - ref_dmin.mean()) <= se(dmin, ref_dmin), (label, dmin.mean(), ref_dmin.mean())
        assert elow.mean() <= 0.005, label  # the BNOT bound, as in the headline test above


def test_stratified_input_keeps_large_sets_blue_at_the_largest_scales():
    """docs/model-format.md §5 and dpc.h: a local cascade cannot remove uniform input's
    large-scale density fluctuations, so at 16x the trained count bnot-2d's power at |q| = 1
    is near white noise's; from stratified input it is near 0, and the blue-noise band holds."""
    from dpc import analysis

    lowest = np.array([[1, 0], [0, 1], [1, 1], [1, -1]])
    m = 16384
    got = {}
    for kind in ("uniform", "stratified"):
        sets = dpc.load("bnot-2d", input=kind).generate_batch(4, seed=0, n_points=m)
        got[kind] = (
            float(np.mean(analysis.power_spectrum_direct(sets, lowest))),
            analysis.radial_spectrum(sets, nu_max=4.0).low_frequency_energy(0.5),
        )
    print(f"[ info ] bnot-2d at {m} points, (P(|q|=1), E_low(0.5)): {got}")
    assert got["uniform"][0] > 0.3
    assert got["stratified"][0] < 0.05
    assert got["stratified"][1] <= 0.005  # the BNOT bound


def test_bnot_2d_stratified_gets_its_input_by_default_and_stays_blue_at_every_scale():
    """The model records dpc.input = stratified, so the default input (auto) is stratified; at
    the trained count it is within the BNOT bounds, and at 16x it keeps E_low and has
    no torus-scale power (docs/reports/models.md card: ratio <= 1.03, power <= 0.0008)."""
    from dpc import analysis

    model = dpc.load("bnot-2d-stratified")
    assert model.input == "stratified" and model.metadata["dpc.input"] == "stratified"
    lowest = np.array([[1, 0], [0, 1], [1, 1], [1, -1]])
    for m, count in ((1024, 16), (16384, 4)):
        sets = model.generate_batch(count, seed=0, n_points=m)
        r = analysis.radial_spectrum(sets, nu_max=4.0)
        assert r.low_frequency_energy(0.5) <= 0.005, m
        assert float(np.mean(analysis.power_spectrum_direct(sets, lowest))) < 0.01, m
    assert analysis.min_distance(model.generate_batch(16, seed=0)).mean_ratio >= 0.65
    uniform = dpc.load("bnot-2d-stratified", input="uniform")
    assert uniform.input == "uniform"
    assert not np.array_equal(uniform.generate(0), model.generate(0))
