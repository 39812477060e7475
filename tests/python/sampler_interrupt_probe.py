"""Measures how fast Ctrl-C (SIGINT) stops a long dpc.Sampler creation, for
tests/python/test_sampler_interrupt.py (run on its own it prints the numbers):

    python tests/python/sampler_interrupt_probe.py [TRIES] [SAMPLES_PER_PIXEL]

Each try starts a sampler over progressive-2d-relaxed (its prefix relaxation makes a table of
4,096 points take seconds), and a timer thread sends SIGINT to this process at a random moment
once the creation has reported progress. The probe prints one JSON line: per try the seconds
from the signal to the KeyboardInterrupt in Python (`raise_s`, None when the creation ended
without one), and the CPU seconds the process used in the 0.3 s after it (`cpu_after_s`, ~0
when libdpc stopped too)."""

import json
import os
import random
import signal
import sys
import threading
import time

import dpc


def one_try(model, spp: int, rng: random.Random) -> dict:
    started = threading.Event()
    sent = {}

    def progress(done, total):
        started.set()

    def fire():
        started.wait()
        time.sleep(rng.uniform(0.0, 0.2))
        sent["t"] = time.perf_counter()
        os.kill(os.getpid(), signal.SIGINT)

    timer = threading.Thread(target=fire, daemon=True)
    timer.start()
    try:
        dpc.Sampler(model, samples_per_pixel=spp, dimensions=4, progress=progress)
    except KeyboardInterrupt:
        raised = time.perf_counter()
    else:
        timer.join()
        return {"raise_s": None, "cpu_after_s": None}
    timer.join()
    cpu0 = time.process_time()
    time.sleep(0.3)
    return {"raise_s": round(raised - sent["t"], 4), "cpu_after_s": round(time.process_time() - cpu0, 4)}


def main() -> None:
    tries = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    spp = int(sys.argv[2]) if len(sys.argv) > 2 else 4096
    model = dpc.load("progressive-2d-relaxed", threads=2)
    rng = random.Random(1)
    results = [one_try(model, spp, rng) for _ in range(tries)]
    print(json.dumps({"tries": results}))


if __name__ == "__main__":
    main()
