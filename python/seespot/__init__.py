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
from typing import Any

from seespot._core import (
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
from seespot.env import register_envs

__all__ = [
    "MAX_TRIAL_ACTIONS",
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
    "distance_map",
    "match_queries",
    "read_records",
    "record_demo",
    "record_name",
    "records_path",
    "rematch",
    "run_spec",
    "run_trial",
    "test_seeds",
]


def run_trial(
    method: str,
    task: str,
    seed: int,
    *,
    index: int = 0,
    models_dir: str = "models",
    demos_dir: str = "demos",
    resolution: int = 112,
    correspond: str = "reference",
) -> dict[str, Any]:
    """Runs one trial of ``method`` on ``task`` from ``seed`` and returns its
    record: the object ``seespot eval`` writes as one JSONL line (``index`` is
    the trial's number in the run, ``trial`` in the record)."""
    ev = Evaluator(method, task, models_dir, demos_dir, resolution, correspond)
    record: dict[str, Any] = json.loads(ev.run(seed, index))
    return record


register_envs()
