"""seespot from Python: See-SPOT-Run's block world, SPOT-Q policies and
Correspond (match, rematch, CCD) with a Rust core (``seespot._core``).

Arrays are numpy: heightmaps are colour ``uint8[H, W, 3]`` and depth
``float32[H, W]`` (metres above the table); Q maps ``float32[R, H, W]``;
action-state embeddings ``float32[R, H, W, D]``; actions ``(rotation, y, x)``
indices into those grids. Bad arguments raise ``ValueError`` naming the
argument. Long calls release the GIL.

    >>> import seespot
    >>> trial = seespot.Trial("stack", seed=1)
    >>> color, depth = trial.observe()

The gymnasium environments ``seespot/Stack-v0``, ``seespot/Row-v0``,
``seespot/Unstack-v0`` and ``seespot/VerticalSquare-v0`` are registered on import;
``seespot.dist`` runs the leave-one-out evaluation on Ray.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

from seespot._core import (
    DEFAULT_RESOLUTION,
    EXTENSIONS,
    MAX_TRIAL_ACTIONS,
    METHODS,
    NUM_ROTATIONS,
    TASKS,
    Evaluator,
    OutputLock,
    Policy,
    Ssr,
    Trial,
    __version__,
    append_record,
    ccd,
    check_resolution,
    correspond,
    demo_dirs,
    distance_map,
    match_queries,
    read_records,
    record_demo,
    record_name,
    records_path,
    rematch,
    run_spec,
    test_seeds,
)
from seespot import _core
from seespot.env import register_envs

__all__ = [
    "DEFAULT_RESOLUTION",
    "MAX_TRIAL_ACTIONS",
    "EXTENSIONS",
    "METHODS",
    "NUM_ROTATIONS",
    "TASKS",
    "Evaluator",
    "OutputLock",
    "Policy",
    "Ssr",
    "Trial",
    "__version__",
    "append_record",
    "ccd",
    "check_resolution",
    "correspond",
    "demo_dirs",
    "distance_map",
    "match_queries",
    "read_records",
    "record_demo",
    "record_name",
    "records_path",
    "rematch",
    "replay",
    "run_spec",
    "run_trial",
    "test_seeds",
    "truth",
    "view",
]


def run_trial(
    method: str,
    task: str,
    seed: int,
    *,
    index: int = 0,
    models_dir: str = "models",
    demos_dir: str = "demos",
    resolution: int = DEFAULT_RESOLUTION,
    correspond: str | dict[str, Any] | None = None,
    embeddings: Any = None,
    truth: bool = False,
) -> dict[str, Any]:
    """Runs one trial of ``method`` on ``task`` from ``seed`` and returns its
    record: the object ``seespot eval`` writes as one JSONL line (``index`` is
    the trial's number in the run, ``trial`` in the record). ``correspond``
    (SSR only): None for the reference's Correspond, ``"plain"``, or a dict of
    Correspond's settings as records hold them (``{"rematch": "global"}``).
    ``embeddings``
    (SSR only): a folder of ``<task>.onnx`` files, a list of ONNX files, or
    functions (a ``torch.nn.Module``, a callable, a ``(grasp, place)`` pair;
    :mod:`seespot.embedding`) used in place of the SPOT-Q policies
    (docs/embeddings.md). ``truth``: label every decision with the
    simulator's truth (``seespot eval --truth``, docs/truth.md): each entry of
    ``actions_log`` gains ``truth``, the executed action's and every pair's F
    verdict (``right``, ``wrong_block``, ``miss``, ...), why, and distance to
    a right action; the trial is the same as without it."""
    ev = Evaluator(method, task, models_dir, demos_dir, resolution, correspond, embeddings, truth=truth)
    record: dict[str, Any] = json.loads(ev.run(seed, index))
    return record


def truth(
    task: str = "all",
    *,
    split: str = "validation",
    starts: int = 20,
    embeddings: Any = None,
    models_dir: str = "models",
    demos_dir: str = "demos",
    resolution: int = DEFAULT_RESOLUTION,
    finetune_steps: int = 0,
    finetuned_dir: str = "results",
) -> dict[str, Any]:
    """Is the match right? The correspondence benchmark (``seespot truth``,
    docs/truth.md) in this process: See-SPOT-Run asked at the states the
    oracle passes through from ``starts`` seeds of ``split`` per task, each
    pair's F judged by the simulator on a copy of the world. Returns the
    report: ``rows`` (``[task, primitive, summary]``, the last for all
    probes: match and selection accuracy, the McNemar test of CCD against
    L2CD, the AUC of -C and -L, precision at C = 0, CCD's picks within 0 to
    50 mm), ``answers`` (every probe's pairs with their truth), ``commit``.
    ``embeddings`` as :class:`Ssr` takes them, functions included;
    ``resolution`` the probe states' grid (112 with the 112 px set's models
    and demos); ``finetune_steps`` (333: the paper's finetuned row) asks the
    SPOT-Q policies finetuned as the reference finetunes, read from
    ``finetuned_dir/finetuned/`` as ``seespot eval`` writes them."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "truth.json"
        argv = ["seespot", "truth", "--task", task, "--split", split, "--starts", str(starts)]
        argv += ["--models", str(models_dir), "--demos", str(demos_dir), "--json", str(out)]
        argv += ["--resolution", str(resolution)]
        if finetune_steps:
            argv += ["--finetune-steps", str(finetune_steps), "--finetuned", str(finetuned_dir)]
        if embeddings is not None:
            argv += ["--embeddings", *_core.register_embeddings(embeddings)]
        code = _core.cli_in_process(argv)
        if code != 0:
            raise ValueError(f"seespot truth failed (exit {code}); its message is above")
        report: dict[str, Any] = json.loads(out.read_text())
        return report


def view(*args: str, embeddings: Any = None) -> int:
    """Runs the debugger page (``seespot view ARGS``) in this process until
    Ctrl-C, and returns its exit status. ``embeddings`` as :class:`Ssr` takes
    them, functions and ``torch.nn.Module`` s included: the page then runs
    See-SPOT-Run on them with no export (:mod:`seespot.embedding`).

        >>> seespot.view("--task", "row", embeddings=[MyNet()])

    Run it from a folder holding ``models/`` and ``demos/``. In a notebook,
    start it in a thread (``threading.Thread(target=seespot.view, ...)``):
    it releases the GIL while it serves."""
    import threading

    from seespot import cli

    argv = ["view", *args]
    if embeddings is not None:
        argv += ["--embeddings", *_core.register_embeddings(embeddings)]
    if threading.current_thread() is threading.main_thread():
        return cli.main(argv)
    # Signal handlers belong to the main thread: a page served from another
    # thread stops with the process.
    return _core.cli_in_process(["seespot", *argv])


def replay(
    trial: Trial,
    record: dict[str, Any],
    where: str,
    observe: bool = False,
    limit: int | None = None,
) -> Iterator[tuple[dict[str, Any], dict[str, Any], Any]]:
    """Steps ``trial`` (started from ``record``'s task and seed) through the
    record's ``actions_log`` (the first ``limit`` actions when given),
    yielding for each action its log entry, what :meth:`Trial.step` returned
    and, with ``observe``, the heightmaps ``(color, depth)`` it was taken in
    (else None). The simulator is deterministic, so a start or a step that
    does not reach the record's progress (or primitive) means other inputs or
    another seespot version: ``ValueError`` naming ``where`` and the field."""
    if trial.progress != record["start_progress"]:
        raise ValueError(
            f"{where}: the re-simulated start has progress {trial.progress}, "
            f"the record `start_progress` {record['start_progress']}"
        )
    for i, entry in enumerate(record["actions_log"][:limit]):
        a = entry["action"]
        seen = trial.observe() if observe else None
        step = trial.step(int(a["rotation"]), int(a["y"]), int(a["x"]))
        if step["primitive"] != a["primitive"] or step["progress_after"] != entry["progress_after"]:
            raise ValueError(
                f"{where}: field `actions_log[{i}]`: re-simulated {step['primitive']} reached progress "
                f"{step['progress_after']}, the record says {a['primitive']} reached {entry['progress_after']} "
                "(made by another simulator version?)"
            )
        yield entry, step, seen


register_envs()
