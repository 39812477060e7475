"""Regenerate pbrt-v4's two Git-LFS tables (pmj02tables.cpp, bluenoise.cpp) into a pbrt-v4 checkout.

pbrt-v4 keeps ``src/pbrt/util/pmj02tables.cpp`` and ``src/pbrt/util/bluenoise.cpp`` in Git LFS; a
checkout without LFS objects cannot build. This script writes replacements that match the
declarations in ``pmj02tables.h`` and ``bluenoise.h``:

* ``pmj02bnSamples[5][65536][2]`` (uint32, fixed point: pbrt reads ``value * 0x1p-32``): five
  pmj02bn sets made by pmj-cpp's ``generate_samples`` (MIT, Andrew Helmer), one seed each. pmj-cpp
  seeds its engine from ``std::random_device``; a private copy of its sources, built in a temporary
  folder, reads the seed from ``PMJ_SEED`` instead, so a rerun gives the same tables.
* ``BlueNoiseTextures[48][128][128]`` (uint16, pbrt reads ``value / 65535``): 48 void-and-cluster
  masks (Ulichney 1993) from dpc's ``dpc.mask("void-and-cluster", size=128, seed=s)``; every rank
  0 … 16383 occurs once per texture and maps to ``round((rank + 1/2) / 16384 * 65535)``.

These are regenerated tables, not the ones pbrt-v4 publishes; numbers measured with them say so.

    python integrations/pbrt-v4/make_tables.py PBRT_SRC --pmj-cpp PMJ_CPP_SRC
"""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

N_SETS = 5
N_SAMPLES = 65536
N_TEXTURES = 48
RES = 128

PMJ_SEEDS = [1, 2, 3, 4, 5]
MASK_SEED0 = 1

MIT_NOTICE = """\
// The PMJ02BN points below were generated with pmj-cpp (https://github.com/Andrew-Helmer/pmj-cpp):
//
// Copyright 2020 Andrew Helmer
//
// Permission is hereby granted, free of charge, to any person obtaining a copy of this software
// and associated documentation files (the "Software"), to deal in the Software without
// restriction, including without limitation the rights to use, copy, modify, merge, publish,
// distribute, sublicense, and/or sell copies of the Software, and to permit persons to whom the
// Software is furnished to do so, subject to the following conditions:
//
// The above copyright notice and this permission notice shall be included in all copies or
// substantial portions of the Software.
//
// THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR IMPLIED, INCLUDING
// BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY, FITNESS FOR A PARTICULAR PURPOSE AND
// NONINFRINGEMENT. IN NO EVENT SHALL THE AUTHORS OR COPYRIGHT HOLDERS BE LIABLE FOR ANY CLAIM,
// DAMAGES OR OTHER LIABILITY, WHETHER IN AN ACTION OF CONTRACT, TORT OR OTHERWISE, ARISING FROM,
// OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE SOFTWARE.
"""

SEED_LINE = "thread_local static std::default_random_engine gen(r());"
SEED_REPLACEMENT = (
    'thread_local static std::default_random_engine gen(std::getenv("PMJ_SEED") ? '
    'static_cast<unsigned>(std::strtoul(std::getenv("PMJ_SEED"), nullptr, 10)) : r());'
)


def build_generator(pmj_src: Path, workdir: Path) -> Path:
    """Copy pmj-cpp's sources to ``workdir``, make its seed come from PMJ_SEED, build with g++ -O2.

    Current g++/libstdc++ no longer pull <cassert> and the floating-point ``abs`` overloads in
    transitively; without ``math.h`` pmj-cpp's toroidal distance calls ``abs(int)``, every
    best-candidate distance is 0 and pmj02bn crashes, so both headers are force-included.
    """
    src = workdir / "pmj-cpp"
    shutil.copytree(pmj_src, src, ignore=shutil.ignore_patterns(".git", "analyses", "docs"))
    util = src / "sample_generation" / "util.cc"
    text = util.read_text()
    if SEED_LINE not in text:
        raise SystemExit(f"{util}: seed line not found; this pmj-cpp version is not the one this script knows")
    util.write_text("#include <cstdlib>\n" + text.replace(SEED_LINE, SEED_REPLACEMENT))
    exe = src / "generate_samples"
    flags = ["-O2", "-std=c++14", "-include", "cassert", "-include", "math.h", f"-I{src}"]
    cmd = ["g++", *flags, "-o", str(exe), str(src / "generate_samples.cc")]
    cmd += sorted(str(p) for p in (src / "sample_generation").glob("*.cc"))
    subprocess.run(cmd, check=True)
    return exe


