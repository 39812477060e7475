"""Importance sampling a 2-D density with dpc's blue noise: points and their pdf.

A density is the piecewise-constant grid of docs/density.md: cell (c, r) of an (H, W) grid is
[c/W, (c+1)/W) x [r/H, (r+1)/H). Normalised to integrate to 1 over the unit square, it is the pdf

    pdf(x, y) = density[r, c] / mean(density),   r = floor(y H), c = floor(x W),

and for any f on [0,1)^2 that is zero wherever the density is,

    integral of f over [0,1)^2  ~=  mean_i f(x_i) / pdf(x_i),

the importance-sampling estimator: unbiased when each point x_i has that pdf. Use it when f is
roughly proportional to the density: an environment map's radiance times a cosine, a light's
power. :func:`sample_density` makes such points from a dpc model: by default its uniform blue
noise, randomly shifted and mapped through the density's inverse CDF (:func:`warp_to_density`),
which have exactly that pdf; ``method="filter"`` takes ``Model.generate_density``'s points
instead, which follow the density only approximately (biased where it has small, very bright
regions: docs/reports/envmap-density.md).

Environment maps in latitude-longitude layout (Mitsuba 3's ``envmap`` convention, measured in
docs/reports/envmap-density.md): a point (x, y) of the square is the direction with azimuth
phi = 2 pi x and polar angle theta = pi y from the +y axis (up),

    d = (sin phi sin theta, cos theta, -cos phi sin theta)         (emitter's local frame),

so the image's top row is the zenith and x = 1/2 looks down +z. Solid angle and the square relate
by d(omega) = 2 pi^2 sin(theta) dx dy: a pdf over the square divided by 2 pi^2 sin(theta) is a
pdf over solid angle (:func:`latlong_to_direction` returns that factor). Mitsuba places pixel
(c, r) of a W x H map at x = (c + 1/2) / W (a cell centre, as here) but at y = r / (H - 1) (the
first row on the pole, the last on the other pole) and interpolates bilinearly between pixels;
a density built from its bitmap rows as cells is thus up to half a row off. Resample the map's
luminance at the cell centres y = (r + 1/2) / H before :func:`latlong_density` where that
matters (a small, bright sun).
"""

from __future__ import annotations

import numpy as np

from .density import as_density
from .errors import InvalidArgumentError

__all__ = ["sample_density", "pdf_of", "warp_to_density", "latlong_density", "latlong_to_direction"]


def _grid(density, resolution: int) -> np.ndarray:
    """The float32 grid the points follow (dpc.density.as_density: checked, largest value 1)."""
    return as_density(density, resolution=resolution)


def _points(points) -> np.ndarray:
    pts = np.asarray(points)
    if pts.dtype.kind not in "fiu" or pts.ndim != 2 or pts.shape[1] != 2:
        raise InvalidArgumentError(f"points must be a numeric (n, 2) array, got {pts.dtype} {pts.shape}")
    pts = pts.astype(np.float64)
    if not np.all(np.isfinite(pts)):
        raise InvalidArgumentError("points must be finite")
    if np.any(pts < 0) or np.any(pts >= 1):
        raise InvalidArgumentError("points must lie in [0, 1)^2")
    return pts


def _pdf(grid: np.ndarray, pts: np.ndarray) -> np.ndarray:
    h, w = grid.shape
    # the cell of a coordinate as libdpc finds it: floor(x * n) in double, for float32 x
    r = np.minimum((pts[:, 1] * h).astype(np.int64), h - 1)
    c = np.minimum((pts[:, 0] * w).astype(np.int64), w - 1)
    return grid[r, c].astype(np.float64) / grid.mean(dtype=np.float64)


