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


def test_native_vector_env_matches_the_single_environments() -> None:
    """`gym.make_vec` gives the native vector environment (Rust threads):
    the same observations, rewards and ends as one `SeespotEnv` per slot,
    and NEXT_STEP autoreset (the step after an end starts that slot again)."""
    from gymnasium.vector import AutoresetMode

    from seespot.env import SeespotVectorEnv

    n = 3
    venv = gym.make_vec("seespot/Stack-v0", num_envs=n, resolution=RES)
    assert isinstance(venv.unwrapped, SeespotVectorEnv)
    assert venv.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    singles = [gym.make("seespot/Stack-v0", resolution=RES) for _ in range(n)]
    obs, info = venv.reset(seed=5)
    assert venv.observation_space.contains(obs)
    for i, env in enumerate(singles):
        o, inf = env.reset(seed=5 + i)
        np.testing.assert_array_equal(obs["color"][i], o["color"])
        np.testing.assert_array_equal(obs["depth"][i], o["depth"])
        assert info["progress"][i] == inf["progress"]
    rng = np.random.default_rng(3)
    ended = np.zeros(n, dtype=bool)
    autoresets = 0
    for _ in range(40):
        actions = np.stack([rng.integers([0, 0, 0], [16, RES, RES]) for _ in range(n)])
        obs, reward, terminated, truncated, info = venv.step(actions)
        for i, env in enumerate(singles):
            if ended[i]:
                # The slot started again: no reward, no end, a fresh trial.
                assert reward[i] == 0 and not terminated[i] and not truncated[i]
                assert info["actions"][i] == 0
                o, _ = env.reset(seed=int(info["seed"][i]))
                autoresets += 1
            else:
                o, r, te, tr, _ = env.step(actions[i])
                assert (reward[i], terminated[i], truncated[i]) == (r, te, tr)
            np.testing.assert_array_equal(obs["color"][i], o["color"])
            np.testing.assert_array_equal(obs["depth"][i], o["depth"])
            assert obs["primitive"][i] == o["primitive"]
        ended = terminated | truncated
    assert autoresets > 0, "no slot ended in 40 random actions (30 is the limit)"
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.zeros((n, 2), dtype=np.int64))
    with pytest.raises(ValueError, match=r"actions\[0\]"):
        venv.step(np.full((n, 3), RES, dtype=np.int64))
    venv.close()


def test_native_vector_env_prefetched_starts() -> None:
    """Each slot's next start is built in the background from a seed drawn
    when its episode starts: the same seed gives the same autoreset seeds,
    `reset()` without a seed takes the prefetched starts, and a prefetch for
    another seed than the one asked for is not used."""
    from seespot._core import Trial, VectorTrials

    def seeds_seen(reset_seed: int) -> list[list[int]]:
        venv = gym.make_vec("seespot/Stack-v0", num_envs=2, resolution=RES)
        _, info = venv.reset(seed=reset_seed)
        seen = [list(info["seed"])]
        actions = np.zeros((2, 3), dtype=np.int64)
        for _ in range(31):  # every slot reaches the 30-action limit once
            _, _, _, _, info = venv.step(actions)
            seen.append(list(info["seed"]))
        _, info = venv.reset()
        seen.append(list(info["seed"]))
        venv.close()
        return seen

    first = seeds_seen(11)
    assert first == seeds_seen(11)
    assert first[0] == [11, 12] and first[-2] != first[0], "no autoreset happened"

    trials = VectorTrials("stack", [1, 2], RES)
    trials.prefetch(np.array([7, -1], dtype=np.int64))
    batch = trials.reset([8, 9])
    color, _ = Trial("stack", 8, RES).observe()
    np.testing.assert_array_equal(batch["color"][0], color)
    with pytest.raises(ValueError, match="seeds"):
        trials.prefetch(np.array([1], dtype=np.int64))
