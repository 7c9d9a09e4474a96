# %% [markdown]
# # Stepping the seespot block world from Python
#
# The four tasks are gymnasium environments. Observations are heightmaps:
# colour `uint8[H, W, 3]` and depth `float32[H, W]` (metres above the table);
# an action is a `(rotation, y, x)` index into the 16 x H x W grid, executed as
# the next primitive (grasp, then place, ...). Run from the repository root:
#
#     .venv-py/bin/python python/examples/env_stepping.py

# %%
import sys

try:
    import gymnasium as gym
    import numpy as np

    import seespot  # registers seespot/Stack-v0, Row-v0, Unstack-v0, VerticalSquare-v0
except ModuleNotFoundError as e:
    sys.exit(
        f"this example needs the seespot package, numpy and gymnasium, and this Python "
        f"({sys.executable}) has no module {e.name!r}. From the repository root, either\n"
        f"  scripts/test-python   # makes .venv-py with all of them (and runs the package's tests)\n"
        f"  .venv-py/bin/python python/examples/env_stepping.py\n"
        f"or\n"
        f"  python3 -m venv .venv && .venv/bin/pip install .   # compiles the Rust core\n"
        f"  .venv/bin/python python/examples/env_stepping.py"
    )

env = gym.make("seespot/Stack-v0")
obs, info = env.reset(seed=1)  # odd seeds are the paper's test seeds
print("colour", obs["color"].shape, obs["color"].dtype, "depth", obs["depth"].shape)
print("progress", info["progress"], "of 4")

# %% Random actions until the trial ends (30 actions at most).
rng = np.random.default_rng(0)
total = 0.0
while True:
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    total += float(reward)
    if terminated or truncated:
        break
print(f"random: {info['actions']} actions, progress {info['progress']}, end {info['end']}")

# %% The same world without gymnasium: a Trial, a shipped policy's Q values,
# and the greedy action.
trial = seespot.Trial("stack", seed=1)
policy = seespot.Policy("models/stack.safetensors")
while trial.end is None:
    color, depth = trial.observe()
    q = policy.q_values(color, depth, trial.next_primitive)  # float32[16, H, W]
    r, y, x = np.unravel_index(int(np.argmax(q)), q.shape)
    trial.step(int(r), int(y), int(x))
print(f"SPOT-Q greedy: {trial.actions} actions, end {trial.end}")
print("block poses (x, y, z, qx, qy, qz, qw):\n", trial.block_poses())
