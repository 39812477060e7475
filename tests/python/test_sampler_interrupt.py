"""Interruptible sampler creation: dpc.Sampler builds its tables off the calling thread, so
Ctrl-C raises KeyboardInterrupt within 0.5 s every time and libdpc stops too
(tests/python/sampler_interrupt_probe.py sends the SIGINTs in a process of its own); progress=
reports the tables' sets, and an exception from it stops the creation."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import dpc

PROBE = Path(__file__).with_name("sampler_interrupt_probe.py")


def test_ctrl_c_stops_a_long_creation_within_half_a_second_every_time():
    r = subprocess.run([sys.executable, str(PROBE), "20"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    tries = json.loads(r.stdout.strip().splitlines()[-1])["tries"]
    assert len(tries) == 20
    for t in tries:
        assert t["raise_s"] is not None, f"a creation ended without its KeyboardInterrupt: {tries}"
        assert t["raise_s"] < 0.5, tries
        assert t["cpu_after_s"] < 0.1, f"libdpc kept working after the interrupt: {tries}"


def test_progress_counts_the_tables_sets_and_changes_no_value():
    seen = []
    with_progress = dpc.Sampler(
        "bnot-2d", samples_per_pixel=16, dimensions=6, net_dims=1, progress=lambda d, t: seen.append((d, t))
    )
    plain = dpc.Sampler("bnot-2d", samples_per_pixel=16, dimensions=6, net_dims=1)
    for t in range(6):
        np.testing.assert_array_equal(with_progress.table(t), plain.table(t))
    assert seen and seen[-1] == (5, 5)  # slot 0 is a net: five sets
    assert all(a[0] <= b[0] for a, b in zip(seen, seen[1:]))


def test_an_exception_from_progress_stops_the_creation():
    class Stop(Exception):
        pass

    def stop(done, total):
        raise Stop()

    model = dpc.load("progressive-2d-relaxed")
    with pytest.raises(Stop):
        dpc.Sampler(model, samples_per_pixel=4096, dimensions=2, progress=stop)
