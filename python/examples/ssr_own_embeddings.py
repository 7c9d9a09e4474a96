# %% [markdown]
# # See-SPOT-Run on your own embeddings
#
# Correspond (match, Eq. 4-5; rematch, Eq. 6; cycle consistency distance C,
# Eq. 7) works on any `float32[R, H, W, D]` action-state embeddings, for
# example the per-pixel features of your own PyTorch network. Here the
# "network" is a fixed random projection of the heightmaps, so the script runs
# with numpy alone; swap in `net(x).permute(0, 2, 3, 1).numpy()`.
#
#     .venv-py/bin/python python/examples/ssr_own_embeddings.py

# %%
import sys

try:
    import numpy as np

    import seespot
except ModuleNotFoundError as e:
    sys.exit(
        f"this example needs the seespot package and numpy, and this Python "
        f"({sys.executable}) has no module {e.name!r}. From the repository root, either\n"
        f"  scripts/test-python   # makes .venv-py with all of them (and runs the package's tests)\n"
        f"  .venv-py/bin/python python/examples/ssr_own_embeddings.py\n"
        f"or\n"
        f"  python3 -m venv .venv && .venv/bin/pip install .   # compiles the Rust core\n"
        f"  .venv/bin/python python/examples/ssr_own_embeddings.py"
    )

rng = np.random.default_rng(0)
W_PROJ = rng.normal(size=(4, 16)).astype(np.float32)  # (r, g, b, depth) -> D = 16


def my_embeddings(color: np.ndarray, depth: np.ndarray, rotations: int = 4) -> np.ndarray:
    """float32[R, H, W, D]: per-pixel features, rotated with np.rot90 per rotation."""
    x = np.concatenate([color / 255.0, depth[..., None] * 10.0], axis=-1).astype(np.float32)
    f = x @ W_PROJ
    return np.stack([np.rot90(f, k) for k in range(rotations)]).astype(np.float32)


# %% A demonstration scene and a live scene of the same task.
demo_trial, live_trial = seespot.Trial("row", 2), seespot.Trial("row", 1)
demo = my_embeddings(*demo_trial.observe())
live = my_embeddings(*live_trial.observe())

# The demonstrated grasp: the top of the highest block of the demo scene.
_, depth = demo_trial.observe()
y, x = np.unravel_index(int(np.argmax(depth)), depth.shape)
pair = seespot.correspond(live, demo, (0, int(y), int(x)))
print("matched live action F =", pair["matched"], "L =", round(pair["l"], 3))
print("rematch into the demo =", pair["rematch"], "C =", round(pair["c"], 2), "pixels")

# %% The pieces one by one, and a mask of allowed live actions.
mask = np.zeros(live.shape[:3], bool)
mask[:, 8:-8, 8:-8] = True
actions, distances = seespot.match_queries(live, demo[0, y, x][None], mask=mask)
print("masked match:", actions[0], distances[0])

# %% The shipped See-SPOT-Run, with its full explanation.
ssr = seespot.Ssr("row")  # policies of stack, unstack, vertical-square; row's two demos
color, depth = live_trial.observe()
d = ssr.decide(color, depth, live_trial.progress, live_trial.next_primitive)
for k, p in enumerate(d["pairs"]):
    mark = "*" if k == d["chosen"] else " "
    print(f"{mark} policy {p['policy']:>15} demo {p['demo']}: L {p['l']:.3f} C {p['c']:.1f}")
