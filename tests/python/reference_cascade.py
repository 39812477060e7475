"""Independent float64 reference of the dpc model format (docs/model-format.md, §3 and §5).

This module deliberately shares no code with libdpc or with ``python/dpc``: it reads model files
with the ``onnx`` package directly, generates the input points with numpy uint64 arithmetic and
runs the cascade of PointFilter layers (paper Eq. 3–4 with the normalised sum of Fig. 7) in
float64 with dense pairwise differences. It is slow (O(m²) per subspace) and meant for test-sized
point sets only.

    model = load_reference("tests/data/model_2d.onnx")
    x0 = initial_points(model, seed=3, m=model.n_points)   # float32, bit-exact with dpc.uniform
    y = run_cascade(model, x0)                              # float64, in [0, 1)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

DOMAIN = "ai.dpc"
DEFAULT_EPS = 1e-4

_U64 = np.uint64
_GOLDEN = _U64(0x9E3779B97F4A7C15)
_MIX1 = _U64(0xBF58476D1CE4E5B9)
_MIX2 = _U64(0x94D049BB133111EB)


# ------------------------------------------------------------------------------------------------
# Model reading (onnx, not libdpc and not dpc.model_file)
# ------------------------------------------------------------------------------------------------


@dataclass
class RefLayer:
    subspaces: list[int]  # bitmask per subspace
    radius: list[float]  # rho_t, in units of the mean spacing h_t
    kernels: np.ndarray  # float64 [s, b] (the file's float32 values, widened exactly)
    eps: float = DEFAULT_EPS
    fixed: int = 0


@dataclass
class RefModel:
    dims: int
    n_points: int
    layers: list[RefLayer]
    grid_axes: list[int] = field(default_factory=list)
    grid_shape: list[int] = field(default_factory=list)
    metadata: dict[str, str] = field(default_factory=dict)


def load_reference(path) -> RefModel:
    """Parse a dpc model file with ``onnx`` and check the parts of §1–§4 the reference relies on."""
    import onnx
    from onnx import numpy_helper

    proto = onnx.load(str(Path(path)))
    versions = {o.domain: o.version for o in proto.opset_import}
    if versions.get(DOMAIN) != 1:
        raise ValueError(f"{path}: ai.dpc opset version {versions.get(DOMAIN)}, expected 1")
    meta = {p.key: p.value for p in proto.metadata_props}
    dims = int(meta["dpc.dims"])
    n_points = int(meta["dpc.n_points"])
    inits = {t.name: numpy_helper.to_array(t) for t in proto.graph.initializer}

    layers = []
    prev = proto.graph.input[0].name
    for node in proto.graph.node:
        if node.domain != DOMAIN or node.op_type != "PointFilter":
            raise ValueError(f"unexpected node {node.domain}:{node.op_type}")
        if node.input[0] != prev:
            raise ValueError("PointFilter nodes do not form a chain")
        prev = node.output[0]
        attrs = {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}
        kern = np.asarray(inits[node.input[1]])
        if kern.dtype != np.float32:
            raise ValueError("kernels must be FLOAT")
        subspaces = [int(v) for v in attrs["subspaces"]]
        radius = [float(v) for v in attrs["radius"]]
        if kern.ndim != 2 or kern.shape[0] != len(subspaces) or len(radius) != len(subspaces):
            raise ValueError("kernels / subspaces / radius shapes disagree")
        layers.append(
            RefLayer(
                subspaces=subspaces,
                radius=radius,
                kernels=kern.astype(np.float64),
                eps=float(attrs.get("eps", DEFAULT_EPS)),
                fixed=int(attrs.get("fixed", 0)),
            )
        )
    if prev != proto.graph.output[0].name:
        raise ValueError("the last PointFilter does not produce the graph output")

    axes = [int(a) for a in meta.get("dpc.grid_axes", "").split(",") if a.strip()]
    shape = [int(g) for g in meta.get("dpc.grid_shape", "").split(",") if g.strip()]
    return RefModel(dims=dims, n_points=n_points, layers=layers, grid_axes=axes, grid_shape=shape, metadata=meta)


# ------------------------------------------------------------------------------------------------
# Input points (§5)
# ------------------------------------------------------------------------------------------------


def _mix(z: np.ndarray) -> np.ndarray:
    """The SplitMix64 finaliser on a uint64 array (numpy uint64 arithmetic wraps mod 2^64)."""
    z = (z ^ (z >> _U64(30))) * _MIX1
    z = (z ^ (z >> _U64(27))) * _MIX2
    return z ^ (z >> _U64(31))


def splitmix_values(seed: int, count: int) -> np.ndarray:
    """Values 0 .. count-1 of the stream of seed: mix(mix(seed) + (c + 1) * golden)."""
    with np.errstate(over="ignore"):
        state0 = _mix(np.array([int(seed) % (1 << 64)], dtype=_U64))[0]
        c1 = np.arange(1, count + 1, dtype=_U64)
        return _mix(state0 + c1 * _GOLDEN)


def uniform(seed: int, m: int, n: int) -> np.ndarray:
    """(m, n) float32: value (i*n + k) >> 40, times 2^-24 (exact in float32)."""
    top24 = (splitmix_values(seed, m * n) >> _U64(40)).astype(np.float64)
    return (top24 * 2.0**-24).astype(np.float32).reshape(m, n)


def grid_fill(x: np.ndarray, axes: list[int], shape: list[int]) -> np.ndarray:
    """Overwrite the gridded dimensions with cell centres; the first axis varies fastest."""
    x = np.array(x, copy=True)
    i = np.arange(x.shape[0], dtype=np.int64)
    stride = 1
    for a, g in zip(axes, shape):
        cell = (i // stride) % g
        x[:, a] = ((cell + 0.5) / g).astype(x.dtype)
        stride *= g
    return x


def initial_points(model: RefModel, seed: int, m: int) -> np.ndarray:
    """The float32 points dpc_generate_n(model, seed, m) filters."""
    x = uniform(seed, m, model.dims)
    if model.grid_axes:
        x = grid_fill(x, model.grid_axes, model.grid_shape)
    return x


# ------------------------------------------------------------------------------------------------
# The cascade (§3)
# ------------------------------------------------------------------------------------------------


def toroidal_delta(a: np.ndarray) -> np.ndarray:
    """delta - floor(delta + 1/2): the per-axis toroidal difference, in [-1/2, 1/2)."""
    return a - np.floor(a + 0.5)


def filter_layer(x: np.ndarray, layer: RefLayer, chunk: int = 256) -> np.ndarray:
    """One PointFilter in float64: x (m, n) in [0, 1) -> y (m, n) in [0, 1).

    Dense over all pairs, in chunks of ``chunk`` rows i: the toroidal differences of a chunk are
    computed once for every dimension and shared by the subspaces."""
    x = np.asarray(x, dtype=np.float64)
    m, n = x.shape
    subs = []
    for t, mask in enumerate(layer.subspaces):
        dims = [k for k in range(n) if (mask >> k) & 1]
        h = float(m) ** (-1.0 / len(dims))  # mean spacing h_t = m^(-1/k_t)
        r = min(layer.radius[t] * h, 0.5)  # receptive radius r_t
        e = layer.eps * h  # cut-off e_t
        subs.append((dims, h, r, e, layer.kernels[t]))

    total = np.zeros((m, n), dtype=np.float64)  # sum over subspaces of Delta_i^t[k]
    xt = np.ascontiguousarray(x.T)  # (n, m)
    for i0 in range(0, m, chunk):
        i1 = min(i0 + chunk, m)
        delta = xt[:, None, :] - xt[:, i0:i1, None]  # (n, c, m): x_jk - x_ik
        tmp = delta + 0.5
        np.floor(tmp, out=tmp)
        delta -= tmp  # toroidal difference, in [-1/2, 1/2)
        del tmp
        for dims, h, r, e, w in subs:
            d2 = delta[dims[0]] ** 2
            for k in dims[1:]:
                d2 += delta[k] ** 2
            d = np.sqrt(d2)
            ci, j = np.nonzero((d > e) & (d < r))
            if ci.size == 0:
                continue
            dd = d[ci, j]
            b = w.shape[0]
            u = dd * (b - 1) / r
            q = np.minimum(np.floor(u), b - 2).astype(np.int64)
            f = u - q
            g = w[q] + f * (w[q + 1] - w[q])  # linear interpolation of the kernel
            coef = h * g / dd
            rows = i0 + ci
            for k in dims:
                total[:, k] += np.bincount(rows, weights=coef * delta[k][ci, j], minlength=m)

    count = np.zeros(n, dtype=np.int64)  # c_k: subspaces containing dimension k
    for dims, *_ in subs:
        count[dims] += 1
    y = x.copy()
    for k in range(n):
        if count[k] > 0 and not (layer.fixed >> k) & 1:
            y[:, k] += total[:, k] / count[k]  # normalised sum
    y -= np.floor(y)  # wrap to [0, 1)
    y[y >= 1.0] = 0.0
    return y


def run_cascade(model: RefModel, x: np.ndarray, layers: int | None = None) -> np.ndarray:
    """All layers (or the first ``layers``) on x (m, n): float64 result."""
    y = np.asarray(x, dtype=np.float64)
    if y.ndim != 2 or y.shape[1] != model.dims:
        raise ValueError(f"points must be (m, {model.dims})")
    for layer in model.layers[:layers]:
        y = filter_layer(y, layer)
    return y


def generate(model: RefModel, seed: int, m: int | None = None) -> np.ndarray:
    """Reference of dpc_generate_n: the cascade on initial_points(seed, m), float64."""
    m = model.n_points if m is None else int(m)
    return run_cascade(model, initial_points(model, seed, m))


def generate_progressive(model: RefModel, seed: int, m: int, base: int, radius: int = 0, relax: int = 0) -> np.ndarray:
    """Reference of dpc_generate_n for a progressive model (§6): a set of min(m, base) points,
    then levels that add min(n, m - n) input points of seed + level * golden to the n so far and
    run every layer on all of them, the first n put back after each layer. With a balance radius
    (§5.1) each level ends with the balance of its prefix, only the level's own points moving
    (float32 in between, as libdpc). With relax steps (§6.1) the levels' float32 points are then
    relaxed jointly. Last, every level is put in its order (order_levels, on the float32 points
    as libdpc)."""
    n = min(m, base)
    y = run_cascade(model, initial_points(model, seed, n))
    if radius:
        y = balance(y.astype(np.float32), radius).astype(np.float32).astype(np.float64)
    level = 1
    while n < m:
        add = min(n, m - n)
        level_seed = (seed + level * int(_GOLDEN)) % (1 << 64)
        x = np.concatenate([y, initial_points(model, level_seed, add).astype(np.float64)])
        for layer in model.layers:
            z = filter_layer(x, layer)
            z[:n] = x[:n]
            x = z
        if radius:
            x = balance(x.astype(np.float32), radius, first=n).astype(np.float32).astype(np.float64)
        y, n, level = x, n + add, level + 1
    if relax:
        y = relax_prefixes(y.astype(np.float32), relax, base)
    return order_levels(y.astype(np.float32), base)


def balance_frequencies(k: int, n: int) -> np.ndarray:
    """The integer q in n dimensions with 0 < |q|^2 <= k^2 and first nonzero component > 0."""
    import itertools

    qs = [q for q in itertools.product(range(-k, k + 1), repeat=n) if 0 < sum(v * v for v in q) <= k * k]
    return np.array([q for q in qs if q[next(i for i, v in enumerate(q) if v)] > 0], dtype=np.float64).reshape(-1, n)


def balance(x: np.ndarray, radius: int, steps: int | None = None, first: int = 0) -> np.ndarray:
    """The output balance (§5.1) in float64: K = min(radius, the largest j with (4 j)^n <= m);
    each step moves every point from index ``first`` on by sum_q q Im(c_q exp(2 pi i q.x)) /
    (pi |q|^2 (m - first)), with c_q = sum_j exp(-2 pi i q.x_j) over all m points before the step;
    3 steps, 8 when only some points move (first > 0: slower, the cross terms are larger)."""
    y = np.array(x, dtype=np.float64)
    m, n = y.shape
    k = 0
    while k < radius and (4 * (k + 1)) ** n <= m:
        k += 1
    if k == 0:
        return y
    q = balance_frequencies(k, n)
    w = 1.0 / (np.pi * (q * q).sum(1) * (m - first))
    for _ in range(steps or (8 if first else 3)):  # libdpc: 3 steps, 8 when only some points move
        z = np.exp(2j * np.pi * (y @ q.T))  # (m, F)
        c = np.conj(z).sum(0)
        y[first:] = (y[first:] + (np.imag(c[None, :] * z[first:]) * w[None, :]) @ q) % 1.0
    return y


def torus_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per-coordinate distance on the unit torus: |a - b| with 0.999… and 0.000… close."""
    d = np.abs(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64))
    return np.minimum(d, 1.0 - d)


