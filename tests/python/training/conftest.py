"""The training tests run against the installed dpc_train (pip install '.[train]'); torch is kept to
1 thread."""

import torch

torch.set_num_threads(1)


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: long-running test (deselect with -m 'not slow')")
