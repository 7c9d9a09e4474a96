"""The leave-one-out evaluation on Ray: ``seespot eval`` scaled out.

Each Ray actor loads one policy set per (method, task) it is given (an
:class:`seespot.Evaluator`) and runs trials with it; the driver alone appends
the records, as they come, to ``<out>/trials/<method>/<task>.jsonl.gz``, the file
``seespot eval`` writes and reads, in the same format with the same provenance.
A rerun skips the seeds already recorded, so an interrupted evaluation resumes,
and ``seespot eval`` with the same arguments then only writes the report.

On one machine, :func:`evaluate` starts a local Ray that listens on 127.0.0.1
only, with the dashboard and usage statistics off; on a cluster pass its
``address``. Each
worker runs its Rust threads (rayon) on ``threads_per_worker`` cores.

    python -m seespot.dist --method oracle --task stack --trials 4 --workers 2 --out runs/eval
"""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from seespot._core import (
    DEFAULT_RESOLUTION,
    METHODS,
    TASKS,
    Evaluator,
    OutputLock,
    append_record,
    read_records,
    records_path,
    test_seeds,
)


RAY_MISSING = (
    "seespot.dist runs the evaluation on Ray, which is not installed: "
    "pip install 'seespot[ray]' (or pip install ray)"
)


def _import_ray() -> Any:
    """Ray, or an error that names the extra that installs it."""
    try:
        import ray
    except ImportError as e:
        raise ImportError(RAY_MISSING) from e
    return ray


def init_local_ray(num_workers: int, threads_per_worker: int) -> None:
    """Starts a local Ray on 127.0.0.1 (no dashboard, no usage statistics).

    On Linux Ray replaces a loopback node address by the machine's outward
    address; it keeps loopback when ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER`` is 0
    (its single-machine mode), read when Ray is imported, so the constant is
    set too when Ray is already imported."""
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
    ray = _import_ray()
    import ray._private.ray_constants as ray_constants

    ray_constants.ENABLE_RAY_CLUSTER = False
    ray.init(
        _node_ip_address="127.0.0.1",
        include_dashboard=False,
        num_cpus=num_workers,
        log_to_driver=False,
        runtime_env={"env_vars": {"RAYON_NUM_THREADS": str(threads_per_worker)}},
    )


def _usable_cores() -> int:
    """The cores this process may run on (its affinity, as ``taskset`` sets
    it, where the platform has one), else every core."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


class TrialRunner:
    """A Ray actor's state: one :class:`seespot.Evaluator` (policy set) per
    (method, task), loaded on first use."""

    def __init__(
        self, models_dir: str, demos_dir: str, resolution: int, correspond: str | dict[str, Any], options: dict[str, Any]
    ):
        self.args = (models_dir, demos_dir, resolution, correspond)
        self.options = options
        self.evaluators: dict[tuple[str, str], Evaluator] = {}

    def run(self, method: str, task: str, seed: int, index: int) -> tuple[str, str, int, str]:
        key = (method, task)
        if key not in self.evaluators:
            self.evaluators[key] = Evaluator(method, task, *self.args, **self.options)
        return method, task, seed, self.evaluators[key].run(seed, index)


def recorded(path: Path) -> dict[int, dict[str, Any]]:
    """The records already in ``path`` by seed (none when it does not exist),
    read as ``seespot eval`` reads them: a last line cut short by a kill is
    dropped, and a damaged line, a seed recorded twice or another method's or
    task's record raises ``ValueError`` naming the file and line."""
    return {int(r["seed"]): r for r in map(json.loads, read_records(path))}


#: The first validation seed (``seespot_sim::seeds::VALIDATION_START``): even
#: seeds are training seeds, odd seeds below it test seeds, odd seeds from it
#: validation seeds.
VALIDATION_START = 10_001


def split_of(seed: int) -> str:
    """The split ``seed`` belongs to: ``training``, ``test`` or ``validation``."""
    if seed % 2 == 0:
        return "training"
    return "test" if seed < VALIDATION_START else "validation"


def check_split(path: Path, recorded_seeds: Iterable[int], new_seeds: Iterable[int]) -> None:
    """Refuses, as ``seespot eval`` does, to add a seed of one split to a
    records file holding another's: a ``ValueError`` naming the file and both
    splits (the report over the file would mix them without a word)."""
    new = next(iter(new_seeds), None)
    if new is None:
        return
    other = next((s for s in recorded_seeds if split_of(s) != split_of(new)), None)
    if other is not None:
        raise ValueError(
            f"{path}: holds {split_of(other)} seeds (seed {other}); seed {new} is a "
            f"{split_of(new)} seed, and a records file holds one split's seeds; "
            "evaluate into another --out (the shipped validation runs are in results/validation)"
        )


