#!/usr/bin/env python3
"""Export a training checkpoint as a dpc model file:

    python training/export.py runs/NAME/checkpoint.pt -o models/NAME.onnx [--standard-ops F.onnx]

The same command as ``dpc-export`` (dpc_train.cli.export_main). Run as a script, Python puts this
folder first on the module path, so ``dpc_train`` is the package beside this file.
"""

from dpc_train.cli import export

if __name__ == "__main__":
    export()