def _relax_low_frequencies(radius: float) -> np.ndarray:
    """Integer frequencies of a half-plane with 0 < |q| <= radius."""
    r = int(radius)
    a, b = np.meshgrid(np.arange(-r, r + 1), np.arange(0, r + 1), indexing="ij")
    q = np.stack([a.ravel(), b.ravel()], 1).astype(np.float64)
    keep = ((q[:, 1] > 0) | (q[:, 0] > 0)) & ((q * q).sum(1) <= radius * radius)
    return q[keep]


def relax_prefixes(points: np.ndarray, steps: int, base: int) -> np.ndarray:
    """The prefix relaxation (§6.1) in float64, with scipy's k-d tree for the neighbour pairs:
    over the prefixes P of base * 2^j < m points and all m, ``steps`` steps of
    x += 0.1 (1 - 0.8 t / steps) F, F_i = sum_P sum_{j in P, pair within R_P + 0.4 s_P at the
    last search} d max(0, G(d) - G(R_P)) + sum_P (0.2 pi / |P|) sum_q Im(conj(c_q(P)) e_q(x_i))
    q / |q|^2, d = x_i - x_j (toroidal), G(d) = exp(-|d|^2 / (2 s_P^2)), s_P = 0.85 / sqrt(|P|)
    (0.60 / sqrt(m) for all m), R_P = min(3.5 s_P, 1/2), q over 0 < |q| <= min(8, sqrt(|P|) / 4)
    of a half-plane, pairs searched every 10 steps."""
    from scipy.spatial import cKDTree

    x = np.array(points, dtype=np.float64)
    m = len(x)
    sizes = [base << j for j in range(m.bit_length()) if base << j < m] + [m]
    widths = {n: (0.60 if n == m else 0.85) / np.sqrt(n) for n in sizes}
    support = {n: min(3.5 * widths[n], 0.5) for n in sizes}
    cut = {n: np.exp(-(support[n] ** 2) / (2 * widths[n] ** 2)) for n in sizes}
    lows = {n: _relax_low_frequencies(min(8, np.sqrt(n) / 4)) for n in sizes}
    pairs: dict[int, np.ndarray] = {}
    for step in range(steps):
        if step % 10 == 0:
            for n in sizes:
                reach = min(support[n] + 0.4 * widths[n], 0.7072)
                pairs[n] = cKDTree(x[:n], boxsize=1.0).query_pairs(reach, output_type="ndarray")
        force = np.zeros_like(x)
        for n in sizes:
            i, j = pairs[n][:, 0], pairs[n][:, 1]
            d = x[i] - x[j]
            d -= np.round(d)
            g = np.maximum(np.exp(-(d * d).sum(1) / (2 * widths[n] ** 2)) - cut[n], 0.0)
            t = d * g[:, None]
            for k in range(2):
                force[:, k] += np.bincount(i, t[:, k], m) - np.bincount(j, t[:, k], m)
            q = lows[n]
            if len(q):
                e = np.exp(2j * np.pi * (x[:n] @ q.T))  # (n, F)
                force[:n] += (0.05 * 4 * np.pi / n) * (np.imag(np.conj(e.sum(0)) * e) @ (q / (q * q).sum(1)[:, None]))
        x = (x + 0.1 * (1 - 0.8 * step / steps) * force) % 1.0
        x[x >= 1.0] = 0.0  # (x % 1.0) rounds a tiny negative x up to 1.0
    return x


