"""dpc.importance: importance sampling a 2-D density with dpc's sets (points and their pdf)."""

import numpy as np
import pytest

import dpc
from dpc.importance import latlong_density, latlong_to_direction, pdf_of, sample_density, warp_to_density


def test_the_pdf_integrates_to_one_and_is_zero_in_zero_cells():
    d = np.array([[1.0, 3.0], [0.0, 4.0]])
    g = (np.mgrid[0:64, 0:64].reshape(2, -1).T[:, ::-1] + 0.5) / 64
    pdf = pdf_of(d, g)
    assert abs(pdf.mean() - 1.0) < 1e-12
    assert np.all(pdf[(g[:, 0] < 0.5) & (g[:, 1] >= 0.5)] == 0)


def test_warped_points_have_exactly_the_pdf():
    """Uniform cell centres of a fine grid warp to counts proportional to the density."""
    d = np.array([[1.0, 3.0, 0.0], [2.0, 0.5, 1.5]])
    n = 600
    u = (np.mgrid[0:n, 0:n].reshape(2, -1).T[:, ::-1] + 0.5) / n
    p = warp_to_density(d, u)
    assert p.dtype == np.float32 and p.min() >= 0 and p.max() < 1
    c = np.minimum((p.astype(np.float64) * [3, 2]).astype(int), [2, 1])
    counts = np.bincount(c[:, 1] * 3 + c[:, 0], minlength=6).reshape(2, 3)
    np.testing.assert_allclose(counts / counts.sum(), d / d.sum(), atol=2e-5)


@pytest.mark.parametrize("method", ["warp", "filter"])
def test_the_estimator_integrates_a_function_shaped_like_the_density(method):
    y, x = (np.mgrid[0:64, 0:64] + 0.5) / 64
    d = 0.2 + x * x + np.where((x - 0.7) ** 2 + (y - 0.3) ** 2 < 0.01, 20.0, 0.0)

    def f(p):
        c = np.minimum((p * 64).astype(int), 63)
        return d[c[:, 1], c[:, 0]] * (1.0 + 0.5 * np.cos(3 * p[:, 1]))

    yy = (np.arange(64) + 0.5) / 64
    exact = float((d * (1.0 + 0.5 * np.cos(3 * yy))[:, None]).mean())
    est = []
    for seed in range(16):
        p, pdf = sample_density(d, 1024, seed, method=method)
        est.append(np.mean(f(p.astype(np.float64)) / pdf))
    assert abs(np.mean(est) / exact - 1) < (0.003 if method == "warp" else 0.02)


def test_sample_density_is_deterministic_and_checks_its_arguments():
    d = np.ones((4, 4))
    a, pa = sample_density(d, 256, 3)
    b, pb = sample_density(d, 256, 3, model=dpc.load("bnot-2d-stratified"))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(pa, pb)
    with pytest.raises(dpc.InvalidArgumentError):
        sample_density(d, 0)
    with pytest.raises(dpc.InvalidArgumentError):
        sample_density(d, 16, method="magic")
    with pytest.raises(dpc.InvalidArgumentError):
        sample_density(d, 16, model=dpc.load("bnot-3d"))
    with pytest.raises(dpc.InvalidArgumentError):
        pdf_of(d, [[0.5, 1.0]])


def test_latlong_directions_and_density():
    p = np.array([[0.0, 0.5], [0.25, 0.5], [0.5, 0.5], [0.3, 0.0]])
    dirs, jac = latlong_to_direction(p)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0)
    np.testing.assert_allclose(dirs[:3], [[0, 0, -1], [1, 0, 0], [0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(dirs[3], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(jac, 2 * np.pi**2 * np.sin(np.pi * p[:, 1]))
    dens = latlong_density(np.ones((4, 8)))
    np.testing.assert_allclose(dens[:, 0], np.sin(np.pi * (np.arange(4) + 0.5) / 4))
    with pytest.raises(dpc.InvalidArgumentError):
        latlong_density(-np.ones((2, 2)))
