"""The density generator's definition (docs/density.md) in float64 numpy, written from the page,
not from libdpc: the parity test holds libdpc's float32 engine to it, and the design study
(lab/density/design.py) varies its choices (the pair's mean spacing, the walls) to show why they
are what they are.

    points = filter(model, density, input_points(model, density, seed, m), pair=..., walls=...)
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

import dpc
from dpc.importance import warp_to_density
from dpc.model_file import read_model

WALL = 4.0  # density ratio a step may not cross, and that makes a wall
WALL_H = np.sqrt(WALL)  # the same for spacings
WALL_REACH = 2.0  # a point nearer a wall of its own than this many spacings sees mirror images
WALL_GLIDE = 4.0  # its own spacings: the shift of those images along a straight wall
H_CAP = 1.0

PAIR_MEANS = {
    "own": lambda hi, hj: np.full_like(hj, hi),  # each point's own spacing: not symmetric
    "arithmetic": lambda hi, hj: 0.5 * (hi + hj),
    "geometric": lambda hi, hj: np.sqrt(hi * hj),
    "harmonic": lambda hi, hj: 2.0 * hi * hj / (hi + hj),
}


def spacing_grid(density, m: int) -> np.ndarray:
    """h per cell: (m rho)^(-1/2) with rho the density over its mean (float32, as libdpc), 0 where
    the density is zero, at most H_CAP."""
    d = np.asarray(density, dtype=np.float64)
    rho = d * d.size / d.sum()
    with np.errstate(divide="ignore"):
        h = np.where(rho > 0, np.minimum(1.0 / np.sqrt(m * rho), H_CAP), 0.0)
    return h.astype(np.float32)


def cell_of(v, n: int):
    return np.minimum((np.asarray(v, dtype=np.float64) * n).astype(np.int64), n - 1)


def input_points(model: dpc.Model, density, seed: int, m: int) -> np.ndarray:
    """The model's input (uniform or stratified) through the density's inverse CDF: the row by
    the second coordinate, the cell within the row by the first, fractions kept."""
    u = (dpc.stratified(seed, m, 2) if model.input == "stratified" else dpc.uniform(seed, m, 2)).astype(np.float64)
    return warp_to_density(density, u).astype(np.float64)  # the package's copy of that map


def own(hi, hj):
    """Spacings hj that a point of spacing hi (> 0) sees as its own side: within WALL_H times."""
    return (hj > 0) & (hj * WALL_H >= hi) & (hj <= hi * WALL_H)


def wall_segments(hcell: np.ndarray) -> np.ndarray:
    """The walls: boundaries between 4-neighbour cells whose spacings differ more than WALL_H
    times or of which one is zero, as rows (x0, y0, x1, y1, h of the cell left / below, h right /
    above); neighbouring boundaries along one line with the same two spacings merged into one
    segment (vertical ones column by column, then horizontal ones row by row)."""
    Hc, Wc = hcell.shape
    h = hcell.astype(np.float64)

    def runs(g):
        """Per boundary between columns c and c + 1 of g: its runs of divided cells down the
        column with the same two spacings, as (c, first row, end row, left, right)."""
        for c in range(g.shape[1] - 1):
            a, b = g[:, c], g[:, c + 1]
            div = np.where((a > 0) & (b > 0), ~own(a, b), (a > 0) != (b > 0))
            r = 0
            while r < len(a):
                if not div[r]:
                    r += 1
                    continue
                e = r + 1
                while e < len(a) and a[e] == a[r] and b[e] == b[r]:
                    e += 1
                yield c, r, e, a[r], b[r]
                r = e

    rows = [((c + 1) / Wc, r / Hc, (c + 1) / Wc, e / Hc, a, b) for c, r, e, a, b in runs(h)]
    rows += [(c / Wc, (r + 1) / Hc, e / Wc, (r + 1) / Hc, a, b) for r, c, e, a, b in runs(h.T)]
    return np.array(rows, dtype=np.float64).reshape(-1, 6)


def nearest_walls(p: np.ndarray, h: np.ndarray, segs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per point, the nearest point of its own walls (those with exactly one side its own) closer
    than WALL_REACH h (at most 1/2), the unit normal from it to the point, and how far its segment
    runs on from it down and up its axis; NaN where none."""
    w = np.full_like(p, np.nan)
    n = np.full_like(p, np.nan)
    run = np.full_like(p, np.nan)
    if not len(segs):
        return w, n, run
    reach = np.minimum(WALL_REACH * h, 0.5)
    for i in range(len(p)):
        mine = own(h[i], segs[:, 4]) != own(h[i], segs[:, 5])
        s = segs[mine]
        q = np.stack([np.clip(p[i, 0], s[:, 0], s[:, 2]), np.clip(p[i, 1], s[:, 1], s[:, 3])], axis=1)
        d = np.sqrt(((q - p[i]) ** 2).sum(1))
        if not len(d) or d.min() >= reach[i]:
            continue
        k = int(np.argmin(d))
        w[i] = q[k]
        axis = 1 if s[k, 0] == s[k, 2] else 0  # vertical segments run along y
        run[i] = (q[k, axis] - s[k, axis], s[k, axis + 2] - q[k, axis])
        if d[k] > 0:
            n[i] = (p[i] - q[k]) / d[k]
        else:  # on the wall: towards the side of its own spacing
            sign = -1.0 if own(h[i], s[k, 4]) else 1.0
            n[i] = (sign, 0.0) if s[k, 0] == s[k, 2] else (0.0, sign)
    return w, n, run


