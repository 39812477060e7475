"""libdpc's float32 cascade against the independent float64 reference (reference_cascade.py).

For every test model of tests/data, several seeds, the trained point count and another count
(not for the gridded model, which has exactly its grid's count): the points of
``dpc.load(path).generate(seed, n)`` and the reference cascade applied to the reference's own
input points agree to 1e-5 per coordinate on the torus, for every ISA path the CPU has. The
reference's generator is checked to be bit-exact with ``dpc.uniform`` first, and hand-placed
points on the torus seam check the wrap-around.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dpc
import reference_cascade as rc
from cpu_isa import HAVE_AVX2, HAVE_AVX512, VECTOR_ISAS  # noqa: E402,F401

DATA = Path(__file__).resolve().parents[1] / "data"
MODELS = ["model_2d", "model_3d_proj", "model_3d_mixed", "model_grid_3to1", "model_10d"]
OTHER_COUNT = {"model_2d": 777, "model_3d_proj": 1500, "model_3d_mixed": 600, "model_10d": 600}
SEEDS = [0, 1, 2**64 - 1]
TOL = 1e-5


ISAS = ["scalar"] + VECTOR_ISAS

_ref_cache: dict[str, rc.RefModel] = {}
_max_diff: dict[str, float] = {}


def ref_model(name: str) -> rc.RefModel:
    if name not in _ref_cache:
        _ref_cache[name] = rc.load_reference(DATA / f"{name}.onnx")
    return _ref_cache[name]


def torus_max(a, b) -> float:
    return float(rc.torus_diff(a, b).max())


def note(key: str, value: float) -> None:
    _max_diff[key] = max(_max_diff.get(key, 0.0), value)


@pytest.fixture(scope="module", autouse=True)
def report_max_diffs():
    yield
    if _max_diff:
        print("\nmax |libdpc - float64 reference| per model / ISA:")
        for key in sorted(_max_diff):
            print(f"  {key}: {_max_diff[key]:.3g}")


# ---- the generator ----------------------------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 7, 0xDEADBEEF, 2**63, 2**64 - 1])
@pytest.mark.parametrize("shape", [(1, 1), (5, 3), (1000, 2), (64, 10)])
def test_reference_rng_is_bit_exact_with_dpc_uniform(seed, shape):
    ours = rc.uniform(seed, *shape)
    theirs = dpc.uniform(seed, *shape)
    assert theirs.dtype == np.float32 and theirs.shape == shape
    assert np.array_equal(ours.view(np.uint32), theirs.view(np.uint32))


def test_reference_rng_known_splitmix64_values():
    # Seed 0 gives the classic SplitMix64 stream from state 0 (mix(0) = 0).
    assert [int(v) for v in rc.splitmix_values(0, 3)] == [0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4, 0x06C45D188009454F]


def test_reference_grid_fill_is_first_axis_fastest():
    x = rc.grid_fill(np.zeros((1024, 3), np.float32), [0, 1], [32, 32])
    assert x[1, 0] == np.float32(1.5 / 32) and x[1, 1] == np.float32(0.5 / 32)
    assert x[32, 0] == np.float32(0.5 / 32) and x[32, 1] == np.float32(1.5 / 32)
    assert np.all(x[:, 2] == 0)


# ---- the cascade -------------------------------------------------------------------------------


def _cases():
    for name in MODELS:
        counts = [None] + ([OTHER_COUNT[name]] if name in OTHER_COUNT else [])
        for n in counts:
            yield pytest.param(name, n, id=f"{name}-{'trained' if n is None else n}")


@pytest.mark.parametrize("name,n", list(_cases()))
def test_generate_matches_float64_reference(name, n):
    ref = ref_model(name)
    m_pts = ref.n_points if n is None else n
    handles = {isa: dpc.load(DATA / f"{name}.onnx", isa=isa, threads=2) for isa in ISAS}
    for seed in SEEDS:
        x0 = rc.initial_points(ref, seed, m_pts)
        expect = rc.run_cascade(ref, x0)
        moved = rc.torus_diff(x0, expect).mean()
        assert moved > 1e-3, "the reference cascade barely moves the points: a vacuous comparison"
        golden = DATA / "golden" / f"{name}__seed{seed}__n{m_pts}.f32"
        if golden.exists():  # the C tests' copy of this reference output (make_golden.py)
            stored = np.fromfile(golden, dtype="<f4").reshape(m_pts, ref.dims)
            assert torus_max(stored, expect) <= 1e-7, f"{golden.name} is stale"
        for isa, model in handles.items():
            got = model.generate(seed, n)
            assert got.shape == (m_pts, ref.dims) and got.dtype == np.float32
            d = torus_max(got, expect)
            note(f"{name} {isa}", d)
            assert d <= TOL, f"{isa}, seed {seed}, {m_pts} points: max |diff| {d:.3g}"
            if seed == SEEDS[0]:  # the same input through Model.filter: the same bits
                assert np.array_equal(model.filter(x0), got)


def _seam_points(ref: rc.RefModel, seed: int) -> np.ndarray:
    """Uniform points plus a cluster straddling the torus seam in every free dimension."""
    m = ref.n_points
    x = rc.initial_points(ref, seed, m)
    free = [k for k in range(ref.dims) if k not in ref.grid_axes]
    rng = np.random.default_rng(seed)
    h = m ** (-1.0 / ref.dims)
    edge = np.array([1e-7, 1 - 1e-7, 0.0, np.nextafter(np.float32(1), np.float32(0)), 2e-7, 1 - 3e-7], dtype=np.float32)
    rows = np.arange(0, 48)
    for r in rows:
        for k in free:
            if (r + k) % 2 == 0:
                x[r, k] = edge[(r + 3 * k) % len(edge)]
            else:  # near the seam on either side, within a spacing
                off = np.float32(rng.uniform(0, 0.5 * h))
                x[r, k] = off if rng.random() < 0.5 else np.float32(1) - off
    x[x >= 1] = np.nextafter(np.float32(1), np.float32(0))
    return x


@pytest.mark.parametrize("name", MODELS)
def test_points_on_the_torus_seam(name):
    ref = ref_model(name)
    x = _seam_points(ref, seed=3)
    assert np.all((x >= 0) & (x < 1))
    expect = rc.run_cascade(ref, x)
    # the seam points interact across the seam in the reference: they do move
    assert rc.torus_diff(x[:48], expect[:48]).max() > 1e-4
    for isa in ISAS:
        model = dpc.load(DATA / f"{name}.onnx", isa=isa)
        got = model.filter(x)
        assert np.all((got >= 0) & (got < 1)), "filter output must be wrapped into [0, 1)"
        d = torus_max(got, expect)
        note(f"{name} {isa} (seam)", d)
        assert d <= TOL, f"{isa}: max |diff| {d:.3g} with points on the seam"
        if ref.grid_axes:
            assert np.array_equal(got[:, ref.grid_axes], x[:, ref.grid_axes])


def test_eps_cut_off_on_a_two_point_model(tmp_path):
    """eps: a pair closer than eps * h is ignored, a pair farther apart interacts (hand-checked
    on two points, where h = 2^(-1/2) and the only pair is the pair itself)."""
    from dpc.model_file import Layer, ModelSpec, write_model

    kern = np.full((1, 8), -0.2, np.float32)
    kern[0, -1] = 0.0
    spec = ModelSpec(dims=2, n_points=2, layers=[Layer([0b11], [0.7], kern, eps=0.3)])
    path = tmp_path / "two_points.onnx"
    write_model(spec, path)
    ref = rc.load_reference(path)
    h = 2**-0.5
    for isa in ISAS:
        model = dpc.load(path, isa=isa)
        near = np.array([[0.5, 0.5], [0.5 + 0.2 * h, 0.5]], np.float32)  # 0.2 h < eps h
        assert np.array_equal(model.filter(near), near)
        far = np.array([[0.5, 0.5], [0.5 + 0.4 * h, 0.5]], np.float32)  # 0.4 h > eps h
        got = model.filter(far)
        expect = rc.run_cascade(ref, far)
        # hand value: d = 0.4 h, u = d (b-1) / r with r = 0.7 h, q = 4, g = -0.2; each point moves
        # h * g = -0.2 h along the pair direction, i.e. away from the other
        g = float(np.float32(-0.2))
        hand = far.astype(np.float64)
        hand[0, 0] += h * g
        hand[1, 0] -= h * g
        assert torus_max(expect, hand) < 1e-12
        assert torus_max(got, expect) <= TOL


# ---- the committed test files are what their scripts make ---------------------------------------


def _same_model(a: rc.RefModel, b: rc.RefModel) -> bool:
    if (a.dims, a.n_points, a.grid_axes, a.grid_shape, a.metadata) != (
        b.dims,
        b.n_points,
        b.grid_axes,
        b.grid_shape,
        b.metadata,
    ):
        return False
    if len(a.layers) != len(b.layers):
        return False
    for x, y in zip(a.layers, b.layers):
        if (x.subspaces, x.radius, x.eps, x.fixed) != (y.subspaces, y.radius, y.eps, y.fixed):
            return False
        # kernels come from numpy exp/sin: allow an ulp of platform difference
        if x.kernels.shape != y.kernels.shape or not np.allclose(x.kernels, y.kernels, rtol=1e-6, atol=1e-9):
            return False
    return True


def test_committed_files_are_what_the_scripts_make(tmp_path):
    import subprocess
    import sys

    env_root = Path(__file__).resolve().parents[2]
    subprocess.run(
        [sys.executable, str(DATA / "make_models.py"), "--out", str(tmp_path)],
        check=True,
        cwd=env_root,
        capture_output=True,
    )
    subprocess.run(
        [sys.executable, str(DATA / "make_golden.py"), "--models", str(tmp_path), "--out", str(tmp_path / "golden")],
        check=True,
        cwd=env_root,
        capture_output=True,
    )
    assert sorted(p.name for p in (tmp_path / "golden").glob("*.f32")) == sorted(
        p.name for p in (DATA / "golden").glob("*.f32")
    ), "golden/ has other files"
    subprocess.run(
        [
            sys.executable,
            str(DATA / "make_malformed.py"),
            "--models",
            str(tmp_path),
            "--out",
            str(tmp_path / "malformed"),
        ],
        check=True,
        cwd=env_root,
        capture_output=True,
    )
    for name in MODELS:
        assert _same_model(rc.load_reference(tmp_path / f"{name}.onnx"), ref_model(name)), name
    for sub in ("variants", "malformed"):
        made = (tmp_path / sub / "manifest.tsv").read_text()
        assert made == (DATA / sub / "manifest.tsv").read_text(), f"{sub}/manifest.tsv is stale"
        names = sorted(p.name for p in (tmp_path / sub).glob("*.onnx"))
        assert names == sorted(p.name for p in (DATA / sub).glob("*.onnx")), sub
        for n in names:  # same sizes: same structure (kernel bytes may differ by an ulp)
            assert (tmp_path / sub / n).stat().st_size == (DATA / sub / n).stat().st_size, n