def parse_points(text: str) -> np.ndarray:
    """pmj-cpp writes one ``(x, y),`` per line."""
    rows = [line.strip().rstrip(",").strip("()").split(",") for line in text.splitlines() if line.strip()]
    return np.array([[float(a), float(b)] for a, b in rows], dtype=np.float64)


def to_fixed(points: np.ndarray) -> np.ndarray:
    """[0,1) doubles to pbrt's uint32 fixed point (pbrt reads value * 2^-32 into a float).

    Each value is floored to 24 significant bits (a multiple of 2^8), so that the float pbrt makes
    of it is exact: a value within float rounding below a stratum's upper edge would otherwise
    round up into the next stratum, and PMJ02BNSampler's pixel-sample sorting, which counts the
    points per pixel tile in float, fails its check (it did for pmj-cpp's raw doubles). Flooring
    keeps every point in its elementary intervals (the finest are 2^-16 wide).
    """
    if points.min() < 0.0 or points.max() >= 1.0:
        raise ValueError("points outside [0, 1)")
    return (np.floor(points * 2.0**24).astype(np.uint32)) << np.uint32(8)


def as_pbrt_reads(fixed: np.ndarray) -> np.ndarray:
    """The coordinates as GetPMJ02BNSample returns them on the CPU: value * 0x1p-32 in double, then float."""
    return (fixed.astype(np.float64) * 2.0**-32).astype(np.float32)


def check_pmj02(fixed: np.ndarray) -> None:
    """As pbrt reads the points (float): every power-of-4 prefix of 4^k points has one point in
    each square of the 2^k x 2^k grid, and the whole set one in each of the 256 x 256 grid, so
    PMJ02BNSampler finds spp points in every pixel tile for every power-of-4 spp."""
    x = as_pbrt_reads(fixed)
    for k in range(0, 9):
        n, cells = 4**k, 2**k
        c = np.floor(x[:n].astype(np.float64) * cells).astype(np.int64)
        if c.min() < 0 or c.max() >= cells:
            raise SystemExit("pmj02bn point outside [0, 1) as pbrt reads it")
        counts = np.bincount(c[:, 1] * cells + c[:, 0], minlength=cells * cells)
        if not np.all(counts == 1):
            raise SystemExit(f"pmj02bn set is not stratified for the first {n} points as pbrt reads them")


def pmj_sets(exe: Path, workdir: Path) -> np.ndarray:
    out = np.empty((N_SETS, N_SAMPLES, 2), dtype=np.uint32)
    for i, seed in enumerate(PMJ_SEEDS):
        path = workdir / f"pmj02bn_{seed}.txt"
        env = dict(os.environ, PMJ_SEED=str(seed))
        subprocess.run(
            [str(exe), "--algorithm=pmj02bn", f"--n={N_SAMPLES}", f"--out={path}"],
            check=True,
            env=env,
            stdout=subprocess.DEVNULL,
        )
        out[i] = to_fixed(parse_points(path.read_text()))
        check_pmj02(out[i])
        print(
            f"pmj02bn set {i} (seed {seed}): {N_SAMPLES} points",
            flush=True,
        )
    if len({out[i].tobytes() for i in range(N_SETS)}) != N_SETS:
        raise SystemExit("two pmj02bn sets are identical: the seed did not reach pmj-cpp's engine")
    return out


def rank_to_uint16(mask: np.ndarray) -> np.ndarray:
    """A rank-normalised mask (values (rank + 1/2)/S, each once) to uint16 value/65535 offsets."""
    s = mask.size
    rank = np.rint(mask * s - 0.5).astype(np.int64)
    if not np.array_equal(np.sort(rank.ravel()), np.arange(s)):
        raise ValueError("mask is not a permutation of ranks")
    return np.rint((rank + 0.5) / s * 65535.0).astype(np.uint16)