def pdf_of(density, points, *, resolution: int = 512) -> np.ndarray:
    """The normalised piecewise-constant pdf of ``density`` at ``points``: float64 (n,).

    ``density`` is anything :func:`dpc.density.as_density` takes (an (H, W) array of values >= 0,
    a callable f(x, y) sampled on a ``resolution``-square grid, an image); ``points`` an (n, 2)
    array in [0, 1)^2. The value is density[r, c] / mean(density) for the point's cell, so it
    integrates to 1 over the square; 0 in zero-density cells. It is exactly the pdf of the points
    of :func:`warp_to_density` (uniform input) and :func:`sample_density`'s default method;
    ``Model.generate_density``'s points follow it only approximately."""
    return _pdf(_grid(density, resolution), _points(points))


def warp_to_density(density, points, *, resolution: int = 512) -> np.ndarray:
    """Points of the square mapped through ``density``'s inverse CDF: float32 (n, 2).

    As libdpc maps its input (docs/density.md): the row by the second coordinate, then the cell
    within the row by the first, the fractions within the cell kept. Uniformly distributed
    ``points`` come out with exactly the pdf :func:`pdf_of` gives; stratified or blue-noise points
    keep their structure in the warped (primary) space. No output lies in a zero cell."""
    grid = _grid(density, resolution)
    pts = _points(points)
    h, w = grid.shape
    g = grid.astype(np.float64)
    rows = np.concatenate([[0.0], np.cumsum(g.sum(1))])
    r = _find(rows, pts[:, 1] * rows[-1])
    fy = (pts[:, 1] * rows[-1] - rows[r]) / (rows[r + 1] - rows[r])
    c, fx = np.empty(len(pts), dtype=np.int64), np.empty(len(pts))
    order = np.argsort(r, kind="stable")
    rows_hit, starts = np.unique(r[order], return_index=True)
    for row, at in zip(rows_hit, np.split(order, starts[1:])):  # by the row's own CDF (precise)
        cdf = np.concatenate([[0.0], np.cumsum(g[row])])
        t = pts[at, 0] * cdf[-1]
        c[at] = _find(cdf, t)
        fx[at] = (t - cdf[c[at]]) / (cdf[c[at] + 1] - cdf[c[at]])
    out = np.stack([_in_cell(c, fx, w), _in_cell(r, fy, h)], axis=-1)
    return np.ascontiguousarray(out)


