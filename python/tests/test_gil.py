"""The GIL is released while Rust steps the world: two threads stepping two
environments take about as long as one. The ratio is printed, not asserted
(tests never assert on wall-clock time)."""

from __future__ import annotations

import threading
import time

import numpy as np

import seespot

STEPS = 40


def _run(seed: int) -> None:
    """Grasps the highest block and places it at a random spot, STEPS actions
    (each settles the physics), starting new trials as they end."""
    rng = np.random.default_rng(seed)
    trial = seespot.Trial("row", seed, resolution=64)
    for _ in range(STEPS):
        if trial.end is not None:
            seed += 2
            trial = seespot.Trial("row", seed, resolution=64)
        _, depth = trial.observe()
        if trial.next_primitive == "grasp":
            y, x = np.unravel_index(int(np.argmax(depth)), depth.shape)
        else:
            y, x = rng.integers(16, 48, size=2)
        trial.step(int(rng.integers(16)), int(y), int(x))


def test_two_threads_step_in_parallel() -> None:
    _run(1)  # warm up
    t0 = time.perf_counter()
    _run(1)
    one = time.perf_counter() - t0
    threads = [threading.Thread(target=_run, args=(s,)) for s in (1, 1)]
    t0 = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    two = time.perf_counter() - t0
    print(f"\nGIL: one env {one:.3f} s, two envs on two threads {two:.3f} s, ratio {two / one:.2f} "
          "(1.0 = fully parallel, 2.0 = serialized)")
