"""The anchors the density study measures dpc against (not the product).

* ``warp``: dpc's own uniform set sent through the density's inverse CDF (Field.warp).
* ``sample_elimination``: weighted sample elimination, Yuksel 2015 ("Sample Elimination for
  Generating Poisson Disk Sample Sets", Eurographics), from the paper: 5 m candidates drawn from
  the density (white), weights w_ij = (1 - d_ij / (2 r_ij))^8 over pairs closer than 2 r_ij, the
  heaviest removed (its neighbours' weights updated) until m remain. Adaptive (the paper's
  adaptive sampling): each candidate has its own r_i = r_max / sqrt(rho(x_i)), r_max the paper's
  2-D maximal radius for m points sqrt(1 / (2 sqrt(3) m)) (rho has mean 1), and a pair uses the
  harmonic mean r_ij = 2 r_i r_j / (r_i + r_j) (as dpc's pair spacing). With the paper's weight
  limiting and defaults: d_ij clamped below at 2 r_ij beta (1 - (m / M)^gamma), alpha 8,
  beta 0.65, gamma 1.5.
* ``dart_throwing``: sequential variable-radius dart throwing: candidates drawn from the density
  one after another, a candidate kept unless a kept point lies closer than the harmonic mean of
  their radii r(x) = c * sqrt(2 / (sqrt(3) m rho(x))) (c = DART_C times the local hexagonal
  spacing), until m are kept. Exact sequential semantics, processed in batches with k-d trees.
* ``lloyd``: weighted Lloyd relaxation (Secord 2002, weighted centroidal Voronoi stippling):
  every raster pixel goes to its nearest site (cKDTree), each site moves to its cell's centroid
  weighted by rho^power. A centroidal Voronoi tessellation of weight f has point density
  proportional to f^(d / (d + 2)) (Gersho 1979), f^(1/2) in 2-D: Secord's weights f = rho give
  points following sqrt(rho) once converged, so the default is power = 2 (points following rho).
  The raster is the density grid supersampled by 2^k until it has at least ``per_point`` pixels
  per point. Starts from a jittered grid sent through the inverse CDF; stops when the mean move
  is below 1e-4 of the local hexagonal spacing or after ``max_iter`` iterations.
"""

from __future__ import annotations

import heapq

import numpy as np
from scipy.spatial import cKDTree

from lab.density.field import Field, hex_spacing

ALPHA, BETA, GAMMA = 8.0, 0.65, 1.5
DART_C = 0.7


