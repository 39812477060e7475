#!/usr/bin/env python3
"""Train a dpc filter cascade: python training/train.py --config training/configs/NAME.toml

The same command as ``dpc-train`` (dpc_train.cli.train_main). Run as a script, Python puts this
folder first on the module path, so ``dpc_train`` is the package beside this file.
"""

from dpc_train.cli import train

if __name__ == "__main__":
    train()