def append(path: Path, line: str) -> None:
    """Appends one record line as ``seespot eval`` does: a fragment left by a
    kill is cut off first, and the line is synced (a killed run loses no
    written trial)."""
    append_record(path, line)


def evaluate(
    methods: Sequence[str],
    tasks: Iterable[str] = TASKS,
    *,
    seed: int = 1,
    trials: int = 50,
    out_dir: str | os.PathLike[str] = "runs/eval",
    models_dir: str = "models",
    demos_dir: str = "demos",
    resolution: int = DEFAULT_RESOLUTION,
    correspond: str | dict[str, Any] = "reference",
    num_workers: int = 2,
    threads_per_worker: int | None = None,
    address: str | None = None,
    embeddings: list[str] | None = None,
    finetune_steps: int = 0,
    finetune_procedure: str = "reference",
    noise: str | None = None,
    truth: bool = False,
) -> dict[tuple[str, str], list[dict[str, Any]]]:
    """Runs (or resumes) the evaluation of ``methods`` on ``tasks`` over the
    seeds ``seed, seed + 2, ...`` (``trials`` of them) with ``num_workers`` Ray
    actors; returns every (method, task)'s records sorted by seed.

    It holds ``seespot eval``'s lock on ``out_dir`` throughout: while another
    evaluation writes there (either kind), it raises ``BlockingIOError``
    naming the holder, before starting Ray. ``embeddings`` (SSR and SPOT-Q):
    an embedding set in place of the SPOT-Q policies (docs/embeddings.md),
    checked here before any trial; the runs are named after it.
    ``finetune_steps`` and ``finetune_procedure``: the finetuned rows, their
    models made once here (in ``out_dir/finetuned/``) before any trial;
    ``noise``: a scene file with a ``[noise]`` table (``seespot eval
    --noise``); ``truth``: label every decision with the simulator's truth
    (``seespot eval --truth``). Custom tasks (``custom:NAME``) and the TransporterNet run as
    the other rows do: every row of the table, into the folders ``seespot
    eval`` writes."""
    ray = _import_ray()

    tasks = list(tasks)
    seeds = test_seeds(seed, trials)
    for m in methods:
        if m not in METHODS:
            raise ValueError(f"methods: '{m}' is not one of {', '.join(METHODS)}")
    if num_workers < 1:
        raise ValueError(f"num_workers: {num_workers} is not positive")
    threads = threads_per_worker or max(1, _usable_cores() // num_workers)
    options: dict[str, Any] = {
        "embeddings": embeddings,
        "finetune_steps": finetune_steps,
        "finetune_procedure": finetune_procedure,
        "noise": noise,
        "out_dir": str(out_dir),
        "truth": truth,
    }
    with OutputLock(out_dir):
        # Each run's records name is the Evaluator's: made here, it also
        # loads and checks every model, and makes the finetuned models once,
        # before any trial and before the workers read them.
        names = {
            (m, t): Evaluator(m, t, models_dir, demos_dir, resolution, correspond, **options).record_name
            for m in methods
            for t in tasks
        }
        # A seed of another split than a file's records is refused before Ray starts.
        for (m, t), name in names.items():
            path = Path(records_path(Path(out_dir), name, t))
            have = recorded(path)
            check_split(path, have, (s for s in seeds if s not in have))
        return _evaluate_locked(
            ray, methods, tasks, seeds, out_dir, models_dir, demos_dir, resolution,
            correspond, num_workers, threads, address, options, names,
        )


def _evaluate_locked(
    ray: Any,
    methods: Sequence[str],
    tasks: list[str],
    seeds: list[int],
    out_dir: str | os.PathLike[str],
    models_dir: str,
    demos_dir: str,
    resolution: int,
    correspond: str | dict[str, Any],
    num_workers: int,
    threads: int,
    address: str | None,
    options: dict[str, Any],
    names: dict[tuple[str, str], str],
) -> dict[tuple[str, str], list[dict[str, Any]]]:
    """:func:`evaluate` once the output folder is locked."""
    started = False
    if not ray.is_initialized():
        if address is None:
            init_local_ray(num_workers, threads)
        else:
            ray.init(
                address=address,
                runtime_env={"env_vars": {"RAYON_NUM_THREADS": str(threads)}},
            )
        started = True
    try:
        runner = ray.remote(num_cpus=1)(TrialRunner)
        actors = [
            runner.remote(models_dir, demos_dir, resolution, correspond, options)  # type: ignore[attr-defined]
            for _ in range(num_workers)
        ]
        paths: dict[tuple[str, str], Path] = {}
        done: dict[tuple[str, str], dict[int, dict[str, Any]]] = {}
        todo: list[tuple[str, str, int, int]] = []
        for m in methods:
            for t in tasks:
                path = Path(records_path(Path(out_dir), names[(m, t)], t))
                paths[(m, t)] = path
                done[(m, t)] = recorded(path)
                todo.extend((m, t, s, index) for index, s in enumerate(seeds) if s not in done[(m, t)])
        # Each actor is handed its next trial when one of its two finishes
        # (one running, one waiting, so it never idles on the driver), in
        # the order above: an actor stays on one (method, task) while it
        # lasts, and the last trials go to whichever actors are free rather
        # than to a queue fixed at the start.
        queue = iter(todo)
        pending: dict[Any, Any] = {}

        def hand(actor: Any) -> None:
            unit = next(queue, None)
            if unit is not None:
                pending[actor.run.remote(*unit)] = actor

        for actor in actors:
            hand(actor)
            hand(actor)
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            actor = pending.pop(ready[0])
            m, t, s, line = ray.get(ready[0])
            hand(actor)
            append(paths[(m, t)], line)
            done[(m, t)][s] = json.loads(line)
        return {
            key: [recs[s] for s in sorted(recs) if s in seeds] for key, recs in done.items()
        }
    finally:
        if started:
            ray.shutdown()


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m seespot.dist", description=__doc__.split("\n\n")[0])
    p.add_argument("--method", action="append", choices=METHODS, help="repeatable; default ssr-ccd")
    p.add_argument("--task", default="all", help="a task id, or all")
    p.add_argument("--trials", type=int, default=50)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", default="runs/eval", help="where records go (the shipped table only when named: --out results)")
    p.add_argument("--models", default="models")
    p.add_argument("--demos", default="demos")
    p.add_argument("--resolution", type=int, default=DEFAULT_RESOLUTION)
    p.add_argument("--correspond", default="reference", help="reference (the default) or plain")
    # Correspond's options, named as `seespot eval --help` names them.
    p.add_argument("--rematch", default=None, help="window (the default) or global")
    p.add_argument("--demo-features", default=None, help="zeroed (the default) or real")
    p.add_argument("--smoothing", default=None, help="reference (the default) or normalized")
    p.add_argument("--smooth-sigma", type=float, default=None, help="with --correspond plain: sigma in pixels")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--address", default=None, help="a Ray cluster's address (default: local)")
    p.add_argument("--embeddings", nargs="+", default=None, help="an embedding set: a folder of <task>.onnx or ONNX files")
    p.add_argument("--finetune-steps", type=int, default=0)
    p.add_argument("--finetune-procedure", default="reference")
    p.add_argument("--noise", default=None, help="a scene file with a [noise] table")
    p.add_argument("--truth", action="store_true", help="label every decision with the simulator's truth (seespot eval --truth)")
    a = p.parse_args(argv)
    try:
        _import_ray()
    except ImportError as e:
        p.exit(2, f"{p.prog}: error: {e}\n")
    tasks = TASKS if a.task == "all" else [a.task]
    options = {"rematch": a.rematch, "demo_features": a.demo_features, "smoothing": a.smoothing, "smooth_sigma": a.smooth_sigma}
    given = {k: v for k, v in options.items() if v is not None}
    correspond: str | dict[str, Any] = {"correspond": a.correspond, **given} if given else a.correspond
    result = evaluate(
        a.method or ["ssr-ccd"],
        tasks,
        seed=a.seed,
        trials=a.trials,
        out_dir=a.out,
        models_dir=a.models,
        demos_dir=a.demos,
        resolution=a.resolution,
        correspond=correspond,
        num_workers=a.workers,
        address=a.address,
        embeddings=a.embeddings,
        finetune_steps=a.finetune_steps,
        finetune_procedure=a.finetune_procedure,
        noise=a.noise,
        truth=a.truth,
    )
    for (m, t), recs in result.items():
        ok = sum(r["success"] for r in recs)
        print(f"{m} {t}: success {ok}/{len(recs)}")


if __name__ == "__main__":
    main()
