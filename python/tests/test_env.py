"""The gymnasium environments: check_env, determinism, AsyncVectorEnv."""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import seespot  # noqa: F401  (registers the environments)
from seespot.env import ENV_IDS

RES = 64


@pytest.mark.parametrize("env_id", sorted(ENV_IDS.values()))
def test_check_env(env_id: str) -> None:
    env = gym.make(env_id, resolution=RES)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_same_seed_same_arrays() -> None:
    def run() -> list[np.ndarray]:
        env = gym.make("seespot/Stack-v0", resolution=RES)
        obs, _ = env.reset(seed=7)
        out = [obs["color"].copy(), obs["depth"].copy()]
        for a in [(0, 20, 30), (3, 40, 10), (5, 33, 33)]:
            obs, *_ = env.step(np.array(a))
            out += [obs["color"].copy(), obs["depth"].copy()]
        return out

    for a, b in zip(run(), run(), strict=True):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)


def test_spaces_and_info() -> None:
    env = gym.make("seespot/Row-v0", resolution=RES)
    obs, info = env.reset(seed=1)
    assert obs["color"].shape == (RES, RES, 3) and obs["color"].dtype == np.uint8
    assert obs["depth"].shape == (RES, RES) and obs["depth"].dtype == np.float32
    assert env.action_space.nvec.tolist() == [16, RES, RES]
    assert 1 <= info["progress"] <= 4


def test_truncated_at_30_actions() -> None:
    env = gym.make("seespot/Stack-v0", resolution=RES)
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    for k in range(30):
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        if terminated:
            pytest.skip("ended early (a block left the workspace)")
        assert truncated == (k == 29)


def test_async_vector_env() -> None:
    # "seespot:" imports seespot (registering the ids) in each spawned worker.
    fns = [lambda: gym.make("seespot:seespot/Unstack-v0", resolution=RES) for _ in range(2)]
    pickle.dumps(gym.make("seespot/Unstack-v0", resolution=RES).spec)
    envs = gym.vector.AsyncVectorEnv(fns, context="spawn")
    try:
        obs, info = envs.reset(seed=[1, 3])
        assert obs["color"].shape == (2, RES, RES, 3)
        obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
        assert reward.shape == (2,)
    finally:
        envs.close()
