"""Point-set quality of every bundled model on the Vulkan backend against the CPU backend.

    python3 -m lab.gpu.vulkan_quality dump --lib .gpu/libdpc.so.0 --out sets.npz   # where the GPU is
    python -m lab.gpu.vulkan_quality compare sets_*.npz                              # here: the table

The trained cascades amplify float32 rounding (docs/training.md, "Precision sensitivity"), so a
GPU returns other points than the CPU for one seed. What must agree is their quality. `dump` needs
only numpy and libdpc's C ABI (ctypes), so it runs on a GPU machine that has neither the dpc
package nor a compiler (bench/gpu_run.sh calls it); it writes 16 sets per model and backend, made
with dpc_generate_batch(seed 0) at each model's own point count. `compare` measures both sides with
dpc.analysis: E_low(0.5) (mean power at every integer frequency below nu = 0.5, docs/analysis.md;
where there is none, 10-D at m = 1,024, below the nu that takes in |q| = 1)
and delta_min (smallest toroidal distance over the densest packing's), and calls a difference of
means significant when it exceeds 4 standard errors, as test_models.py's same-quality test does.
The table goes to the "vulkan_quality" section of docs/performance.md.
"""

from __future__ import annotations

import argparse
import ctypes
import platform
import sys
from pathlib import Path

import numpy as np

from lab.common import ROOT, replace_section  # no dpc import: dump runs where the package is not installed

SETS = 16
BACKENDS = {"cpu": 1, "vulkan": 2}  # dpc_backend
SHARD = 15 << 20
UNSUPPORTED = 4  # DPC_ERROR_UNSUPPORTED


def dump(lib_path: str, out: str, only: list[str]) -> None:
    lib = ctypes.CDLL(lib_path)
    lib.dpc_last_error.restype = ctypes.c_char_p
    lib.dpc_model_device.restype = ctypes.c_char_p
    lib.dpc_model_device.argtypes = [ctypes.c_void_p]
    lib.dpc_model_load_file.argtypes = [ctypes.c_char_p, ctypes.c_void_p, ctypes.POINTER(ctypes.c_void_p)]
    lib.dpc_model_free.argtypes = [ctypes.c_void_p]
    lib.dpc_generate_batch.argtypes = [
        ctypes.c_void_p,
        ctypes.c_uint64,
        ctypes.c_size_t,
        ctypes.c_size_t,
        ctypes.c_void_p,
    ]
    lib.dpc_model_get_info.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
    arrays, devices, skipped = {}, {}, []
    for path in sorted((ROOT / "models").glob("*.onnx")):
        if only and path.stem not in only:
            continue
        for backend, code in BACKENDS.items():
            opts = ctypes.create_string_buffer(256)  # dpc_load_options, filled by its init
            lib.dpc_load_options_init(opts)
            ctypes.c_uint32.from_buffer(opts, 8).value = 0  # .threads: every CPU (same bits)
            ctypes.c_uint32.from_buffer(opts, 12).value = code  # .backend follows 3 4-byte fields
            model = ctypes.c_void_p()
            st = lib.dpc_model_load_file(str(path).encode(), opts, ctypes.byref(model))
            if st == UNSUPPORTED and backend == "vulkan":  # progressive models: CPU only
                skipped.append(f"{path.stem}: {lib.dpc_last_error().decode()}")
                arrays.pop(f"{path.stem}/cpu")
                break
            if st != 0:
                sys.exit(f"{path.name} on {backend}: {lib.dpc_last_error().decode()}")
            info = (ctypes.c_uint32 * 64)()
            lib.dpc_model_get_info(model, info)
            dims, m = info[0], info[1]  # dpc_model_info starts with dims, n_points
            sets = np.empty((SETS, m, dims), np.float32)
            if lib.dpc_generate_batch(model, 0, SETS, 0, sets.ctypes.data) != 0:
                sys.exit(f"{path.name} on {backend}: {lib.dpc_last_error().decode()}")
            devices[backend] = lib.dpc_model_device(model).decode()
            lib.dpc_model_free(model)
            arrays[f"{path.stem}/{backend}"] = sets
        else:
            print(f"{path.stem}: {SETS} sets of {m} {dims}-D points on each backend", flush=True)
    # Shards of at most SHARD bytes (the device tool brings back files of up to 16 MiB).
    shards, size = [{}], 0
    for key, a in arrays.items():
        if size + a.nbytes > SHARD and shards[-1]:
            shards.append({})
            size = 0
        shards[-1][key] = a
        size += a.nbytes
    stem = out[: -len(".npz")] if out.endswith(".npz") else out
    for i, shard in enumerate(shards):
        shard["_devices"] = np.array([devices["cpu"], devices["vulkan"], platform.node()])
        shard["_skipped"] = np.array(skipped, dtype=str)
        path = f"{stem}_{i}.npz"
        np.savez_compressed(path, **shard)
        print(f"wrote {path}")


