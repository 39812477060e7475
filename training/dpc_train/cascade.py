"""The filter cascade (paper Sec. 5): l layers whose kernel tables are interpolated across depth
from l_u unique kernels, subspaces with scale-aware radii, optional gridded dimensions.

The parameters are exactly what a model file stores after expansion: per layer, an [s, b] table
(docs/model-format.md §2), the subspace masks, radii ρ_t, eps and the fixed mask.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch

from .filter import FilterConfigError, NeighbourCache, check_layer, filter_layer

AXES = "xyzwabcdefghijklmnopqrstuv"


def parse_subspace(spec, n: int) -> int:
    """A swizzle ("xz"), a list of dims ([0, 2]) or an int mask → bitmask (checked against n)."""
    if isinstance(spec, int):
        mask = spec
    elif isinstance(spec, str):
        mask = 0
        for c in spec:
            if c not in AXES:
                raise FilterConfigError(f"unknown axis letter {c!r} in subspace {spec!r}")
            mask |= 1 << AXES.index(c)
    else:
        mask = 0
        for k in spec:
            mask |= 1 << int(k)
    if mask <= 0 or mask >> n:
        raise FilterConfigError(f"subspace {spec!r} is empty or uses dims >= n = {n}")
    return mask


@dataclass
class CascadeSpec:
    """Architecture of a cascade (everything but the learned kernel values)."""

    dims: int
    n_points: int
    layers: int = 32
    unique_kernels: int = 8
    bins: int = 32
    subspaces: list = field(default_factory=lambda: ["xy"])
    radius: list = field(default_factory=lambda: [4.0])
    eps: float = 1e-4
    grid_axes: list = field(default_factory=list)
    grid_shape: list = field(default_factory=list)
    init: str = "zero"  # "zero" (identity cascade), "repulsion", or "model" (init_model's kernels)
    init_model: str = ""  # init = "model": a bundled model's name or a model file path
    init_sigma: float = 0.85  # repulsion: Gaussian width, in mean spacings
    init_amplitude: float = 0.05  # repulsion: kernel value at d = 0 (units of spacing)
    input: str = "uniform"  # training inputs: "uniform" or "stratified" (format §5)
    order: str = "set"  # "set", or "progressive": generated level by level (format §6)
    progressive_base: int = 16  # progressive: the first level's point count
    # every table ends at 0 at the radius (its last bin held at 0): the filter is continuous at
    # r, so a pair crossing r moves its points by a little, not a jump that float32 rounding of
    # d can switch on or off (docs/training.md, "Kernels continuous at r")
    continuous: bool = False
    # > 0: every table value at distance d (in spacings) is at most max_attraction * d, so an
    # isolated pair closes at most 2 * max_attraction of its gap in a layer. Without it a kernel
    # with g(d) = d / 2 makes a pair at that distance meet exactly, inside eps * h, where no later
    # layer sees it (bnot-10d: 1 set in ~3,000; docs/training.md §2). 0: no limit.
    max_attraction: float = 0.0
    # > 0: the generator's output balance radius (metadata dpc.balance, format §5.1): after the
    # cascade, libdpc cancels each set's power at the integer frequencies 0 < |q| <= balance.
    # Not part of training: the loss sees the cascade's output.
    balance: int = 0

    def __post_init__(self):
        if not 1 <= self.dims <= 64:
            raise FilterConfigError(f"dims must be in 1..64, got {self.dims}")
        if self.n_points < 2:
            raise FilterConfigError(f"n_points must be >= 2, got {self.n_points}")
        if self.layers < 1 or not 1 <= self.unique_kernels <= self.layers:
            raise FilterConfigError(
                f"need layers >= 1 and 1 <= unique_kernels <= layers, got layers={self.layers},"
                f" unique_kernels={self.unique_kernels}"
            )
        if not 2 <= self.bins <= 65536:
            raise FilterConfigError(f"bins must be in 2..65536, got {self.bins}")
        self.masks = [parse_subspace(s, self.dims) for s in self.subspaces]
        if len(self.radius) != len(self.masks):
            raise FilterConfigError(f"radius needs one value per subspace ({len(self.masks)}), got {len(self.radius)}")
        if len(self.grid_axes) != len(self.grid_shape):
            raise FilterConfigError("grid_axes and grid_shape must have the same length")
        if self.grid_axes:
            if sorted(set(self.grid_axes)) != list(self.grid_axes) or max(self.grid_axes) >= self.dims:
                raise FilterConfigError(f"grid_axes must be increasing dims < {self.dims}")
            if math.prod(self.grid_shape) != self.n_points:
                raise FilterConfigError(
                    f"prod(grid_shape) = {math.prod(self.grid_shape)} must equal n_points = {self.n_points}"
                )
        if self.init not in ("zero", "repulsion", "model"):
            raise FilterConfigError(f"init must be 'zero', 'repulsion' or 'model', got {self.init!r}")
        if (self.init == "model") != bool(self.init_model):
            raise FilterConfigError("init = 'model' goes with init_model (a model name or file), and only it")
        if self.input not in ("uniform", "stratified"):
            raise FilterConfigError(f"input must be 'uniform' or 'stratified', got {self.input!r}")
        if self.input == "stratified" and self.grid_axes:
            raise FilterConfigError("stratified input is for patterns without grid axes")
        if not (self.max_attraction >= 0 and math.isfinite(self.max_attraction)):
            raise FilterConfigError(f"max_attraction must be finite and >= 0, got {self.max_attraction}")
        if self.order not in ("set", "progressive"):
            raise FilterConfigError(f"order must be 'set' or 'progressive', got {self.order!r}")
        if self.order == "progressive" and (self.grid_axes or not 1 <= self.progressive_base <= self.n_points):
            raise FilterConfigError("a progressive cascade has no grid axes and 1 <= progressive_base <= n_points")
        if isinstance(self.balance, bool) or not (isinstance(self.balance, int) and 0 <= self.balance <= 32):
            raise FilterConfigError(f"balance must be an integer radius in 0..32, got {self.balance!r}")
        if self.balance and self.grid_axes:
            raise FilterConfigError("balance is for models without grid axes (sets, or progressive levels)")
        check_layer(self.dims, torch.zeros(len(self.masks), self.bins), self.masks, self.radius, self.eps, self.fixed)

    @property
    def fixed(self) -> int:
        return sum(1 << a for a in self.grid_axes)


# SplitMix64's increment: level j >= 1 of a progressive set of seed s takes its new input points
# from seed s + j * GOLDEN (mod 2^64), docs/model-format.md §6.
GOLDEN = 0x9E3779B97F4A7C15


def progressive_levels(m: int, base: int) -> list[tuple[int, int]]:
    """(start, count) of each level of a progressive set of m points (format §6): the first
    min(m, base) points, then each level doubles the set (the last one stops at m). The first n
    points of a set of m are the set of n for every level size n = base * 2^j <= m."""
    levels = [(0, min(m, base))]
    n = levels[0][1]
    while n < m:
        a = min(n, m - n)
        levels.append((n, a))
        n += a
    return levels


def repulsion_kernel(bins: int, rho: float, sigma: float, amplitude: float) -> torch.Tensor:
    """Table of g(d) = −A·exp(−d²/2σ²) at the bin distances d_q = q·ρ/(b−1) (spacing units).

    A local Gaussian repulsion (docs/architecture.md, "A quick study the design started from"):
    applied a few dozen times from uniform points it already removes most low-frequency energy,
    so it is a far better start than zero.
    """
    d = torch.arange(bins, dtype=torch.float64) * (rho / (bins - 1))
    return -amplitude * torch.exp(-0.5 * (d / sigma) ** 2)


class Cascade(torch.nn.Module):
    """l filter layers from l_u unique [s, b] kernels, linearly interpolated across depth."""

    def __init__(self, spec: CascadeSpec, initialise: bool = True):
        """initialise = False: zero kernels, for a caller that loads trained ones next."""
        super().__init__()
        self.spec = spec
        s, b = len(spec.masks), spec.bins
        theta = torch.zeros(spec.unique_kernels, s, b, dtype=torch.float64)
        if spec.init == "repulsion":
            for t, rho in enumerate(spec.radius):
                theta[:, t] = repulsion_kernel(b, rho, spec.init_sigma, spec.init_amplitude)
        self.theta = torch.nn.Parameter(theta.float())
        if spec.init == "model" and initialise:
            with torch.no_grad():
                self.theta.copy_(self._kernels_of(spec.init_model))

    def _kernels_of(self, name: str) -> torch.Tensor:
        """The unique kernels whose interpolation gives a model file's layer tables (exactly, for a
        file trained with this architecture: least squares over the interpolation otherwise)."""
        import dpc
        from dpc.model_file import read_model

        path = name if name.endswith(".onnx") else dpc.model_path(name)
        f = read_model(path)
        sp = self.spec
        same = f.dims == sp.dims and len(f.layers) == sp.layers
        same = same and all(L.subspaces == sp.masks and list(L.radius) == sp.radius for L in f.layers)
        if not same or f.layers[0].kernels.shape != (len(sp.masks), sp.bins):
            raise FilterConfigError(f"init_model {name}: its architecture differs from this config's [model]")
        lo, hi, frac = self.layer_weights()
        interp = torch.zeros(sp.layers, sp.unique_kernels, dtype=torch.float64)
        interp[torch.arange(sp.layers), lo] += 1 - frac
        interp[torch.arange(sp.layers), hi] += frac
        tables = torch.from_numpy(np.stack([L.kernels for L in f.layers]).astype(np.float64)).reshape(sp.layers, -1)
        theta = torch.linalg.lstsq(interp, tables).solution
        return theta.reshape(sp.unique_kernels, len(sp.masks), sp.bins).float()

    def layer_weights(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(lo, hi, frac): layer i uses (1−frac[i])·θ[lo[i]] + frac[i]·θ[hi[i]]."""
        lu, n_layers = self.spec.unique_kernels, self.spec.layers
        pos = torch.arange(n_layers, dtype=torch.float64) * ((lu - 1) / (n_layers - 1) if n_layers > 1 else 0.0)
        lo = torch.clamp(torch.floor(pos).long(), max=lu - 1)
        hi = torch.clamp(lo + 1, max=lu - 1)
        return lo, hi, pos - lo.double()

    def tables(self) -> torch.Tensor:
        """Per-layer kernel tables [l, s, b] (the values a model file stores)."""
        lo, hi, frac = self.layer_weights()
        f = frac.to(self.theta)[:, None, None]
        tabs = (1 - f) * self.theta[lo] + f * self.theta[hi]
        if self.spec.continuous:
            tabs = torch.cat([tabs[..., :-1], torch.zeros_like(tabs[..., -1:])], dim=-1)
        if self.spec.max_attraction > 0:
            b = self.spec.bins
            d = torch.stack([torch.arange(b, dtype=torch.float64) * (rho / (b - 1)) for rho in self.spec.radius])
            tabs = torch.minimum(tabs, (self.spec.max_attraction * d).to(tabs))
        return tabs

    def forward(self, x: torch.Tensor, impl: str = "torch", return_all: bool = False, skin: float | None = 1.0):
        """Run all layers. skin (in spacings): reuse neighbour lists across layers while points
        move less than skin/2 (NeighbourCache; same result); None searches afresh per layer."""
        sp = self.spec
        tabs = self.tables().to(x.dtype)
        if sp.order == "progressive":
            if return_all:
                raise FilterConfigError("return_all is for set cascades")
            # level by level: the points of earlier levels are neighbours that never move. The
            # gradient stops at them: each level learns to insert points into the set it is
            # given (through all levels the gradient compounds and Adam's steps overshot:
            # docs/training.md §2)
            y = x[..., :0, :]
            for start, count in progressive_levels(x.shape[-2], sp.progressive_base):
                level = torch.cat([y.detach(), x[..., start : start + count, :]], dim=-2)
                y = self._run(level, tabs, impl, skin, start)
            return y
        return self._run(x, tabs, impl, skin, 0, return_all)

    def _run(self, x, tabs, impl, skin, frozen: int, return_all: bool = False):
        """All layers on x; the first `frozen` points stay where they are."""
        sp = self.spec
        cache = NeighbourCache(sp.masks, sp.radius, skin) if skin is not None else None
        outs = []
        for i in range(sp.layers):
            y = filter_layer(x, tabs[i], sp.masks, sp.radius, sp.eps, sp.fixed, impl=impl, cache=cache)
            x = torch.cat([x[..., :frozen, :], y[..., frozen:, :]], dim=-2) if frozen else y
            if return_all:
                outs.append(x)
        return outs if return_all else x

    def input_points(
        self, batch: int, generator: torch.Generator, m: int | None = None, dtype=torch.float32, device="cpu"
    ) -> torch.Tensor:
        """[batch, m, n] input points: uniform random, gridded dims set to cell centres, or for
        input = "stratified" libdpc's stratified points (format §5) of seeds drawn from the
        generator, so a model trained on them sees what dpc.load(..., input="stratified") feeds it."""
        sp = self.spec
        m = sp.n_points if m is None else m
        if sp.input == "stratified" or sp.order == "progressive":
            import dpc  # libdpc's generators, not copies of them

            make = dpc.stratified if sp.input == "stratified" else dpc.uniform
            seeds = torch.randint(0, 1 << 62, (batch,), generator=generator).tolist()
            if sp.order == "progressive":  # each level's new points from the level's seed (format §6)
                levels = progressive_levels(m, sp.progressive_base)
                sets = [
                    np.concatenate([make((s + j * GOLDEN) % (1 << 64), a, sp.dims) for j, (_, a) in enumerate(levels)])
                    for s in seeds
                ]
            else:
                sets = [make(s, m, sp.dims) for s in seeds]
            x = torch.from_numpy(np.stack(sets)).double()
            return x.to(dtype=dtype, device=device)
        x = torch.rand(batch, m, sp.dims, generator=generator, dtype=torch.float64)
        if sp.grid_axes:
            if m != sp.n_points:
                raise FilterConfigError("a gridded cascade runs at its trained point count only")
            idx = torch.arange(m)
            div = 1
            for a, gsz in zip(sp.grid_axes, sp.grid_shape):
                x[:, :, a] = (((idx // div) % gsz).double() + 0.5) / gsz
                div *= gsz
        return x.to(dtype=dtype, device=device)
