"""The rendering bench's anchor samplers (lab/rendering/anchors): each is the sampler it names.
ZSobol's pixels and aligned pixel groups are nets, Sobol' directions are scipy's, Heitz et al.'s
values are their published function of the tables, every value is uniform over seeds."""

from __future__ import annotations

import numpy as np
import pytest

from dpc.baselines import is_02_net

# Mitsuba-optional, as test_mitsuba.py: CI installs the mitsuba extra and runs it.
mi = pytest.importorskip("mitsuba", reason="mitsuba is not installed (pip install .[mitsuba])")
mi.set_variant("scalar_rgb")

from lab.rendering import anchors  # noqa: E402

anchors.register(mi)
M64 = (1 << 64) - 1


def mix64(z: int) -> int:
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
    return z ^ (z >> 31)


def hash2(a: int, b: int) -> int:
    return mix64((a * 0x9E3779B97F4A7C15 + mix64((b + 0x632BE59BD9B4E019) & M64)) & M64)


def morton(x: int, y: int) -> int:
    return sum(((x >> b) & 1) << (2 * b) | ((y >> b) & 1) << (2 * b + 1) for b in range(8))


def values(name: str, spp: int, seed: int, block: int, pixels, requests: int = 4, two_d: bool = True, **extra):
    """{(x, y): (spp, requests, 2)} values of the plugin for pixels of one block; the block's
    first seed is 0, as Mitsuba's first block of a render with seed 0."""
    s = mi.load_dict(
        {"type": name, "sample_count": spp, "seed": seed, "block_size": block, **anchors.properties(name, mi), **extra}
    )
    s.seed(0)  # the block's first seed: the pixel at Morton index 0
    out = {}
    for x, y in pixels:
        s.seed(morton(x, y))
        v = np.zeros((spp, requests, 2))
        for i in range(spp):
            for r in range(requests):
                v[i, r] = tuple(s.next_2d()) if two_d else (s.next_1d(), 0.0)
            s.advance()
        out[(x, y)] = v
    return out


def test_sobol_directions_are_scipys():
    from scipy.stats import qmc

    v = anchors.sobol_directions(8).astype(np.uint64)
    idx = np.arange(256)
    pts = np.zeros((256, 8), dtype=np.uint64)
    for k in range(8):
        pts ^= np.where(((idx >> k) & 1)[:, None] == 1, v[None, :, k], np.uint64(0))
    ref = (qmc.Sobol(8, scramble=False, bits=32).random(256) * 2.0**32).astype(np.uint64)
    assert sorted(map(tuple, pts)) == sorted(map(tuple, ref))  # scipy draws them in Gray-code order


@pytest.mark.parametrize("spp", [4, 16])
def test_zsobol_pixels_and_aligned_pixel_groups_are_nets(spp):
    pix = [(x, y) for y in range(4) for x in range(4)]
    v = values("zsobol", spp, 3, 8, pix)
    for r in range(4):
        for p in pix:
            assert is_02_net(v[p][:, r])
        for gx in (0, 2):  # each aligned 2 x 2 group of pixels: a net of 4 spp points
            for gy in (0, 2):
                group = np.concatenate([v[(gx + dx, gy + dy)][:, r] for dx in (0, 1) for dy in (0, 1)])
                assert is_02_net(group)
        assert is_02_net(np.concatenate([v[p][:, r] for p in pix]))  # the 4 x 4 group


def test_padded_and_joint_sobol_stratify_each_pixel():
    pix = [(0, 0), (5, 2)]
    for name in ("padded_sobol", "owen_sobol"):
        v = values(name, 16, 1, 8, pix)
        for p in pix:
            assert is_02_net(v[p][:, 0])  # the film position: Sobol' dimensions 0 and 1
            for r in range(4):
                for c in range(2):  # every 1-D projection: one value per stratum
                    assert sorted(np.floor(v[p][:, r, c] * 16).astype(int)) == list(range(16))
        assert not np.allclose(v[pix[0]], v[pix[1]])


def test_pmj02bn_tables_are_progressive_nets():
    t = anchors.pmj02bn_tables(tables=2).astype(np.float64) / 2.0**32
    for table in t:
        for k in range(0, 9):
            assert is_02_net(table[: 1 << k])


@pytest.mark.parametrize("spp", [1, 4, 16])
def test_heitz2019_is_the_published_function_of_its_tables(spp):
    z = np.load(anchors.HEITZ)
    sob, scr, rnk = z["sobol"].ravel(), z[f"scrambling_{spp}spp"].ravel(), z[f"ranking_{spp}spp"].ravel()
    seed, pix = 5, [(0, 0), (3, 1), (7, 6)]
    v = values("heitz2019", spp, seed, 8, pix, requests=6)
    k = hash2(seed, 0)  # the run's key: the seed and the block (its first seed, 0)
    for (x, y), got in v.items():
        i, j = (x + (k & 0xFFFFFFFF)) & 127, (y + (k >> 32)) & 127
        for s in range(spp):
            for d in range(12):
                ranked = s ^ int(rnk[(d & 7) + (i + j * 128) * 8])
                value = int(sob[d + ranked * 256]) ^ int(scr[(d & 7) + (i + j * 128) * 8])
                assert got[s, d // 2, d % 2] == np.float32((0.5 + value) / 256)


def test_heitz2019_rotated_is_the_published_values_rotated_per_dimension():
    """The study variant: each dimension's values moved by one toroidal rotation per seed."""
    pix = [(0, 0), (3, 1), (7, 6)]
    a, b = values("heitz2019", 4, 2, 8, pix, requests=3), values("heitz2019", 4, 2, 8, pix, requests=3, rotate=True)
    shift = (b[pix[0]] - a[pix[0]]) % 1.0  # (samples, requests, 2): one rotation per dimension
    for p in pix:
        d = (b[p] - a[p]) % 1.0
        assert np.allclose(np.minimum(np.abs(d - shift[0]), 1 - np.abs(d - shift[0])), 0, atol=1e-6)
    assert np.all(shift[0] > 1e-4)


@pytest.mark.parametrize("name,extra", [(n, {}) for n in anchors.ANCHORS] + [("heitz2019", {"rotate": True})])
def test_values_are_uniform_over_seeds(name, extra):
    """One pixel, sample 0, its first 1-D and 2-D values over 400 seeds: Kolmogorov-Smirnov."""
    from scipy.stats import kstest

    got = []
    for seed in range(400):
        v = values(name, 4, seed, 8, [(3, 5)], requests=2, **extra)[(3, 5)]
        got.append(v[0].ravel())
    got = np.array(got)
    # heitz2019's values are bin centres of 256 bins: uniform up to 1/512
    for c in range(got.shape[1]):
        assert kstest(got[:, c], "uniform").pvalue > 1e-3, (name, c)