def _close_pairs(p: np.ndarray, reach: np.ndarray, chunk: int = 1 << 14) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j), i != j, each unordered pair once, with |p_i - p_j| < reach_i where
    reach_i <= reach_j (a pair's cut-off below must be <= both reaches)."""
    if len(p) == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    tree = cKDTree(p)
    out_i, out_j = [], []
    for start in range(0, len(p), chunk):
        stop = min(start + chunk, len(p))
        lists = tree.query_ball_point(p[start:stop], reach[start:stop], return_sorted=False)
        lens = np.fromiter((len(x) for x in lists), np.int64, len(lists))
        j = np.fromiter((k for x in lists for k in x), np.int64, int(lens.sum()))
        i = np.repeat(np.arange(start, stop), lens)
        keep = (reach[j] > reach[i]) | ((reach[j] == reach[i]) & (j > i))
        out_i.append(i[keep])
        out_j.append(j[keep])
    return np.concatenate(out_i), np.concatenate(out_j)


def harmonic(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return 2.0 * a * b / (a + b)


def warp(field: Field, uniform: np.ndarray) -> np.ndarray:
    """(b): a uniform set sent through the inverse CDF."""
    return field.warp(uniform)


def sample_elimination(field: Field, m: int, rng: np.random.Generator, ratio: int = 5) -> np.ndarray:
    """(c): adaptive weighted sample elimination of ratio * m candidates down to m."""
    n = ratio * m
    cand = field.sample(n, rng)
    r_max = np.sqrt(1.0 / (2.0 * np.sqrt(3.0) * m))
    r = r_max / np.sqrt(field.rho(cand))
    # pair cut-off 2 r_ij <= 4 min(r_i, r_j): found from the point with the smaller radius
    i, j = _close_pairs(cand, 4.0 * r)
    d = np.linalg.norm(cand[i] - cand[j], axis=1)
    rij = harmonic(r[i], r[j])
    near = d < 2.0 * rij
    i, j, d, rij = i[near], j[near], d[near], rij[near]
    d = np.maximum(d, 2.0 * rij * BETA * (1.0 - (m / n) ** GAMMA))  # weight limiting
    w = (1.0 - d / (2.0 * rij)) ** ALPHA
    weight = np.bincount(i, w, n) + np.bincount(j, w, n)
    # neighbour lists (CSR) as Python lists for the heap loop
    src = np.concatenate([i, j])
    dst = np.concatenate([j, i])
    ww = np.concatenate([w, w])
    order = np.argsort(src, kind="stable")
    dst, ww = dst[order].tolist(), ww[order].tolist()
    ptr = np.concatenate([[0], np.cumsum(np.bincount(src, minlength=n))]).tolist()
    wt = weight.tolist()
    alive = [True] * n
    heap = [(-wt[k], k) for k in range(n)]
    heapq.heapify(heap)
    left = n
    while left > m:
        neg, k = heapq.heappop(heap)
        if not alive[k] or -neg != wt[k]:
            continue  # stale entry
        alive[k] = False
        left -= 1
        for e in range(ptr[k], ptr[k + 1]):
            q = dst[e]
            if alive[q]:
                wt[q] -= ww[e]
                heapq.heappush(heap, (-wt[q], q))
    return cand[np.asarray(alive)]


def dart_throwing(
    field: Field, m: int, rng: np.random.Generator, c: float = DART_C, max_ratio: int = 100
) -> tuple[np.ndarray, int]:
    """(d): sequential variable-radius dart throwing until m points are kept (or max_ratio * m
    candidates are spent): (points, candidates used)."""
    kept = np.empty((0, 2))
    kept_r = np.empty(0)
    used = 0
    batch = max(256, m // 16)
    while len(kept) < m and used < max_ratio * m:
        cand = field.sample(batch, rng)
        cr = c * hex_spacing(m, field.rho(cand))
        ok = np.ones(batch, bool)
        if len(kept):
            # a conflict needs d < r_ij <= 2 min(r_i, r_j): look within 2 r of the candidate
            lists = cKDTree(kept).query_ball_point(cand, 2.0 * cr, return_sorted=False)
            lens = np.fromiter((len(x) for x in lists), np.int64, batch)
            j = np.fromiter((k for x in lists for k in x), np.int64, int(lens.sum()))
            i = np.repeat(np.arange(batch), lens)
            hit = np.linalg.norm(cand[i] - kept[j], axis=1) < harmonic(cr[i], kept_r[j])
            ok[i[hit]] = False
        live = np.flatnonzero(ok)
        # conflicts among this batch's survivors, resolved in order (the sequential rule)
        a, b = _close_pairs(cand[live], 2.0 * cr[live])
        hit = np.linalg.norm(cand[live[a]] - cand[live[b]], axis=1) < harmonic(cr[live[a]], cr[live[b]])
        a, b = np.minimum(a[hit], b[hit]), np.maximum(a[hit], b[hit])  # earlier, later
        earlier: list[list[int]] = [[] for _ in range(len(live))]
        for x, y in zip(a.tolist(), b.tolist()):
            earlier[y].append(x)
        take = [False] * len(live)
        need = m - len(kept)
        last = len(live)
        for k in range(len(live)):
            take[k] = not any(take[x] for x in earlier[k])
            if take[k]:
                need -= 1
                if need == 0:
                    last = k + 1
                    break
        sel = live[np.flatnonzero(take)]
        # candidates after the m-th kept one were never thrown
        used += int(live[last - 1]) + 1 if need == 0 and last else batch
        kept = np.concatenate([kept, cand[sel]])
        kept_r = np.concatenate([kept_r, cr[sel]])
    return kept, used


def jittered(field: Field, m: int, rng: np.random.Generator) -> np.ndarray:
    """m points of a jittered k x k grid (k = ceil(sqrt(m)), a random subset when k^2 > m) sent
    through the inverse CDF."""
    k = int(np.ceil(np.sqrt(m)))
    y, x = np.mgrid[0:k, 0:k]
    u = (np.stack([x.ravel(), y.ravel()], axis=1) + rng.random((k * k, 2))) / k
    if k * k > m:
        u = u[rng.choice(k * k, m, replace=False)]
    return field.warp(u)


def raster(field: Field, m: int, per_point: int = 8, power: float = 2.0) -> tuple[np.ndarray, np.ndarray, int]:
    """Pixel centres with density > 0 and their weights rho^power: the density grid supersampled
    by the smallest power of 2 giving >= per_point pixels per point; (centres, weights, factor)."""
    s = 1
    while field.h * field.w * s * s < per_point * m:
        s *= 2
    hh, ww = field.h * s, field.w * s
    y, x = (np.mgrid[0:hh, 0:ww] + 0.5) / np.array([hh, ww])[:, None, None]
    w = np.repeat(np.repeat(field.grid**power, s, axis=0), s, axis=1).ravel()
    pix = np.stack([x.ravel(), y.ravel()], axis=1)
    keep = w > 0
    return pix[keep], w[keep], s


def lloyd(
    field: Field,
    m: int,
    rng: np.random.Generator,
    max_iter: int,
    tol: float = 1e-4,
    per_point: int = 8,
    power: float = 2.0,
) -> tuple[np.ndarray, int, float, int]:
    """(e): weighted Lloyd relaxation: (points, iterations run, last mean move in local spacings,
    supersampling factor)."""
    pix, w, s = raster(field, m, per_point, power)
    sites = jittered(field, m, rng)
    move = np.inf
    it = 0
    while it < max_iter and move >= tol:
        _, idx = cKDTree(sites).query(pix, workers=1)
        mass = np.bincount(idx, w, m)
        cx = np.bincount(idx, w * pix[:, 0], m)
        cy = np.bincount(idx, w * pix[:, 1], m)
        has = mass > 0
        new = sites.copy()
        new[has, 0] = cx[has] / mass[has]
        new[has, 1] = cy[has] / mass[has]
        move = float(np.mean(np.linalg.norm(new - sites, axis=1) / hex_spacing(m, field.rho(new))))
        sites = new
        it += 1
    return sites, it, move, s