def _find(cdf: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The cells k with cdf[k] <= t < cdf[k + 1] and mass (cdf[k + 1] > cdf[k]); t in [0, cdf[-1]]."""
    k = np.clip(np.searchsorted(cdf, t, side="right") - 1, 0, len(cdf) - 2)
    while np.any(empty := cdf[k + 1] <= cdf[k]):  # t rounded onto the top end, past empty cells
        k[empty] -= 1
    return k


def _in_cell(cell: np.ndarray, f: np.ndarray, n: int) -> np.ndarray:
    """(cell + f) / n as float32 inside that cell (libdpc's in_cell: rounding may land on an edge)."""
    v = ((cell + np.clip(f, 0.0, 1.0)) / n).astype(np.float32)
    for _ in range(4):
        hi = (v.astype(np.float64) * n).astype(np.int64) > cell
        v[hi] = np.nextafter(v[hi], np.float32(0))
        lo = (v.astype(np.float64) * n).astype(np.int64) < cell
        v[lo] = np.nextafter(v[lo], np.float32(1))
    return v


def sample_density(
    density, n: int, seed: int = 0, model="bnot-2d-stratified", *, method: str = "warp", resolution: int = 512
) -> tuple[np.ndarray, np.ndarray]:
    """Blue noise importance-sampling ``density``, and each point's pdf: (points (n, 2) float32
    in [0, 1)^2, pdf (n,) float64 = :func:`pdf_of`).

    Estimate the integral of f over the square as ``np.mean(f(points) / pdf)``; f must vanish
    where the density does (no point lies in a zero cell). ``method``:

    - ``"warp"`` (default): the model's uniform set for ``seed`` (``Model.generate``), shifted
      on the torus by a random offset drawn from ``seed``, then :func:`warp_to_density`. Each
      point then has exactly the pdf returned, so the estimator is unbiased for any density; the
      set is blue noise in the square before the warp (as a renderer's sampler is).
    - ``"filter"``: ``Model.generate_density``, blue noise in the density's own local spacing.
      Its points follow the density only approximately: where the density has a small region
      of very high value (an HDR sun), the filters push points out of it, the returned pdf is
      not theirs and the estimate is biased (docs/reports/envmap-density.md measures a sun of 60 %
      of the mass getting 13 % of 64 points and 48 % of 1024).

    ``model`` is a bundled model's name or a loaded :class:`dpc.Model` (a 2-D set model:
    bnot-2d-stratified, bnot-2d, blue-2d, ...); ``density`` and ``resolution`` as for
    :func:`pdf_of`; ``seed`` as for ``generate``. The same seed gives the same bits."""
    from ._model import Model, load

    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InvalidArgumentError(f"n must be a positive integer, got {n!r}")
    if method not in ("warp", "filter"):
        raise InvalidArgumentError(f'method must be "warp" or "filter", got {method!r}')
    if isinstance(model, Model):
        m = model
    elif isinstance(model, str):
        m = load(model)
    else:
        raise InvalidArgumentError(f"model must be a model name or a dpc.Model, got {type(model).__name__}")
    if m.dims != 2:
        raise InvalidArgumentError(f"the model makes {m.dims}-D points; sample_density needs a 2-D model")
    grid = _grid(density, resolution)
    if method == "filter":
        pts = m.generate_density(grid, int(n), seed)
    else:
        shift = np.random.default_rng(int(seed)).random(2)
        u = (m.generate(seed, int(n)).astype(np.float64) + shift) % 1.0
        pts = warp_to_density(grid, np.minimum(u, np.nextafter(1.0, 0.0)))
    return pts, _pdf(grid, pts.astype(np.float64))


def latlong_density(luminance) -> np.ndarray:
    """The density over the square of a latitude-longitude map's luminance: luminance[r, c] times
    sin(theta_r), theta_r = pi (r + 1/2) / H the row centre's polar angle, float64 (H, W).

    Sampling the square with it and mapping by :func:`latlong_to_direction` samples directions
    in proportion to the luminance (over solid angle), since d(omega) = 2 pi^2 sin(theta) dx dy.
    ``luminance`` is a 2-D (H, W) array of values >= 0 (row 0 is the zenith; HDR values welcome:
    pass luminance, not an RGB image, which dpc.density.as_density would read as tone in [0, 1])."""
    lum = np.asarray(luminance)
    if lum.dtype.kind not in "fiu" or lum.ndim != 2 or 0 in lum.shape:
        raise InvalidArgumentError(f"luminance must be a numeric (H, W) array, got {lum.dtype} {lum.shape}")
    lum = lum.astype(np.float64)
    if not np.all(np.isfinite(lum)) or np.any(lum < 0):
        raise InvalidArgumentError("luminance must be finite and >= 0")
    h = lum.shape[0]
    out = lum * np.sin(np.pi * (np.arange(h) + 0.5) / h)[:, None]
    as_density(out)  # the density checks (not all zero, size), with their messages
    return out


def latlong_to_direction(points) -> tuple[np.ndarray, np.ndarray]:
    """Directions of points of the square in latitude-longitude layout, and the Jacobian:
    (directions (n, 3) float64 unit vectors, jacobian (n,) float64 = 2 pi^2 sin(theta)).

    (x, y) -> phi = 2 pi x, theta = pi y, d = (sin phi sin theta, cos theta, -cos phi sin theta):
    Mitsuba 3's envmap frame (+y up; apply the emitter's to_world for world space). A pdf over
    the square becomes a pdf over solid angle as pdf / jacobian, so with radiance L and a
    cosine, E(n) = integral of L(w) max(0, n.w) dw ~= mean_i L(d_i) max(0, n.d_i) jacobian_i / pdf_i."""
    pts = _points(points)
    phi, theta = 2.0 * np.pi * pts[:, 0], np.pi * pts[:, 1]
    st = np.sin(theta)
    d = np.stack([np.sin(phi) * st, np.cos(theta), -np.cos(phi) * st], axis=-1)
    return d, 2.0 * np.pi**2 * st
