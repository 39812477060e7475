"""An independent transcription of the sampler definition in docs/rendering.md ("Definition"),
in numpy, from public pieces only: the models' scalar-path point sets (``dpc.load(...,
isa="scalar").generate``) and the published 32 x 32 mask (``dpc.Sampler.mask()``). The tests
compare libdpc's dpc_sampler_get_1d / _get_2d with it bit for bit."""

from __future__ import annotations

import numpy as np

import dpc

M64 = (1 << 64) - 1
GOLDEN = 0x9E3779B97F4A7C15
SET_STEP = 0xD1B54A32D192ED03
TILE = 32
F32 = np.float32


def mix64(z: int) -> int:
    z &= M64
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
    return z ^ (z >> 31)


def unit24(bits: int) -> np.float32:
    return F32(bits & 0xFFFFFF) * F32(1.0 / 16777216.0)


def wrap(a, b) -> np.float32:
    t = F32(F32(a) + F32(b))
    return F32(t - F32(1.0)) if t >= F32(1.0) else t


def fold(v) -> np.float32:
    """The baker's transform on the 2^-24 grid: 2v below 1/2, 2(1 - v) - 2^-24 from 1/2 on."""
    v = F32(v)
    if v < F32(0.5):
        return F32(F32(2.0) * v)
    return F32(F32(F32(2.0) * F32(F32(1.0) - v)) - F32(2.0**-24))


def stratify(table: np.ndarray) -> np.ndarray:
    """Each coordinate -> (rank + 1/2) / n, ties ranked by position."""
    n = len(table)
    out = np.empty_like(table)
    for c in range(2):
        order = np.lexsort((np.arange(n), table[:, c]))
        ranks = np.empty(n, dtype=np.int64)
        ranks[order] = np.arange(n)
        out[:, c] = (ranks.astype(F32) + F32(0.5)) / F32(n)
    return out


class ReferenceSampler:
    def __init__(self, model_paths, spp: int, dims: int, seed: int, fold_from: int | None = 1):
        self.n, self.D, self.base = spp, dims, mix64(seed)
        self.fold_from = fold_from  # None: no dimension folded
        models = [dpc.load(p, isa="scalar", threads=1) for p in model_paths]
        # progressive models: tables read in order (rotation range 0), 1-D strata by x rank
        self.progressive = models[0].order == "progressive"
        self.rotate = 0 if self.progressive else spp
        self.tables = []
        k = 0
        while len(self.tables) < dims:
            m = models[k % len(models)]
            pts = m.generate(seed=mix64(self.base + (k + 1) * SET_STEP), n_points=spp)
            for a in range(0, m.dims - 1, 2):
                if len(self.tables) < dims:
                    self.tables.append(stratify(pts[:, a : a + 2].astype(F32)))
            k += 1
        self.mask = dpc.Sampler.mask()

    def key(self, dim: int, pass_: int) -> int:
        return mix64(self.base ^ mix64(((pass_ << 32) | dim) + GOLDEN))

    def _locate(self, x: int, y: int, index: int, dim: int):
        n = self.n
        x, y = x % (1 << 32), y % (1 << 32)
        pass_, k = divmod(index, n)
        key = self.key(dim, pass_)
        h = mix64(key ^ ((y << 32) | x))
        j = k + (((h >> 32) * self.rotate) >> 32)
        if j >= n:
            j -= n
        ox, oy = key & 31, (key >> 5) & 31
        m = self.mask[(y + oy) % TILE, (x + ox) % TILE]
        return dim % self.D, j, m, (unit24(key >> 10), unit24(key >> 34))

    def get_2d(self, x: int, y: int, index: int, dim: int) -> np.ndarray:
        t, j, m, c = self._locate(x, y, index, dim)
        p = self.tables[t][j]
        v = [wrap(p[0], wrap(m[0], c[0])), wrap(p[1], wrap(m[1], c[1]))]
        if self._folds(dim):
            v = [fold(a) for a in v]
        return np.array(v, dtype=F32)

    def _folds(self, dim: int) -> bool:
        return self.fold_from is not None and dim >= self.fold_from

    def get_1d(self, x: int, y: int, index: int, dim: int) -> np.float32:
        t, j, m, c = self._locate(x, y, index, dim)
        u = wrap(m[2], c[0])
        i = int(F32(self.tables[t][j][0] * F32(self.n))) if self.progressive else j
        lattice = F32(F32(F32(i) + u) * F32(F32(1.0) / F32(self.n)))
        v = wrap(lattice if lattice < F32(1.0) else F32(0.0), c[1])
        return fold(v) if self._folds(dim) else v
