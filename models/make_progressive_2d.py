"""Write models/bnot-2d-progressive.onnx: progressive 2-D blue noise (docs/progressive.md).

bnot-2d-stratified's trained cascade (40 layers), repeated REPEATS times in a row, under the
progressive generation rule (dpc.order = "progressive", first level 16 points,
docs/model-format.md §6): each level's new points are filtered REPEATS x 40 times past the
earlier levels' points, which stay in place. The repeats let the new points settle into the
holes the held points leave (docs/progressive.md measures 1, 3 and 8 repeats); fine-tuning the
40 layers on a loss over the prefixes (training/configs/bnot-2d-progressive-finetune.toml)
measured worse, so the shipped cascade is the trained set cascade, unchanged.

    python models/make_progressive_2d.py [--repeats 4]     # writes models/bnot-2d-progressive.onnx
"""

import argparse
import hashlib
from pathlib import Path

from dpc.model_file import ModelSpec, read_model, write_model

HERE = Path(__file__).resolve().parent
SOURCE = HERE / "bnot-2d-stratified.onnx"
REPEATS = 4


def progressive_spec(repeats: int = REPEATS) -> ModelSpec:
    src = read_model(SOURCE)
    keep = ("dpc.input", "dpc.loss")  # the input kind it was trained on and how
    meta = {k: v for k, v in src.metadata.items() if k in keep}
    meta.update(
        {
            "dpc.order": "progressive",
            "dpc.progressive_base": "16",
            "dpc.source": f"models/make_progressive_2d.py --repeats {repeats}",
            "dpc.derived_from": f"bnot-2d-stratified.onnx sha256 {hashlib.sha256(SOURCE.read_bytes()).hexdigest()}",
            "dpc.trained": "no (the kernels are bnot-2d-stratified's)",
        }
    )
    return ModelSpec(
        dims=2,
        n_points=src.n_points,
        layers=list(src.layers) * repeats,
        name="bnot-2d-progressive",
        description=(
            "Progressive 2-D blue noise: the first 16 * 2^j points of a set are the set of that "
            "size, each blue noise. bnot-2d-stratified's cascade repeated "
            f"{repeats} times, run level by level with the earlier points held in place."
        ),
        metadata=meta,
    )


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=REPEATS)
    ap.add_argument("-o", "--output", default=str(HERE / "bnot-2d-progressive.onnx"))
    args = ap.parse_args()
    write_model(progressive_spec(args.repeats), args.output)
    print(f"wrote {args.output} ({Path(args.output).stat().st_size} bytes)")