def compare(npzs: list[str], doc: Path) -> None:
    from dpc import analysis

    data = {}
    for npz in npzs:
        with np.load(npz) as f:
            data.update({k: f[k] for k in f.files})
    device = str(data["_devices"][1])
    names = sorted({k.split("/")[0] for k in data if "/" in k})
    rows, worst = [], 0.0
    for name in names:
        cpu, gpu = data[f"{name}/cpu"].astype(np.float64), data[f"{name}/vulkan"].astype(np.float64)
        d = np.abs(gpu - cpu)
        d = np.minimum(d, 1.0 - d).max(axis=2)
        cells = [f"`{name}`", f"{cpu.shape[1]:,} x {cpu.shape[2]}-D", f"{d.max():.2g}"]
        m, n = cpu.shape[1:]
        nu = 0.5 if 0.5 * m ** (1 / n) > 1 else 1.25 / m ** (1 / n)  # some |q| = 1 below nu
        measures = [
            (
                lambda x, nu=nu: np.array([analysis.low_frequency_energy(s[None], nu) for s in x]),
                "" if nu == 0.5 else f", nu < {nu:.2g}",
            ),
            (lambda x: analysis.min_distance(x).ratios, ""),
        ]
        flags = []
        for measure, note in measures:
            a, b = measure(cpu), measure(gpu)
            se = np.hypot(a.std(ddof=1), b.std(ddof=1)) / np.sqrt(SETS)
            z = abs(b.mean() - a.mean()) / se if se > 0 else 0.0
            worst = max(worst, z)
            flags.append(z > 4)
            cells.append(f"{a.mean():.4g} / {b.mean():.4g} ({z:.1f}){note}")
        cells.append("**differs**" if any(flags) else "same")
        rows.append("| " + " | ".join(cells) + " |")
        print(rows[-1], flush=True)
    same = sum(r.endswith("same |") for r in rows)
    lines = [
        f"`python -m lab.gpu.vulkan_quality compare` on sets that `bench/gpu_run.sh` made on **{device}** "
        f"(`vulkan_quality.py dump`: {SETS} sets per model and backend, dpc_generate_batch with seed 0, "
        "each model's own point count; the CPU column is the same machine's CPU backend). Columns: the "
        "largest toroidal difference between a Vulkan point and the CPU point of the same index; "
        "E_low(0.5) (where a model has no integer frequency below nu = 0.5, below the nu that the row names, "
        "which takes in |q| = 1) and delta_min as CPU mean / Vulkan mean, and in parentheses the difference in "
        "standard errors of the difference of means (4 or more counts as differing, as in "
        "`tests/python/test_models.py`'s same-quality test).",
        "",
        "| model | points | max \\|Vulkan - CPU\\| | E_low(0.5) CPU / Vulkan (z) | delta_min CPU / Vulkan (z) | "
        "quality |",
        "|---|---|---:|---:|---:|---|",
        *rows,
        "",
        f"{same} of {len(rows)} models give point sets of the same quality on both backends (largest z {worst:.1f}).",
    ]
    skipped = sorted({str(x).split(":")[0] for x in data["_skipped"]})
    if skipped:
        lines += [
            "",
            "Not on the Vulkan backend (progressive models run on the CPU backend only): "
            + ", ".join(f"`{n}`" for n in skipped)
            + ".",
        ]
    section = "\n".join(lines)
    if "<!-- vulkan_quality:begin -->" not in doc.read_text():
        sys.exit(f"{doc} has no <!-- vulkan_quality:begin --> ... end marker pair to replace")
    replace_section(doc, "vulkan_quality", section)
    print(f"\n{section}\nwrote {doc}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("dump", help="make the sets (needs only numpy and libdpc)")
    d.add_argument("--lib", required=True, help="path of libdpc.so.0")
    d.add_argument("--out", required=True, help="OUT.npz: writes OUT_0.npz, OUT_1.npz, ... (at most 15 MiB each)")
    d.add_argument("--models", nargs="*", default=[], help="these models only (default: every bundled one)")
    c = sub.add_parser("compare", help="measure the sets with dpc.analysis")
    c.add_argument("npz", nargs="+", help="the files dump wrote (OUT_0.npz, OUT_1.npz, ...)")
    c.add_argument("--doc", default=str(ROOT / "docs" / "performance.md"))
    args = ap.parse_args()
    if args.cmd == "dump":
        dump(args.lib, args.out, args.models)
    else:
        compare(args.npz, Path(args.doc))


if __name__ == "__main__":
    main()
