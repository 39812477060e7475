#!/usr/bin/env python3
"""Export a training checkpoint as a dpc model file:

    python training/export.py runs/NAME/checkpoint.pt -o models/NAME.onnx [--standard-ops F.onnx]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from dpc_train.export import export  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("checkpoint", help="runs/NAME/checkpoint.pt")
    ap.add_argument("-o", "--output", required=True, help="model file to write (.onnx)")
    ap.add_argument("--standard-ops", metavar="FILE",
                    help="also write a plain-ONNX variant (standard operators, dense all pairs)")
    ap.add_argument("--batched", action="store_true",
                    help="standard-ops variant takes [batch, m, n] instead of [m, n]")
    ap.add_argument("--name", help="pattern name stored in the model (default: config's)")
    a = ap.parse_args(argv)
    if not Path(a.checkpoint).is_file():
        print(f"export.py: error: checkpoint {a.checkpoint} not found", file=sys.stderr)
        return 2
    try:
        summary = export(a.checkpoint, a.output, standard_ops=a.standard_ops, name=a.name,
                         batched=a.batched)
    except (ValueError, KeyError, OSError) as e:
        print(f"export.py: error: {type(e).__name__}: {e}", file=sys.stderr)
        return 2
    print(json.dumps(summary, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