def blue_noise_textures() -> np.ndarray:
    import dpc  # the project's package; its void-and-cluster baseline (Ulichney 1993)

    out = np.empty((N_TEXTURES, RES, RES), dtype=np.uint16)
    for t in range(N_TEXTURES):
        out[t] = rank_to_uint16(np.asarray(dpc.mask("void-and-cluster", size=RES, seed=MASK_SEED0 + t)))
    print(f"{N_TEXTURES} void-and-cluster textures {RES}x{RES}", flush=True)
    return out


def _rows(values: np.ndarray, per_line: int, fmt) -> list[str]:
    flat = [fmt(int(v)) for v in values.ravel()]
    return [", ".join(flat[i : i + per_line]) + "," for i in range(0, len(flat), per_line)]


def header(command: str, what: str) -> str:
    return (
        f"// {what}\n"
        "// REGENERATED TABLE: not the table pbrt-v4 publishes (that one is stored in Git LFS and was\n"
        "// not available). Written by dpc's integrations/pbrt-v4/make_tables.py:\n"
        f"//   {command}\n"
        "// Do not edit; rerun the command.\n"
    )


def write_pmj(path: Path, sets: np.ndarray, command: str) -> None:
    lines = [
        header(
            command,
            "pmj02bnSamples: 5 pmj02bn sets of 65536 points, uint32 fixed point (x * 2^32, floored to 24 bits).",
        ),
        f"// pmj-cpp seeds (PMJ_SEED): {PMJ_SEEDS}\n",
        MIT_NOTICE,
        "#include <pbrt/util/pmj02tables.h>\n\nnamespace pbrt {\n",
        "PBRT_CONST uint32_t pmj02bnSamples[nPMJ02bnSets][nPMJ02bnSamples][2] = {",
    ]
    for s in range(sets.shape[0]):
        lines.append("{")
        pairs = sets[s]
        for i in range(0, pairs.shape[0], 4):
            chunk = pairs[i : i + 4]
            lines.append(" ".join(f"{{0x{int(a):08x}, 0x{int(b):08x}}}," for a, b in chunk))
        lines.append("},")
    lines.append("};\n\n}  // namespace pbrt\n")
    path.write_text("\n".join(lines))


def write_blue_noise(path: Path, tex: np.ndarray, command: str) -> None:
    lines = [
        header(
            command,
            "BlueNoiseTextures: 48 void-and-cluster masks 128x128 (dpc.mask('void-and-cluster', size=128, "
            f"seed={MASK_SEED0}..{MASK_SEED0 + N_TEXTURES - 1})), uint16, value/65535.",
        ),
        "#include <pbrt/util/bluenoise.h>\n\nnamespace pbrt {\n",
        "PBRT_CONST uint16_t BlueNoiseTextures[NumBlueNoiseTextures][BlueNoiseResolution][BlueNoiseResolution] = {",
    ]
    for t in range(tex.shape[0]):
        lines.append("{")
        for row in tex[t]:
            lines.append("{" + " ".join(_rows(row, RES, str)) + "},")
        lines.append("},")
    lines.append("};\n\n}  // namespace pbrt\n")
    path.write_text("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("pbrt_src", type=Path, help="pbrt-v4 checkout (has src/pbrt/util/pmj02tables.h)")
    ap.add_argument("--pmj-cpp", type=Path, required=True, help="pmj-cpp source tree (has generate_samples.cc)")
    args = ap.parse_args(argv)
    util = args.pbrt_src / "src" / "pbrt" / "util"
    if not (util / "pmj02tables.h").is_file() or not (util / "bluenoise.h").is_file():
        raise SystemExit(f"{util}: pmj02tables.h / bluenoise.h not found")
    if not (args.pmj_cpp / "generate_samples.cc").is_file():
        raise SystemExit(f"{args.pmj_cpp}: generate_samples.cc not found")
    command = "python integrations/pbrt-v4/make_tables.py " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    tex = blue_noise_textures()
    with tempfile.TemporaryDirectory(prefix="pmj-cpp-") as tmp:
        exe = build_generator(args.pmj_cpp, Path(tmp))
        sets = pmj_sets(exe, Path(tmp))
    write_pmj(util / "pmj02tables.cpp", sets, command)
    write_blue_noise(util / "bluenoise.cpp", tex, command)
    print(f"wrote {util / 'pmj02tables.cpp'} and {util / 'bluenoise.cpp'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