GLIDE = 4.0  # mean spacings: the shift along a side of the images across it (at most 1/4)


def glide(m: int) -> float:
    return float(np.float32(min(GLIDE / np.sqrt(m), 0.25)))


def _images(p: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The set and its images at the square's sides: (coordinates, the index of the point each
    shows, its family). Across a side an image is the mirror image shifted along the side by
    -tau (family 1: seen by the points of the lower or left half) or +tau (family 2: the upper
    or right half), kept where the shifted coordinate stays in [0, 1); families 1 and 2 across
    the left and right sides, 3 and 4 across the bottom and top; the corners' images (family 5)
    are mirrored twice and not shifted."""
    x, y = p[:, 0], p[:, 1]
    idx = np.arange(len(p))
    pts, owner, fam = [p], [idx], [np.zeros(len(p), np.int64)]
    for f, s in ((1, -tau), (2, tau)):
        for mx in (-x, 2.0 - x):
            k = (y + s >= 0) & (y + s < 1)
            pts.append(np.stack([mx, y + s], 1)[k]), owner.append(idx[k]), fam.append(np.full(k.sum(), f))
    for f, s in ((3, -tau), (4, tau)):
        for my in (-y, 2.0 - y):
            k = (x + s >= 0) & (x + s < 1)
            pts.append(np.stack([x + s, my], 1)[k]), owner.append(idx[k]), fam.append(np.full(k.sum(), f))
    for mx in (-x, 2.0 - x):
        for my in (-y, 2.0 - y):
            pts.append(np.stack([mx, my], 1)), owner.append(idx), fam.append(np.full(len(p), 5))
    return np.concatenate(pts), np.concatenate(owner), np.concatenate(fam)


def _seen(fam: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Which images a point at q sees: the set, the corners and the families of its halves."""
    return (fam == 0) | (fam == 5) | (fam == (1 if q[1] < 0.5 else 2)) | (fam == (3 if q[0] < 0.5 else 4))


