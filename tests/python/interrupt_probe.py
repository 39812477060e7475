"""Measures how fast Ctrl-C (SIGINT) stops a long dpc.generate, for tests/python/test_interrupt.py
(run on its own it prints the numbers):

    python tests/python/interrupt_probe.py [N_POINTS] [COUNT]

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


def main() -> None:
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
