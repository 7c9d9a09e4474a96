"""Steps per second of seespot's native vector environment (``gym.make_vec``:
N trials stepped on Rust threads, the GIL released) against gymnasium's
``AsyncVectorEnv`` over the single environment (one process per trial), in
the same run, for N = 2, 8 and 32.

Both step uniformly random actions (so episodes end, and autoreset, at the
30-action limit or earlier) for ``--seconds`` each, after one warm-up step;
the two are measured alternately, ``--rounds`` times, and the medians are
printed with their ratio. Run it from the repository root::

    scripts/bench-vector-env            # or: python python/benchmarks/vector_env.py --json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from typing import Any

import gymnasium as gym
import numpy as np

import seespot  # noqa: F401  (registers the environments)


def steps_per_second(make: Any, n: int, seconds: float, resolution: int) -> float:
    venv = make(n, resolution)
    rng = np.random.default_rng(0)
    hi = np.array([16, resolution, resolution])
    try:
        venv.reset(seed=1)
        venv.step(rng.integers(0, hi, size=(n, 3)))
        steps, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            venv.step(rng.integers(0, hi, size=(n, 3)))
            steps += n
        return steps / (time.perf_counter() - start)
    finally:
        venv.close()


def native(n: int, resolution: int) -> Any:
    return gym.make_vec("seespot/Stack-v0", num_envs=n, resolution=resolution, vectorization_mode="vector_entry_point")


def asynchronous(n: int, resolution: int) -> Any:
    return gym.vector.AsyncVectorEnv(
        [lambda: gym.make("seespot/Stack-v0", resolution=resolution) for _ in range(n)]
    )


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--envs", type=int, nargs="+", default=[2, 8, 32])
    p.add_argument("--seconds", type=float, default=5.0, help="stepping time per measurement")
    p.add_argument("--rounds", type=int, default=3, help="alternating measurements per N")
    p.add_argument("--resolution", type=int, default=112)
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    args = p.parse_args(argv)
    rows = []
    for n in args.envs:
        nat, asy = [], []
        for _ in range(args.rounds):
            nat.append(steps_per_second(native, n, args.seconds, args.resolution))
            asy.append(steps_per_second(asynchronous, n, args.seconds, args.resolution))
        row = {
            "num_envs": n,
            "native_steps_per_s": statistics.median(nat),
            "async_steps_per_s": statistics.median(asy),
        }
        row["ratio"] = row["native_steps_per_s"] / row["async_steps_per_s"]
        rows.append(row)
        if not args.json:
            print(
                f"N = {n:>2}: native {row['native_steps_per_s']:8.1f} steps/s, "
                f"AsyncVectorEnv {row['async_steps_per_s']:8.1f} steps/s, ratio {row['ratio']:.2f}x",
                flush=True,
            )
    if args.json:
        print(json.dumps({"cpus": os.cpu_count(), "resolution": args.resolution, "rows": rows}))


if __name__ == "__main__":
    main()