def layer(
    p,
    hcell,
    spec_layer,
    pair: str = "harmonic",
    walls: bool = True,
    segs: np.ndarray | None = None,
    glides: bool = True,
    wall_glides: bool = True,
):
    """One layer: every point's step, then the steps taken (mirrored at the sides; none across a
    wall or into a zero cell). walls: pairs of spacings more than WALL_H apart see the smaller one,
    and steps do not cross walls; segs: the walls (wall_segments) when they also mirror; glides:
    the images across the sides are shifted along them (False: plain mirror images); wall_glides:
    so are those across long straight walls (False: plain mirrors at every wall)."""
    Hc, Wc = hcell.shape
    h = hcell[cell_of(p[:, 1], Hc), cell_of(p[:, 0], Wc)].astype(np.float64)
    rho = spec_layer.radius[0]
    w = spec_layer.kernels[0].astype(np.float64)
    b = len(w)
    mean = PAIR_MEANS[pair]
    imgs, owner, fam = _images(p, glide(len(p)) if glides else 0.0)
    tree = cKDTree(imgs)
    reach = np.minimum(rho * np.maximum(2.0 * h, h.max()) if pair != "harmonic" else rho * 2.0 * h, 0.5)
    lists = tree.query_ball_point(p, reach)
    mirror = walls and segs is not None and len(segs) > 0
    if mirror:
        wall, normal, run = nearest_walls(p, h, segs)
    step = np.zeros_like(p)

    def terms(delta, hij):
        d = np.sqrt((delta**2).sum(1))
        u = d * (b - 1) / (rho * hij)
        ok = (u < b - 1) & (d > spec_layer.eps * hij) & (d < 0.5)
        q = np.minimum(np.floor(u[ok]).astype(np.int64), b - 2)
        g = w[q] + (u[ok] - q) * (w[q + 1] - w[q])
        return ((hij[ok] * g / d[ok])[:, None] * delta[ok]).sum(0), ok

    for i, nb in enumerate(lists):
        nb = np.asarray(nb, dtype=np.int64)
        nb = nb[_seen(fam[nb], p[i])]
        if not len(nb):
            continue
        delta = imgs[nb] - p[i]
        hj = h[owner[nb]]
        hij = mean(h[i], hj)
        same = own(h[i], hj)
        if walls:  # spacings more than WALL_H apart: the smaller spacing, and no mirror image
            hij = np.where(same, hij, np.minimum(h[i], hj))
        step[i], ok = terms(delta, hij)
        if mirror and not np.isnan(wall[i, 0]):
            n = normal[i]
            D = (p[i] - wall[i]) @ n
            w0 = np.array([-n[1], n[0]])
            s = WALL_GLIDE * h[i] * (-1.0 if w0 @ (0.5 - p[i]) < 0 else 1.0)
            up = np.sign(s) * (w0[1] if n[1] == 0 else w0[0])  # the glide's way along the segment's axis
            if not wall_glides or (n[0] != 0 and n[1] != 0) or run[i, int(up > 0)] < abs(s):
                # a plain mirror: the images of its own side's pairs across the wall's line, and its own
                e = delta @ n + D
                keep = ok & same & (e > 0)
                img = delta[keep] - 2.0 * e[keep][:, None] * n
                mine = np.vstack([img, -2.0 * D * n[None, :]])
                step[i] += terms(mine, np.append(hij[keep], h[i]))[0]
                continue
            # a glide mirror: the images of its own side's points (itself too) across the wall's
            # line, shifted along it by s (-n_y, n_x), s = +-WALL_GLIDE h towards the square's
            # middle, where its segment runs on for that long; their points lie within reach of
            # x_i + s (-n_y, n_x)
            src = np.asarray(tree.query_ball_point(p[i] + s * w0, reach[i]), dtype=np.int64)
            src = src[_seen(fam[src], p[i])]
            t = imgs[src] - p[i]
            hs = h[owner[src]]
            e = t @ n + D
            keep = own(h[i], hs) & (e > 0)
            img = t[keep] - 2.0 * e[keep][:, None] * n - s * w0
            step[i] += terms(img, mean(h[i], hs[keep]))[0]
    new = p + step
    new = np.where(new < 0, -new, np.where(new >= 1, 2.0 - new, new))
    inside = np.all((new >= 0) & (new < 1), axis=1)
    nc = np.clip(new, 0, np.nextafter(1.0, 0))
    hn = hcell[cell_of(nc[:, 1], Hc), cell_of(nc[:, 0], Wc)].astype(np.float64)
    if walls:
        ok = inside & (hn * np.sqrt(WALL) >= h) & (hn <= h * np.sqrt(WALL))
    else:
        ok = inside & (hn > 0)
    return np.where(ok[:, None], new, p)


def generate(
    model_path,
    density,
    m: int,
    seed: int = 0,
    *,
    pair: str = "harmonic",
    walls: bool = True,
    mirror: bool = True,
    glides: bool = True,
    wall_glides: bool = True,
):
    """The points of dpc_generate_density in float64, with the design's choices as options
    (mirror: walls are mirrors, as well as stopping steps; glides: the sides' images glide;
    wall_glides: so do those of long straight walls)."""
    model = dpc.load(model_path)
    spec = read_model(dpc.model_path(model_path))
    p = input_points(model, density, seed, m)
    hcell = spacing_grid(density, m)
    segs = wall_segments(hcell) if walls and mirror else None
    for spec_layer in spec.layers:
        p = layer(p, hcell, spec_layer, pair, walls, segs, glides, wall_glides)
    return p
