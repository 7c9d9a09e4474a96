# %% [markdown]
# # See-SPOT-Run on your own network (ONNX)
#
# Builds a small embedding network with the `onnx` package alone (no
# framework, no GPU), saves it, runs See-SPOT-Run on it and opens the
# debugger on it. The contract the file follows is docs/embeddings.md: one
# input `float32[rotations, 4, 112, 112]` (the rotated scene: colour
# `v / 255 - 0.5` and height `/ 0.1 m` on a 4 mm grid), one output
# `float32[rotations, D, S, S]` with S dividing 112 (here D = 16, S = 28:
# stride 4, the shipped policies' stride).
#
#     .venv-py/bin/python python/examples/ssr_onnx_network.py           # SSR decision and one trial
#     .venv-py/bin/python python/examples/ssr_onnx_network.py --view    # and the debugger on it

# %%
import sys
import tempfile
from pathlib import Path

try:
    import numpy as np
    from onnx import TensorProto, checker, helper, numpy_helper, save

    import seespot
except ModuleNotFoundError as e:
    sys.exit(
        f"this example needs the seespot package, numpy and onnx, and this Python "
        f"({sys.executable}) has no module {e.name!r}. From the repository root, either\n"
        f"  scripts/test-python   # makes .venv-py with all of them (and runs the package's tests)\n"
        f"  .venv-py/bin/python python/examples/ssr_onnx_network.py --view\n"
        f"or\n"
        f"  python3 -m venv .venv && .venv/bin/pip install . onnx   # compiles the Rust core\n"
        f"  .venv/bin/python python/examples/ssr_onnx_network.py --view"
    )


def build_network(path: Path, depth: int = 16, seed: int = 0) -> Path:
    """A fixed random 3 x 3 convolution, stride 4, from the four input
    channels to `depth` features, then a ReLU: one output shared by both
    primitives. Cell k of the output is centred on input pixel 4k (pads 1)."""
    rng = np.random.default_rng(seed)
    weights = rng.normal(scale=0.5, size=(depth, 4, 3, 3)).astype(np.float32)
    scene = helper.make_tensor_value_info("scene", TensorProto.FLOAT, ["rotations", 4, 112, 112])
    features = helper.make_tensor_value_info("features", TensorProto.FLOAT, ["rotations", depth, 28, 28])
    nodes = [
        helper.make_node("Conv", ["scene", "w"], ["pre"], kernel_shape=[3, 3], strides=[4, 4], pads=[1, 1, 1, 1]),
        helper.make_node("Relu", ["pre"], ["features"]),
    ]
    graph = helper.make_graph(nodes, "my-network", [scene], [features], [numpy_helper.from_array(weights, "w")])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    checker.check_model(model)
    save(model, str(path))
    return path


# %% Build it.
out = Path(sys.argv[2] if len(sys.argv) > 2 and sys.argv[1] == "--out" else tempfile.mkdtemp())
net = build_network(out / "my-network.onnx")
print("wrote", net)

# %% One SSR decision with it: M = 1 model (the file), N = 2 demonstrations.
ssr = seespot.Ssr("row", embeddings=[str(net)])
trial = seespot.Trial("row", 1)
color, depth = trial.observe()
d = ssr.decide(color, depth, trial.progress, trial.next_primitive)
for k, p in enumerate(d["pairs"]):
    mark = "*" if k == d["chosen"] else " "
    print(f"{mark} model {p['policy']} demo {p['demo']}: L {p['l']:.3f} C {p['c']:.1f}")

# %% A whole trial, recorded as `seespot eval` records it (run name `ssr-ccd@my-network`).
record = seespot.run_trial("ssr-ccd", "row", 1, embeddings=[str(net)])
print(record["method"], "seed", record["seed"], "success", record["success"], "in", record["actions"], "actions")

# %% The debugger on it (Ctrl-C to stop): the page shows each pair, the
# match and rematch maps, click-to-query and what the network sees.
if "--view" in sys.argv:
    from seespot.cli import main

    main(["view", "--task", "row", "--embeddings", str(net)])
