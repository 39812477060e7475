"""The pbrt study's reductions (lab/rendering/pbrt_study.py) on synthetic data: no pbrt needed."""

from __future__ import annotations

import numpy as np
import pytest

from lab.rendering import pbrt_study as S


def write_pfm(path, img: np.ndarray, little: bool = True) -> None:
    """As pbrt writes it: 'PF', width height, scale (negative: little endian), rows bottom to top."""
    h, w, _ = img.shape
    dtype = "<f4" if little else ">f4"
    head = f"PF\n{w} {h}\n{-1.0 if little else 1.0:f}\n".encode()
    path.write_bytes(head + np.ascontiguousarray(img[::-1], dtype=dtype).tobytes())


@pytest.mark.parametrize("little", [True, False])
def test_read_pfm_keeps_the_top_row_first(tmp_path, little):
    img = np.arange(2 * 3 * 3, dtype=np.float32).reshape(2, 3, 3)
    p = tmp_path / "a.pfm"
    write_pfm(p, img, little)
    got = S.read_pfm(p)
    assert got.shape == (2, 3, 3)
    np.testing.assert_array_equal(got, img)


def test_image_stats_mse_and_white_noise_energy():
    rng = np.random.default_rng(1)
    ref = rng.random((64, 64, 3))
    noise = rng.normal(0, 0.1, (64, 64, 3))
    mse, el = S.image_stats(ref + noise, ref)
    assert mse == pytest.approx((noise**2).mean())
    assert 0.8 < el < 1.2  # white noise: E_low about 1


def test_image_stats_low_frequency_error_has_high_energy_and_blue_error_low():
    rng = np.random.default_rng(2)
    white = rng.normal(0, 1, (64, 64))
    f = np.fft.fftfreq(64)
    q = np.hypot(f[:, None], f[None, :])
    low = np.real(np.fft.ifft2(np.fft.fft2(white) * (q < 0.1)))
    high = np.real(np.fft.ifft2(np.fft.fft2(white) * (q > 0.3)))
    ref = np.zeros((64, 64, 3))
    assert S.image_stats(ref + low[..., None], ref)[1] > 3
    assert S.image_stats(ref + high[..., None], ref)[1] < 0.05


def test_mean_se_and_ratio_se():
    m, se = S.mean_se([1.0, 2.0, 3.0, 4.0])
    assert m == 2.5
    assert se == pytest.approx(np.std([1, 2, 3, 4], ddof=1) / 2)
    assert S.mean_se([5.0]) == (5.0, 0.0)
    r, rse = S.ratio_se(2.0, 0.2, 1.0, 0.1)
    assert r == 2.0
    assert rse == pytest.approx(2.0 * np.hypot(0.1, 0.1))


def test_parse_function_mse():
    got = S.parse_function_mse("1 0.5\n2 0.25\n\n4 0.125\n")
    assert got == {1: 0.5, 2: 0.25, 4: 0.125}


def test_verdict_says_whether_a_miss_is_beyond_two_standard_errors():
    assert "within 2 standard errors" in S.verdict(1.05, 0.04)
    assert "more than 2 standard errors" in S.verdict(1.20, 0.04)
    assert "standard errors of 1" not in S.verdict(0.9, 0.04)


def rows(mse: float, elow: float) -> dict:
    return {n: {"mse": mse, "mse_se": 0.01 * mse, "elow": elow, "elow_se": 0.01} for n in S.SCENE_SPP}


def test_goals_meet_and_miss():
    scenes = {
        "a": {"rows": {"dpc": rows(1.0, 0.5), "zsobol": rows(2.0, 1.0), "paddedsobol": rows(0.5, 1.0)}},
    }
    checks = S.goals(scenes)
    assert len(checks) == 2 * len(S.MSE_GOAL_SPP) + len(S.ELOW_GOAL_SPP)
    by = {name: (ok, text + cause) for name, ok, text, cause in checks}
    ok, text = by["a, 16 spp: dpc MSE <= zsobol's"]
    assert ok and "x0.50" in text
    ok, text = by["a, 64 spp: dpc MSE <= paddedsobol's"]
    assert not ok and "miss by 100%" in text and "more than 2 standard errors" in text
    ok, text = by["a, 16 spp: dpc MSE <= paddedsobol's"]
    assert not ok and "pad Owen-scrambled nets" in text
    ok, text = by["a, 1 spp: dpc E_low <= zsobol's"]
    assert ok and "likely" not in text  # a met goal names no cause
    scenes["a"]["rows"]["zsobol"] = rows(0.5, 1.0)  # a clear miss below 64 spp: not isolated
    by = {name: (ok, text + cause) for name, ok, text, cause in S.goals(scenes)}
    ok, text = by["a, 16 spp: dpc MSE <= zsobol's"]
    assert not ok and "not isolated" in text
    ok, text = by["a, 1 spp: dpc E_low <= zsobol's"]
    assert ok and "likely" not in text  # a met goal names no cause
    scenes["a"]["rows"]["dpc"] = rows(1.0, 2.0)
    by = {name: (ok, text) for name, ok, text, _ in S.goals(scenes)}
    assert not by["a, 4 spp: dpc E_low <= zsobol's"][0]


def test_an_elow_miss_with_the_smaller_blurred_error_says_so():
    def blurred(mse, elow, blur):
        r = rows(mse, elow)
        for n in S.ELOW_GOAL_SPP:
            r[n].update(blur=blur, blur_se=0.01 * blur)
        return r

    scenes = {
        "a": {"rows": {"dpc": blurred(1.0, 0.9, 0.5), "zsobol": blurred(2.0, 0.7, 1.0), "paddedsobol": rows(2, 1)}}
    }
    by = {name: (ok, text, cause) for name, ok, text, cause in S.goals(scenes)}
    ok, text, cause = by["a, 4 spp: dpc E_low <= zsobol's"]
    assert not ok and "blurred error x0.50" in text and "a share of each sampler's own error" in cause
    scenes["a"]["rows"]["dpc"] = blurred(1.0, 0.9, 1.5)  # the blurred error higher too: the other causes
    ok, text, cause = {n: (o, t, c) for n, o, t, c in S.goals(scenes)}["a, 4 spp: dpc E_low <= zsobol's"]
    assert not ok and "blurred error x1.50" in text and "share" not in cause