def order_level(x: np.ndarray, n: int, a: int) -> np.ndarray:
    """The order within a progressive level (§6) of x[n : n + a] after the held x[:n], as the
    indices 0 .. a-1 of the level's points in picking order. Energy of a point: the sum of b over
    the held points (in index order), then over the picks before it (in picking order),
    b = (1 - d^2 / R^2)^3 within R (else 0), d^2 the toroidal squared distance summed over the
    coordinates in order, R^2 = min((2 r)^2, 1/4), r = (n + a)^(-1/dims) by 64 halvings. Quota:
    cells of depth t split the first two coordinates (one in 1-D) into 2^t parts each; D is the
    largest depth whose cells number at most a / 8. Each pick starts at the whole torus and, at
    depths 1 .. D, enters the child cell (among those with unpicked points) of the largest
    (picks in the parent + 1) * (points in the child) - (picks in the child) * (points in the
    parent), ties to the child whose least (energy, index) unpicked point is least; in the last
    cell it picks that point. +, -, *, / and exact cells only, so libdpc's order is this one
    exactly (no shortcut here: the reference reads as the rule)."""
    y = np.asarray(x, dtype=np.float64)
    dims = y.shape[1]
    lo, hi = 0.0, 1.0
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        p = mid
        for _ in range(dims - 1):
            p *= mid
        lo, hi = (lo, mid) if p * float(n + a) >= 1.0 else (mid, hi)
    r2 = min((2.0 * hi) ** 2, 0.25)
    level = y[n : n + a]
    split = min(dims, 2)
    depth = 0
    while 8 << (split * (depth + 1)) <= a:
        depth += 1

    def cells(t: int) -> np.ndarray:  # a cell id per point at depth t
        c = np.minimum(np.floor(level[:, :split] * 2.0**t), 2**t - 1).astype(np.int64)
        return c[:, 0] * (2**t) + (c[:, 1] if split == 2 else 0)

    cell = [cells(t) for t in range(depth + 1)]

    def bump(p: np.ndarray) -> np.ndarray:
        d2 = None
        for k in range(dims):
            d = level[:, k] - p[k]
            d = np.where(d > 0.5, d - 1.0, np.where(d < -0.5, d + 1.0, d))
            d2 = d * d if d2 is None else d2 + d * d
        t = 1.0 - d2 / r2
        return np.where(d2 < r2, t * t * t, 0.0)

    def least(mask: np.ndarray) -> tuple[float, int]:  # least (energy, index) among mask
        idx = np.flatnonzero(mask)
        k = int(np.argmin(e[idx]))  # argmin: the first of equal minima, the lowest index
        return float(e[idx[k]]), int(idx[k])

    e = np.zeros(a)
    for j in range(n):
        e = e + bump(y[j])
    picked = np.zeros(a, dtype=bool)
    order = []
    for _ in range(a):
        inside = np.ones(a, dtype=bool)  # the current cell's points
        for t in range(1, depth + 1):
            n_parent, k_parent = int(inside.sum()), int((inside & picked).sum())
            best = None
            for child in np.unique(cell[t][inside & ~picked]):
                members = inside & (cell[t] == child)
                deficit = (k_parent + 1) * int(members.sum()) - int((members & picked).sum()) * n_parent
                key = (-deficit, *least(members & ~picked))
                if best is None or key < best[0]:
                    best = (key, members)
            inside = best[1]
        i = least(inside & ~picked)[1]
        order.append(i)
        picked[i] = True
        e = np.where(picked, e, e + bump(level[i]))
    return np.array(order, dtype=np.int64)


def levels(m: int, base: int) -> list[tuple[int, int]]:
    """(start, count) of each level of a progressive set of m points (§6): the first min(m, base)
    points, then blocks of min(n, m - n) after the first n."""
    out = [(0, min(m, base))]
    while sum(out[-1]) < m:
        n = sum(out[-1])
        out.append((n, min(n, m - n)))
    return out


def order_levels(x: np.ndarray, base: int) -> np.ndarray:
    """Every level of the ordered set x reordered by order_level (§6), the first level first."""
    y = np.array(x, dtype=np.float64)
    for n, a in levels(len(y), base):
        y[n : n + a] = y[n : n + a][order_level(y, n, a)]
    return y
