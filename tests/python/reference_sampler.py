"""An independent transcription of the sampler definition in docs/rendering.md ("Definition"),
in numpy, from public pieces only: the models' scalar-path point sets (``dpc.load(...,
isa="scalar").generate``) and the published 32 x 32 mask (``dpc.Sampler.mask()``). The tests
compare libdpc's dpc_sampler_get_1d / _get_2d with it bit for bit."""

from __future__ import annotations

import itertools

import numpy as np

import dpc

M64 = (1 << 64) - 1
GOLDEN = 0x9E3779B97F4A7C15
SET_STEP = 0xD1B54A32D192ED03
TILE = 32
SPIN = 0xBF58476D1CE4E5B9
HERO = 0x632BE59BD9B4E019  # the 1-D offsets of net slots: mix64(hash ^ HERO)
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


def in_stratum(s: int, n: int, u) -> np.float32:
    """Where a 1-D value of stratum s of n sits inside it: frac(u + k/4), k = floor(s gcd(n, 4) / n)."""
    g = 4 if n % 4 == 0 else (1 if n % 2 else 2)
    return wrap(u, F32(0.25) * F32((s * g) // n))


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


FRAME_ORDER = 0x632BE59BD9B4E019


def order_for_frames(table: np.ndarray, scramble: int) -> np.ndarray:
    """Frames: points by their cells' Morton codes (2^L x 2^L cells, 4^L >= n; x bit b at 2b),
    each code scrambled by nested(code, scramble), then bit-reversed over 2L bits; ties by position."""
    n = len(table)
    L = 0
    while 4**L < n:
        L += 1
    keys = []
    for i in range(n):
        code = 0
        for a in range(2):
            cell = (int(F32(table[i, a] * F32(n))) << L) // n
            for b in range(L):
                code |= ((cell >> b) & 1) << (2 * b + a)
        rev = reverse32(nested(code, scramble)) >> (32 - 2 * L) if L else 0
        keys.append((rev, i))
    return table[[i for _, i in sorted(keys)]]


NET_OPTIMISED = 64
NET_SWEEPS = 4
NET_SEED = 0x243F6A8885A308D3


def net_kernel(m: int) -> np.ndarray:
    """h(c): the mean over u of w(torus distance of u and u XOR c), w(e) = 65535 (Q - e^2)^4 / Q^4
    (integer division) for e^2 < Q, Q = 81 n / 50 (integer division); integer mean (>> m)."""
    n = 1 << m
    q = 81 * n // 50
    u = np.arange(n, dtype=np.int64)
    h = np.zeros(n, dtype=np.int64)
    for c in range(n):
        d = np.abs(u - (u ^ c))
        e = np.minimum(d, n - d)
        r = np.maximum(q - e * e, 0)
        h[c] = sum(int(v) ** 4 * 65535 // q**4 for v in r) >> m
    return h


def make_net(m: int, seed: int) -> np.ndarray:
    """The (n, 2) integer cells of a net slot (docs/rendering.md, "Net dimensions")."""
    n = 1 << m
    i = np.arange(n, dtype=np.int64)
    bx = np.zeros(n, dtype=np.int64)
    by = np.zeros(n, dtype=np.int64)
    v = 1 << (m - 1)
    for b in range(m):  # x: i's bits reversed; y: XOR of direction numbers v_b of i's set bits
        bx |= ((i >> b) & 1) << (m - 1 - b)
        by ^= np.where((i >> b) & 1, v, 0)
        v ^= v >> 1
    base = np.stack([bx, by], -1)
    p = base.copy()
    f = 0
    for c in range(2):
        for j in range(1, m):
            for pre in range(1 << j):
                f += 1
                if mix64(seed + f * GOLDEN) >> 63:
                    p[(base[:, c] >> (m - j)) == pre, c] ^= 1 << (m - 1 - j)
    if n <= NET_OPTIMISED and m >= 1:
        h = net_kernel(m)
        for _ in range(NET_SWEEPS):
            changed = False
            for j in range(1, m):
                for pre in range(1 << j):
                    for c in range(2):
                        o, bit = 1 - c, 1 << (m - 1 - j)
                        inside = (base[:, c] >> (m - j)) == pre
                        a, b = p[inside], p[~inside]
                        new = h[(a[:, None, c] ^ bit) ^ b[None, :, c]]
                        old = h[a[:, None, c] ^ b[None, :, c]]
                        if int(((new - old) * h[a[:, None, o] ^ b[None, :, o]]).sum()) < 0:
                            p[inside, c] ^= bit
                            changed = True
            if not changed:
                break
    return p


def net_values(cell, j: int, h: int, m: int) -> list:
    """Net point j's cell randomised by the pixel's hash h: swap (bit 32), XOR (bits 0.., 16..),
    offset inside the cell from g = (h XOR (j + 1) golden) * 0xD6E8FEB86659FD93 (bits 40.. for x,
    16.. for y)."""
    a, b = int(cell[0]), int(cell[1])
    if (h >> 32) & 1:
        a, b = b, a
    a ^= h & ((1 << m) - 1)
    b ^= (h >> 16) & ((1 << m) - 1)
    g = ((h ^ ((j + 1) * GOLDEN & M64)) * 0xD6E8FEB86659FD93) & M64
    shift = 24 - m
    low = (1 << shift) - 1
    return [
        F32((a << shift) | ((g >> 40) & low)) * F32(2.0**-24),
        F32((b << shift) | ((g >> 16) & low)) * F32(2.0**-24),
    ]


M32 = (1 << 32) - 1
PERM4 = list(itertools.permutations(range(4)))  # lexicographic
SCREEN_BELOW = 64


def reverse32(v: int) -> int:
    return int(f"{v & M32:032b}"[::-1], 2)


def nested(v: int, seed: int) -> int:
    """Laine and Karras's hash with Burley's constants: bit b of the result is bit b of v XOR a
    function of the bits below b and the seed."""
    v &= M32
    v ^= (v * 0x3D20ADEA) & M32
    v = (v + seed) & M32
    v = (v * ((seed >> 16) | 1)) & M32
    v ^= (v * 0x05526C56) & M32
    v ^= (v * 0x53A22864) & M32
    return v


def screen_code(kt: int, x: int, y: int) -> int:
    """The Morton code of tile place (x, y), its base-4 digits permuted from the top (kt: the
    tile's hash)."""
    code = 0
    for b in range(5):
        code |= ((x >> b) & 1) << (2 * b) | ((y >> b) & 1) << (2 * b + 1)
    out = 0
    for level in range(5):
        shift = 8 - 2 * level
        digit, prefix = (code >> shift) & 3, code >> (shift + 2)
        h = mix64(kt + ((((prefix << 3) | level) + 1) * GOLDEN))
        out |= PERM4[((h >> 32) * 24) >> 32][digit] << shift
    return out


def sobol1(i: int) -> int:
    """Sobol's second coordinate of i, 32 bits: v_0 = 2^31, v_b = v_(b-1) XOR v_(b-1) >> 1."""
    out, v = 0, 1 << 31
    for b in range(32):
        if (i >> b) & 1:
            out ^= v
        v ^= v >> 1
    return out


def sobol2(i: int) -> int:
    """Sobol's third coordinate of i, 32 bits, from its definition: primitive polynomial
    x^2 + x + 1, initial m_1 = 1, m_2 = 3, m_k = 2 m_(k-1) XOR 4 m_(k-2) XOR m_(k-2), direction
    number v_k = m_k / 2^k."""
    mk = [1, 3]
    while len(mk) < 32:
        mk.append((2 * mk[-1]) ^ (4 * mk[-2]) ^ mk[-2])
    out = 0
    for b in range(32):
        if (i >> b) & 1:
            out ^= (mk[b] << (31 - b)) & M32
    return out


def screen_index(kt: int, code: int, k: int, m: int) -> int:
    """Sample k's index in the tile's sequence: the block at code, k shuffled in it."""
    hp = mix64(kt ^ ((code << 1) | 1))
    return (code << m) | (reverse32(nested(reverse32(k) >> (32 - m), hp & M32)) >> (32 - m))


def screen_values(kt: int, code: int, k: int, m: int) -> list:
    i = screen_index(kt, code, k, m)
    hs = mix64(kt + GOLDEN)
    xs = reverse32(nested(i, hs & M32))
    ys = reverse32(nested(reverse32(sobol1(i)), hs >> 32))
    return [F32(xs >> 8) * F32(2.0**-24), F32(ys >> 8) * F32(2.0**-24)]


class ReferenceSampler:
    def __init__(
        self,
        model_paths,
        spp: int,
        dims: int,
        seed: int,
        fold_from: int | None = None,
        net_dims="auto",
        net_layout="auto",
        frames: int = 1,
    ):
        self.frames = frames
        spp *= frames  # points per table; frame f takes indices f * spp / frames ..
        self.n, self.D, self.base = spp, dims, mix64(seed)
        self.fold_from = fold_from  # None: no dimension folded
        models = [dpc.load(p, isa="scalar", threads=1) for p in model_paths]
        # progressive models: tables read in order (rotation range 0), 1-D strata by x rank
        self.progressive = models[0].order == "progressive"
        self.rotate = 0 if self.progressive or frames > 1 else spp  # frames: read in order too
        self.tables = []
        k = 0
        while len(self.tables) < dims:
            m = models[k % len(models)]
            pts = m.generate(seed=mix64(self.base + (k + 1) * SET_STEP), n_points=spp)
            for a in range(0, m.dims - 1, 2):
                if len(self.tables) < dims:
                    table = stratify(pts[:, a : a + 2].astype(F32))
                    if frames > 1 and not self.progressive:
                        t = len(self.tables)
                        table = order_for_frames(table, mix64(self.base ^ mix64(t + FRAME_ORDER)) & M32)
                    self.tables.append(table)
            k += 1
        self.mask = dpc.Sampler.mask()
        # net slots: only when spp is a power of two >= 2
        self.m = spp.bit_length() - 1
        if net_dims == "auto":  # every slot for set models (from 2 spp on), else dimension 0; frames none
            net_dims = 0 if frames > 1 else dims if spp >= 2 and not self.progressive else 1
        self.net_slots = min(net_dims, dims) if spp >= 2 and spp == 1 << self.m else 0
        if net_layout == "auto":  # screen-ordered below 64 spp
            net_layout = "screen" if spp < SCREEN_BELOW else "pixel"
        self.screen = self.net_slots > 0 and net_layout == "screen"
        self.nets, self.net_index = [], []  # the cells, and each cell's Sobol' index
        for t in range(self.net_slots):
            seed_t = mix64(self.base ^ mix64(t + NET_SEED))
            net, index = make_net(self.m, seed_t), np.arange(spp)
            if t > 0:  # later nets in a seeded random order (Fisher-Yates), progressive: per octave
                for i in range(spp - 1, 0, -1):
                    low = 0 if self.rotate else 1 << (i.bit_length() - 1)
                    j = low + (((mix64((seed_t + i * 0xD1342543DE82EF95) & M64) >> 32) * (i - low + 1)) >> 32)
                    net[[i, j]] = net[[j, i]]
                    index[[i, j]] = index[[j, i]]
            self.nets.append(net)
            self.net_index.append(index)

    def key(self, dim: int, pass_: int) -> int:
        return mix64(self.base ^ mix64(((pass_ << 32) | dim) + GOLDEN))

    def _locate(self, x: int, y: int, index: int, dim: int):
        n = self.n
        x, y = x % (1 << 32), y % (1 << 32)
        pass_, k = divmod(index, n)
        key = self.key(dim, pass_)
        t = dim % self.D
        if t < self.net_slots and self.screen:  # the tile's hash, the pixel's permuted code
            kt = mix64(key ^ (((y // TILE) << 32) | (x // TILE)))
            return t, k, None, None, (kt, screen_code(kt, x % TILE, y % TILE))
        if t < self.net_slots:  # the pixel's own hash: rotation and digital shift
            h = mix64(key ^ ((y << 32) | x))
            j = k + (((h >> 32) * self.rotate) >> 32)
            return t, j - n if j >= n else j, None, None, h
        tile = ((y // TILE) << 32) | (x // TILE)
        kt = mix64((self.key(0, pass_) if self.frames > 1 else key) ^ tile)  # frames: dimension 0's offsets
        place = (y % TILE) * TILE + (x % TILE)
        spin = ((kt ^ (((place + 1) * GOLDEN) & M64)) * SPIN) & M64
        j = k + (((spin >> 32) * self.rotate) >> 32)
        ox, oy = kt & 31, (kt >> 5) & 31
        m = self.mask[(y + oy) % TILE, (x + ox) % TILE]
        return t, j - n if j >= n else j, m, (unit24(key >> 10), unit24(key >> 34)), None

    def get_2d(self, x: int, y: int, index: int, dim: int) -> np.ndarray:
        t, j, m, c, h = self._locate(x, y, index, dim)
        if t < self.net_slots and self.screen:  # never folded
            return np.array(screen_values(h[0], h[1], j, self.m), dtype=F32)
        if t < self.net_slots:  # never folded
            return np.array(net_values(self.nets[t][j], j, h, self.m), dtype=F32)
        p = self.tables[t][j]
        v = [wrap(p[0], wrap(m[0], c[0])), wrap(p[1], wrap(m[1], c[1]))]
        if self._folds(dim):
            v = [fold(a) for a in v]
        return np.array(v, dtype=F32)

    def _folds(self, dim: int) -> bool:
        return self.fold_from is not None and dim >= self.fold_from

    def get_1d(self, x: int, y: int, index: int, dim: int) -> np.float32:
        t, j, m, c, h = self._locate(x, y, index, dim)
        inv = F32(F32(1.0) / F32(self.n))
        if t < self.net_slots:  # a stratum at the pixel's offset; never folded
            r = mix64((h[0] if self.screen else h) ^ HERO)
            if self.screen:
                kt, code = h
                below = ((reverse32(code) >> 10) ^ r) & 0x3FFFFF
                u = F32(((code & 3) << 22) | below) * F32(2.0**-24)
            else:
                u = unit24(r)
            if dim > 0 and (dim - 1) % self.D < self.net_slots:  # after a net slot: its point's Sobol' z
                t0, j0, _, _, h0 = self._locate(x, y, index, dim - 1)
                i = screen_index(h0[0], h0[1], j0, self.m) if self.screen else int(self.net_index[t0][j0])
                s = reverse32(nested(reverse32(sobol2(i)), r >> 32)) >> (32 - self.m)
            else:  # the stratum of this slot's own net point's x
                v = screen_values(*h, j, self.m)[0] if self.screen else net_values(self.nets[t][j], j, h, self.m)[0]
                s = int(F32(v * F32(self.n)))
            value = F32(F32(F32(s) + in_stratum(s, self.n, u)) * inv)
            return value if value < F32(1.0) else F32(0.0)
        u = wrap(m[2], c[0])
        i = int(F32(self.tables[t][j][0] * F32(self.n))) if not self.rotate else j
        if self.frames > 1:  # i / n shifted as a whole by u
            v = wrap(wrap(F32(F32(i) * F32(F32(1.0) / F32(self.n))), u), c[1])
            return fold(v) if self._folds(dim) else v
        lattice = F32(F32(F32(i) + in_stratum(i, self.n, u)) * inv)
        v = wrap(lattice if lattice < F32(1.0) else F32(0.0), c[1])
        return fold(v) if self._folds(dim) else v
