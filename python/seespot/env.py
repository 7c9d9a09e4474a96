"""The gymnasium environments: one per task, ``seespot/Stack-v0``,
``seespot/Row-v0``, ``seespot/Unstack-v0``, ``seespot/VerticalSquare-v0``.

Observation: a dict of ``color`` (``uint8[H, W, 3]``), ``depth``
(``float32[H, W]``, metres above the table, clipped to ``[0, 1]``) and
``primitive`` (0 = grasp, 1 = place: the primitive the next action uses).
Action: ``(rotation, y, x)`` in ``MultiDiscrete([16, H, W])``. Reward: the
change in task progress (Sec. 3 of the paper; progress runs 1..=4).
``terminated`` on success or a block leaving the workspace, ``truncated`` at
30 actions; ``info`` holds ``progress``, ``max_progress``, ``seed`` and the
last step's outcome. With ``truth=True`` (``gym.make("seespot/Stack-v0",
truth=True)``), ``info["truth"]`` also holds the simulator's truth about the
action just taken, worked out on a copy of the world before it ran
(``verdict``, ``why``, ``distance_mm``; docs/truth.md): a measurement for the
experimenter, not an observation for the agent.

``gym.make_vec("seespot/Stack-v0", num_envs=8)`` gives the native vector
environment, :class:`SeespotVectorEnv` (the ``vector_entry_point``): the N
trials step together on Rust threads with the GIL released, and the batch
comes back as one array per field. Its autoreset mode is ``NEXT_STEP``, as
gymnasium's own vector environments: the step after an episode ends starts
it again from a new seed (that step's action for it is ignored, its reward
is 0 and it is neither terminated nor truncated).
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from seespot._core import (
    DEFAULT_RESOLUTION,
    MAX_TRIAL_ACTIONS,
    NUM_ROTATIONS,
    Trial,
    VectorTrials,
    check_resolution,
)

ENV_IDS = {
    "stack": "seespot/Stack-v0",
    "row": "seespot/Row-v0",
    "unstack": "seespot/Unstack-v0",
    "vertical-square": "seespot/VerticalSquare-v0",
}

# Depth above the table is at most a few blocks (5 cm each); 1 m bounds it.
MAX_DEPTH = 1.0

Obs = dict[str, Any]


def _spaces(resolution: int) -> tuple[spaces.Dict, spaces.MultiDiscrete]:
    """One environment's observation and action spaces at ``resolution``."""
    n = resolution
    observation = spaces.Dict(
        {
            "color": spaces.Box(0, 255, shape=(n, n, 3), dtype=np.uint8),
            "depth": spaces.Box(0.0, MAX_DEPTH, shape=(n, n), dtype=np.float32),
            "primitive": spaces.Discrete(2),
        }
    )
    return observation, spaces.MultiDiscrete([NUM_ROTATIONS, n, n])


class SeespotEnv(gym.Env[Obs, np.ndarray]):
    """One task of the block world as a gymnasium environment. Seeds: an
    explicit ``reset(seed=s)`` starts trial ``s`` (odd seeds are the test
    split); without one, the next seed is drawn from ``np_random``."""

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"]}

    def __init__(
        self,
        task: str,
        resolution: int = DEFAULT_RESOLUTION,
        render_mode: str | None = None,
        truth: bool = False,
    ):
        if task not in ENV_IDS:
            raise ValueError(f"task: unknown task '{task}' (expected one of {sorted(ENV_IDS)})")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode: '{render_mode}' is not None or 'rgb_array'")
        self.task = task
        self.resolution = check_resolution(resolution)
        self.render_mode = render_mode
        self.observation_space, self.action_space = _spaces(self.resolution)
        self.truth = truth
        self._trial: Trial | None = None
        self._color: np.ndarray | None = None
        self._before_grasp = 0

    def _obs(self) -> Obs:
        assert self._trial is not None
        color, depth = self._trial.observe()
        np.clip(depth, 0.0, MAX_DEPTH, out=depth)
        self._color = color
        return {
            "color": color,
            "depth": depth,
            "primitive": 0 if self._trial.next_primitive == "grasp" else 1,
        }

    def _info(self) -> dict[str, Any]:
        assert self._trial is not None
        t = self._trial
        return {
            "progress": t.progress,
            "max_progress": t.max_progress,
            "seed": t.seed,
            "actions": t.actions,
            "end": t.end,
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Obs, dict[str, Any]]:
        super().reset(seed=seed)
        trial_seed = seed if seed is not None else int(self.np_random.integers(0, 2**31))
        self._trial = Trial(self.task, trial_seed, self.resolution)
        self._before_grasp = self._trial.progress
        return self._obs(), self._info()

    def step(self, action: Any) -> tuple[Obs, SupportsFloat, bool, bool, dict[str, Any]]:
        if self._trial is None:
            raise RuntimeError("step() before reset()")
        a = np.asarray(action)
        if a.shape != (3,):
            raise ValueError(f"action: expected (rotation, y, x), got shape {a.shape}")
        before = self._trial.progress
        truth = None
        if self.truth:
            if self._trial.next_primitive == "grasp":
                self._before_grasp = before
            truth = self._trial.truth(int(a[0]), int(a[1]), int(a[2]), self._before_grasp)
        outcome = self._trial.step(int(a[0]), int(a[1]), int(a[2]))
        obs = self._obs()
        info = self._info()
        info["primitive_success"] = outcome["primitive_success"]
        if truth is not None:
            info["truth"] = truth
        end = outcome["end"]
        terminated = end in ("success", "out-of-workspace")
        truncated = end == "action-limit" or (
            end is None and self._trial.actions >= MAX_TRIAL_ACTIONS
        )
        reward = float(self._trial.progress - before)
        return obs, reward, terminated, truncated, info

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        if self.render_mode == "rgb_array" and self._color is not None:
            return self._color
        return None


