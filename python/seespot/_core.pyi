"""Types of the Rust core ``seespot._core`` (app/py); see its module docs."""

import os
import pathlib
from collections.abc import Mapping, Sequence
from typing import Any, TypeAlias, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "EXTENSIONS",
    "MAX_TRIAL_ACTIONS",
    "METHODS",
    "NUM_ROTATIONS",
    "DEFAULT_RESOLUTION",
    "TASKS",
    "Evaluator",
    "OutputLock",
    "Policy",
    "Ssr",
    "Trial",
    "VectorTrials",
    "__version__",
    "append_record",
    "ccd",
    "check_resolution",
    "cli",
    "cli_in_process",
    "correspond",
    "demo_dirs",
    "distance_map",
    "match_queries",
    "read_records",
    "record_demo",
    "record_name",
    "records_path",
    "register_embeddings",
    "rematch",
    "run_spec",
    "test_seeds",
]

__version__: str
TASKS: list[str]
METHODS: list[str]
EXTENSIONS: list[tuple[str, str, list[str]]]
"""seespot's extensions of See-SPOT-Run: (name, the information it reads:
``heightmaps``, ``progress`` or ``simulator``, the extensions it needs), in
the order they run (docs/extensions.md)."""
NUM_ROTATIONS: int
DEFAULT_RESOLUTION: int
"""Heightmap pixels per side of the shipped set (224, 2 mm/px): the default
of every ``resolution`` argument below (shown as ``...``)."""
MAX_TRIAL_ACTIONS: int

_Ix3: TypeAlias = tuple[int, int, int]

@final
class Trial:
    def __new__(
        cls, task: str, seed: int, resolution: int = ..., demos_dir: str | os.PathLike[str] = ...
    ) -> Trial: ...
    @staticmethod
    def from_scene(path: str | os.PathLike[str], index: int = 0) -> Trial: ...
    @property
    def task(self) -> str: ...
    @property
    def seed(self) -> int: ...
    @property
    def resolution(self) -> int: ...
    @property
    def progress(self) -> int: ...
    @property
    def max_progress(self) -> int: ...
    @property
    def actions(self) -> int: ...
    @property
    def end(self) -> str | None: ...
    @property
    def next_primitive(self) -> str: ...
    def block_poses(self) -> npt.NDArray[np.float32]: ...
    def observe(self) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.float32]]: ...
    def step(self, rotation: int, y: int, x: int) -> dict[str, Any]: ...
    def truth(self, rotation: int, y: int, x: int, before_grasp: int | None = None) -> dict[str, Any]: ...

@final
class VectorTrials:
    def __new__(
        cls,
        task: str,
        seeds: list[int],
        resolution: int = ...,
        demos_dir: str | os.PathLike[str] = ...,
    ) -> VectorTrials: ...
    @property
    def num_envs(self) -> int: ...
    def reset(self, seeds: list[int]) -> dict[str, npt.NDArray[Any]]: ...
    def step(
        self, actions: npt.NDArray[np.int64], reset_seeds: npt.NDArray[np.int64]
    ) -> dict[str, npt.NDArray[Any]]: ...
    def prefetch(self, seeds: npt.NDArray[np.int64]) -> None: ...

@final
class Policy:
    def __new__(cls, path: str | os.PathLike[str]) -> Policy: ...
    @property
    def task(self) -> str: ...
    @property
    def resolution(self) -> int: ...
    def q_values(
        self, color: npt.ArrayLike, depth: npt.ArrayLike, primitive: str
    ) -> npt.NDArray[np.float32]: ...
    def embed(
        self, color: npt.ArrayLike, depth: npt.ArrayLike, primitive: str
    ) -> npt.NDArray[np.float32]: ...

@final
class Ssr:
    def __new__(
        cls,
        task: str,
        models_dir: str | os.PathLike[str] = ...,
        demos_dir: str | os.PathLike[str] = ...,
        method: str = "ssr-ccd",
        correspond: str | Mapping[str, Any] | None = None,
        embeddings: Any = None,
        extensions: Sequence[str] | None = None,
    ) -> Ssr: ...
    @property
    def extensions(self) -> list[str]: ...
    @property
    def information(self) -> str: ...
    @property
    def title(self) -> str: ...
    def act(self, trial: Trial) -> dict[str, Any]: ...
    @property
    def policy_names(self) -> list[str]: ...
    def decide(
        self, color: npt.ArrayLike, depth: npt.ArrayLike, progress: int, primitive: str
    ) -> dict[str, Any]: ...

@final
class Evaluator:
    def __new__(
        cls,
        method: str,
        task: str,
        models_dir: str | os.PathLike[str] = ...,
        demos_dir: str | os.PathLike[str] = ...,
        resolution: int = ...,
        correspond: str | Mapping[str, Any] | None = None,
        embeddings: Any = None,
        finetune_steps: int = 0,
        finetune_procedure: str = "reference",
        noise: str | os.PathLike[str] | None = None,
        out_dir: str | os.PathLike[str] = ...,
        truth: bool = False,
    ) -> Evaluator: ...
    @property
    def record_name(self) -> str: ...
    @property
    def task(self) -> str: ...
    def run(self, seed: int, index: int) -> str: ...

def check_resolution(resolution: int) -> int: ...
def cli(argv: list[str]) -> int: ...
def cli_in_process(argv: list[str]) -> int: ...
def register_embeddings(embeddings: Any) -> list[str]: ...
def demo_dirs(task: str, demos_dir: str | os.PathLike[str] = ...) -> list[pathlib.Path]: ...
def test_seeds(start: int, count: int) -> list[int]: ...
def records_path(out_dir: str | os.PathLike[str], method: str, task: str) -> pathlib.Path: ...
def record_name(method: str, correspond: str | Mapping[str, Any] | None = None) -> str: ...
def run_spec(name: str) -> dict[str, Any]: ...
def read_records(path: str | os.PathLike[str]) -> list[str]: ...
def append_record(path: str | os.PathLike[str], line: str) -> None: ...
def record_demo(
    task: str,
    seed: int,
    actions: list[tuple[str, int, int, int]],
    out: str | os.PathLike[str],
    resolution: int = ...,
    colours_matter: bool = False,
    overwrite: bool = False,
) -> int: ...

@final
class OutputLock:
    def __new__(cls, out_dir: str | os.PathLike[str]) -> OutputLock: ...
    def release(self) -> None: ...
    @property
    def held(self) -> bool: ...
    def __enter__(self) -> OutputLock: ...
    def __exit__(self, *exception: object) -> bool: ...
def match_queries(
    live: npt.ArrayLike, queries: npt.ArrayLike, mask: npt.ArrayLike | None = None
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float32]]: ...
def rematch(
    demo: npt.ArrayLike,
    query: npt.ArrayLike,
    rotation: int | None = None,
    mask: npt.ArrayLike | None = None,
) -> tuple[_Ix3, float]: ...
def ccd(demo_action: _Ix3, rematch: _Ix3) -> float: ...
def correspond(
    live: npt.ArrayLike,
    demo: npt.ArrayLike,
    demo_action: _Ix3,
    live_mask: npt.ArrayLike | None = None,
    demo_mask: npt.ArrayLike | None = None,
) -> dict[str, Any]: ...
def distance_map(
    embeddings: npt.ArrayLike, query: npt.ArrayLike, rotation: int
) -> npt.NDArray[np.float32]: ...
