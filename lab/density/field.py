"""A piecewise-constant density on [0,1)^2 as dpc defines it (python/dpc/density.py): a (H, W)
grid, row r covering y in [r/H, (r+1)/H), column c covering x in [c/W, (c+1)/W). Here it is
normalised to mean 1, so that m * rho(x) is the expected number density of an m-point set.

The transport used throughout the study is the Knothe-Rosenblatt one: the marginal CDF over rows
(by y), then the conditional CDF within the row (by x), both linear inside a cell. ``warp`` (the
inverse CDF) sends the uniform square onto the density; ``unwarp`` (the CDF) sends it back.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["Field", "ramp", "bump", "step", "photo", "hex_spacing"]

_BELOW_ONE = np.nextafter(1.0, 0.0)


def hex_spacing(m: int, rho) -> np.ndarray:
    """The nearest-neighbour distance of a hexagonal packing of number density m * rho:
    sqrt(2 / (sqrt(3) m rho)) (docs/analysis.md's d_max at the local density)."""
    return np.sqrt(2.0 / (np.sqrt(3.0) * m * np.asarray(rho, dtype=np.float64)))


class Field:
    """A density grid with its transport, exact window masses and edge cells."""

    def __init__(self, grid, name: str = "") -> None:
        g = np.asarray(grid, dtype=np.float64)
        if g.ndim != 2 or not np.all(np.isfinite(g)) or np.any(g < 0) or not g.max() > 0:
            raise ValueError("a density grid is a 2-D array of finite values >= 0, positive somewhere")
        self.name = name
        self.grid = g / g.mean()  # mean 1: the integral over the unit square is 1
        self.h, self.w = g.shape
        rows = self.grid.sum(axis=1)
        self.row_mass = rows / rows.sum()
        self.row_cdf = np.concatenate([[0.0], np.cumsum(self.row_mass)])
        self.row_cdf /= self.row_cdf[-1]
        col = np.cumsum(self.grid, axis=1)
        safe = np.where(col[:, -1:] > 0, col[:, -1:], 1.0)
        self.col_cdf = np.concatenate([np.zeros((self.h, 1)), col / safe], axis=1)  # (H, W + 1)
        self._flat_cdf = (self.col_cdf + np.arange(self.h)[:, None]).ravel()
        sat = np.zeros((self.h + 1, self.w + 1))
        sat[1:, 1:] = np.cumsum(np.cumsum(self.grid, axis=0), axis=1) / (self.h * self.w)
        self.sat = sat  # sat[i, j]: the mass of [0, j/W) x [0, i/H)

    def float32(self) -> np.ndarray:
        """The grid as dpc takes it (only ratios matter)."""
        return np.ascontiguousarray(self.grid, dtype=np.float32)

    def cells(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r = np.clip((p[:, 1] * self.h).astype(np.int64), 0, self.h - 1)
        c = np.clip((p[:, 0] * self.w).astype(np.int64), 0, self.w - 1)
        return r, c

    def rho(self, p: np.ndarray) -> np.ndarray:
        """The density (mean 1) at points (n, 2)."""
        r, c = self.cells(p)
        return self.grid[r, c]

    def warp(self, u: np.ndarray) -> np.ndarray:
        """The inverse CDF: uniform points (n, 2) in [0,1)^2 to points following the density. The
        row from u_y on the marginal CDF, the column from u_x on that row's conditional CDF, the
        fraction within each cell kept (linear inside the cell)."""
        u = np.asarray(u, dtype=np.float64)
        uy = u[:, 1]
        r = np.clip(np.searchsorted(self.row_cdf, uy, side="right") - 1, 0, self.h - 1)
        t = (uy - self.row_cdf[r]) / np.where(self.row_mass[r] > 0, self.row_mass[r], 1.0)
        y = (r + np.clip(t, 0.0, 1.0)) / self.h
        k = np.searchsorted(self._flat_cdf, r + u[:, 0], side="right") - 1
        c = np.clip(k - r * (self.w + 1), 0, self.w - 1)
        lo, hi = self.col_cdf[r, c], self.col_cdf[r, c + 1]
        s = (u[:, 0] - lo) / np.where(hi > lo, hi - lo, 1.0)
        x = (c + np.clip(s, 0.0, 1.0)) / self.w
        return np.minimum(np.stack([x, y], axis=1), _BELOW_ONE)

    def unwarp(self, p: np.ndarray) -> np.ndarray:
        """The CDF (the inverse of ``warp``): points of the density back to the uniform square."""
        p = np.asarray(p, dtype=np.float64)
        r, c = self.cells(p)
        t = p[:, 1] * self.h - r
        s = p[:, 0] * self.w - c
        uy = self.row_cdf[r] + t * self.row_mass[r]
        ux = self.col_cdf[r, c] + s * (self.col_cdf[r, c + 1] - self.col_cdf[r, c])
        return np.clip(np.stack([ux, uy], axis=1), 0.0, _BELOW_ONE)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """White noise following the density: n independent points."""
        return self.warp(rng.random((n, 2)))

    def cumulative(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The mass of [0, x) x [0, y): bilinear in the summed-area table, which is exact for a
        piecewise-constant density (partial cells covered by their fraction)."""
        i = np.clip(np.asarray(y) * self.h, 0.0, self.h)
        j = np.clip(np.asarray(x) * self.w, 0.0, self.w)
        i0 = np.minimum(i.astype(np.int64), self.h - 1)
        j0 = np.minimum(j.astype(np.int64), self.w - 1)
        fi, fj = i - i0, j - j0
        s = self.sat
        return (
            s[i0, j0] * (1 - fi) * (1 - fj)
            + s[i0, j0 + 1] * (1 - fi) * fj
            + s[i0 + 1, j0] * fi * (1 - fj)
            + s[i0 + 1, j0 + 1] * fi * fj
        )

    def mass(self, x0, y0, x1, y1) -> np.ndarray:
        """The exact mass of the rectangles [x0, x1) x [y0, y1) (the fraction of the points)."""
        f = self.cumulative
        return f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0)

    def edge_distance(self, p: np.ndarray) -> np.ndarray:
        """Distance from points to the nearest edge cell (a cell whose density differs from a
        4-neighbour's by more than 2x; zero beside positive counts), measured to the cell's
        centre less half its diagonal (so never more than the true distance); inf without edges."""
        g = self.grid
        edge = np.zeros(g.shape, bool)
        for a, b, ea, eb in (
            (g[:, :-1], g[:, 1:], (slice(None), slice(None, -1)), (slice(None), slice(1, None))),
            (g[:-1, :], g[1:, :], (slice(None, -1), slice(None)), (slice(1, None), slice(None))),
        ):
            big = np.maximum(a, b) > 2.0 * np.minimum(a, b)
            edge[ea] |= big
            edge[eb] |= big
        if not edge.any():
            return np.full(len(p), np.inf)
        r, c = np.nonzero(edge)
        centres = np.stack([(c + 0.5) / self.w, (r + 0.5) / self.h], axis=1)
        d, _ = cKDTree(centres).query(p)
        return np.maximum(d - 0.5 * np.hypot(1.0 / self.w, 1.0 / self.h), 0.0)


def _centres(n: int) -> tuple[np.ndarray, np.ndarray]:
    y, x = (np.mgrid[0:n, 0:n] + 0.5) / n
    return x, y


def ramp(n: int = 256) -> Field:
    x, _ = _centres(n)
    return Field(0.1 + x, "ramp")


def bump(n: int = 256) -> Field:
    x, y = _centres(n)
    return Field(0.05 + np.exp(-((x - 0.5) ** 2 + (y - 0.5) ** 2) / (2 * 0.15**2)), "bump")


def step(n: int = 256) -> Field:
    x, _ = _centres(n)
    return Field(np.where(x < 0.5, 1.0, 16.0), "step")


PHOTO_GAMMA = 1.0


def photo(gamma: float = PHOTO_GAMMA) -> Field:
    """Grace Hopper (matplotlib's sample photo, a US Navy photograph, public domain): 600 x 512,
    rows 44 .. 555 (a 512 x 512 square), averaged 2 x 2 to 256 x 256; density (1 - tone)^gamma,
    tone = Rec. 709 luminance in [0, 1] (dpc.density.image_tone): dark is dense."""
    import matplotlib.cbook as cbook
    from PIL import Image

    from dpc.density import image_tone

    with Image.open(cbook.get_sample_data("grace_hopper.jpg", asfileobj=False)) as img:
        tone = image_tone(np.asarray(img.convert("RGB"))).astype(np.float64)
    sq = tone[44:556].reshape(256, 2, 256, 2).mean(axis=(1, 3))
    return Field((1.0 - sq) ** gamma, "photo")