#: ``VectorTrials``' end codes.
_SUCCESS, _ACTION_LIMIT, _OUT_OF_WORKSPACE = 1, 2, 3


class SeespotVectorEnv(VectorEnv[Obs, np.ndarray, np.ndarray]):
    """``num_envs`` trials of one task stepped together in Rust
    (``seespot._core.VectorTrials``): the same observations, rewards and
    ends as ``num_envs`` copies of :class:`SeespotEnv`, batched. Seeds:
    ``reset(seed=s)`` starts trial i from ``s + i`` (a list gives each its
    own); without one, and at every autoreset, seeds are drawn from
    ``np_random``. Each trial's next seed is drawn when its episode starts, so
    that its next start is built in the background meanwhile (a start costs as
    much as about a hundred steps). ``info`` holds ``progress``, ``seed``,
    ``actions`` and ``primitive_success`` arrays, each with its ``_name``
    mask."""

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, task: str, num_envs: int = 1, resolution: int = DEFAULT_RESOLUTION, **kwargs: Any):
        if task not in ENV_IDS:
            raise ValueError(f"task: unknown task '{task}' (expected one of {sorted(ENV_IDS)})")
        if not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs: {num_envs!r} is not a positive integer")
        if kwargs.get("render_mode") is not None:
            raise ValueError("render_mode: the vector environment renders nothing")
        self.task = task
        self.num_envs = num_envs
        self.resolution = check_resolution(resolution)
        self.single_observation_space, self.single_action_space = _spaces(self.resolution)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._trials: VectorTrials | None = None
        self._ended = np.zeros(num_envs, dtype=bool)
        # Per trial, the seed of its next start (being built in the background).
        self._next: np.ndarray | None = None

    def _draw(self, count: int) -> np.ndarray:
        return self.np_random.integers(0, 2**31, count, dtype=np.int64)

    def _obs_info(self, batch: dict[str, Any]) -> tuple[Obs, dict[str, Any]]:
        depth = batch["depth"]
        np.clip(depth, 0.0, MAX_DEPTH, out=depth)
        obs = {"color": batch["color"], "depth": depth, "primitive": batch["primitive"]}
        info: dict[str, Any] = {}
        every = np.ones(self.num_envs, dtype=bool)
        for key in ("progress", "seed", "actions", "primitive_success"):
            info[key] = batch[key]
            info[f"_{key}"] = every
        return obs, info

    def reset(
        self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Obs, dict[str, Any]]:
        if isinstance(seed, list):
            if len(seed) != self.num_envs:
                raise ValueError(f"seed: {len(seed)} seeds for {self.num_envs} environments")
            super().reset(seed=seed[0])
            seeds = [int(s) for s in seed]
        elif seed is not None:
            super().reset(seed=seed)
            seeds = [seed + i for i in range(self.num_envs)]
        else:
            super().reset()
            drawn = self._next if self._next is not None else self._draw(self.num_envs)
            seeds = [int(s) for s in drawn]
        if self._trials is None:
            self._trials = VectorTrials(self.task, seeds, self.resolution)
        batch = self._trials.reset(seeds)
        self._ended[:] = False
        self._next = self._draw(self.num_envs)
        self._trials.prefetch(self._next)
        return self._obs_info(batch)

    def step(self, actions: Any) -> tuple[Obs, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if self._trials is None:
            raise RuntimeError("step() before reset()")
        a = np.asarray(actions, dtype=np.int64)
        if a.shape != (self.num_envs, 3):
            raise ValueError(f"actions: expected shape ({self.num_envs}, 3), got {a.shape}")
        assert self._next is not None
        started = self._ended
        resets = np.where(started, self._next, -1)
        batch = self._trials.step(a, resets)
        if started.any():
            self._next[started] = self._draw(int(started.sum()))
            self._trials.prefetch(np.where(started, self._next, -1))
        end = batch["end"]
        stepped = ~self._ended
        reward = np.where(stepped, batch["progress"] - batch["progress_before"], 0).astype(np.float64)
        terminated = stepped & ((end == _SUCCESS) | (end == _OUT_OF_WORKSPACE))
        truncated = stepped & ((end == _ACTION_LIMIT) | ((end == 0) & (batch["actions"] >= MAX_TRIAL_ACTIONS)))
        self._ended = terminated | truncated
        obs, info = self._obs_info(batch)
        return obs, reward, terminated, truncated, info


def register_envs() -> None:
    """Registers the four environments (idempotent)."""
    for task, env_id in ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point="seespot.env:SeespotEnv",
                vector_entry_point="seespot.env:SeespotVectorEnv",
                kwargs={"task": task},
                max_episode_steps=None,
            )
