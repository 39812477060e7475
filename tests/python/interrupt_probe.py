"""Measures how fast Ctrl-C (SIGINT) stops a long dpc.generate, for tests/python/test_robustness.py
(run on its own it prints the numbers):

    python tests/python/interrupt_probe.py [N_POINTS] [COUNT]
    python tests/python/interrupt_probe.py masks [TRIALS]

The second form interrupts mask making TRIALS times each: an annealed design made on the spot
(dpc.mask_design, libdpc on a worker thread) and void-and-cluster (numpy), each after a random
0.05 .. 0.4 s, and prints one JSON line with every latency (`annealed`, `void_and_cluster`:
seconds from the signal to the KeyboardInterrupt, None where the work ended first), the CPU
seconds used in 0.5 s after the last (`cpu_after_s`) and the design threads still running.

A timer thread sends SIGINT to this process once libdpc has reported progress; the probe prints
one JSON line: the seconds from the signal to the KeyboardInterrupt in Python (`raise_s`), and
the CPU seconds the process used in the 0.5 s after it (`cpu_after_s`, ~0 when libdpc stopped
too, ~0.5 per busy core when it went on working)."""

import json
import os
import signal
import sys
import threading
import time

import dpc


def _interrupt_after(delay: float, work) -> float | None:
    """Run work(), SIGINT this process after ``delay`` s; seconds from signal to exception."""
    sent = {}

    def fire():
        sent["t"] = time.perf_counter()
        signal.raise_signal(signal.SIGINT)

    timer = threading.Timer(delay, fire)
    timer.start()
    try:
        work()
    except KeyboardInterrupt:
        return round(time.perf_counter() - sent["t"], 4)
    finally:
        timer.cancel()
    return None


def masks(trials: int) -> None:
    import random

    from dpc import baselines, mask_design

    rng = random.Random(1)
    out = {"annealed": [], "void_and_cluster": []}
    for k in range(trials):
        # 48 x 48, not bundled: about 3 s of design (about 0.1 s between libdpc's polls)
        design = lambda k=k: mask_design.anneal_mask(48, seed=k)  # noqa: E731
        out["annealed"].append(_interrupt_after(rng.uniform(0.05, 0.4), design))
        # 192 x 192: about 1.5 s on a Zen 5 core (128 x 128 took 0.28 s there and could end first)
        out["void_and_cluster"].append(
            _interrupt_after(rng.uniform(0.05, 0.4), lambda k=k: baselines.void_and_cluster(192, seed=k))
        )
    # the cancelled designs' worker threads stop at libdpc's next poll: no work goes on after
    time.sleep(0.3)
    cpu0 = time.process_time()
    time.sleep(0.5)
    out["cpu_after_s"] = round(time.process_time() - cpu0, 4)
    out["design_threads_left"] = sum(t.name == "dpc-mask-design" for t in threading.enumerate())
    print(json.dumps(out))


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "masks":
        masks(int(sys.argv[2]) if len(sys.argv) > 2 else 20)
        return
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2_000_000
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 1
    model = dpc.load("bnot-2d", threads=1)
    started = threading.Event()
    sent = {}

    def progress(done, total):
        started.set()

    def fire():
        started.wait()
        time.sleep(0.5)
        sent["t"] = time.perf_counter()
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=fire, daemon=True).start()
    t0 = time.perf_counter()
    try:
        model.generate_batch(count, seed=1, n_points=n, progress=progress)
        print(json.dumps({"interrupted": False, "seconds": time.perf_counter() - t0}))
        return
    except KeyboardInterrupt:
        raised = time.perf_counter()
    cpu0 = time.process_time()
    time.sleep(0.5)
    cpu_after = time.process_time() - cpu0
    print(
        json.dumps(
            {
                "interrupted": True,
                "raise_s": round(raised - sent["t"], 4),
                "cpu_after_s": round(cpu_after, 4),
                "n_points": n,
                "count": count,
            }
        )
    )


if __name__ == "__main__":
    main()
