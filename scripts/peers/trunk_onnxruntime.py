"""The onnxruntime peer of seespot's policy trunk (`seespot bench policy`,
`trunk_both_primitives_16_rotations`).

Exports the five convolutions (each with its ReLU) of a shipped seespot
policy, grasp and place nets, to one ONNX graph built with the `onnx`
package from the weights in the safetensors file, then times onnxruntime
on what seespot's trunk computes in a decision: 16 rotations x 2 primitives
of a 4 x 112 x 112 network input (each primitive's net on the same batch of
16). Inputs are uniform in [-0.5, 0.5), the range of the network's
normalised colour channels. Prints one JSON object: the median and best of
`--iterations` timed runs after a warm-up, in ms.
"""
import argparse
import json
import struct
import time

import numpy as np
import onnx
import onnxruntime as ort
from onnx import TensorProto, helper, numpy_helper

# The trunk of app/policy/src/net.rs: (name, stride, dilation); 3x3 kernels,
# padding = dilation, a ReLU after each. conv5's dilation is the weights
# file's: its architecture `spotq-fcn-s4-c64-dN` names it (N = 1 without -dN).
def trunk_layers(conv5_dilation):
    return [("conv1", 2, 1), ("conv2", 2, 1), ("conv3", 1, 1), ("conv4", 1, 2),
            ("conv5", 1, conv5_dilation)]


def conv5_dilation(metadata):
    tail = metadata.get("architecture", "").rsplit("-", 1)[-1]
    return int(tail[1:]) if tail.startswith("d") and tail[1:].isdigit() else 1


def read_safetensors(path):
    """The file's tensors by name, and its metadata."""
    with open(path, "rb") as f:
        n = struct.unpack("<Q", f.read(8))[0]
        header = json.loads(f.read(n))
        data = f.read()
    out = {}
    for name, t in header.items():
        if name == "__metadata__":
            continue
        assert t["dtype"] == "F32", (name, t["dtype"])
        a, b = t["data_offsets"]
        out[name] = np.frombuffer(data[a:b], dtype="<f4").reshape(t["shape"]).copy()
    return out, header.get("__metadata__", {})


def trunk_graph(weights, batch, n, dilation=1):
    nodes, inits, outputs = [], [], []
    x = helper.make_tensor_value_info("x", TensorProto.FLOAT, [batch, 4, n, n])
    for prim in ("grasp", "place"):
        h = "x"
        for name, stride, dil in trunk_layers(dilation):
            w = f"{prim}.{name}.weight"
            b = f"{prim}.{name}.bias"
            inits += [numpy_helper.from_array(weights[w], w), numpy_helper.from_array(weights[b], b)]
            conv = f"{prim}.{name}.conv"
            nodes.append(helper.make_node(
                "Conv", [h, w, b], [conv], kernel_shape=[3, 3], strides=[stride, stride],
                dilations=[dil, dil], pads=[dil, dil, dil, dil]))
            h = f"{prim}.{name}.relu"
            nodes.append(helper.make_node("Relu", [conv], [h]))
        outputs.append(helper.make_tensor_value_info(h, TensorProto.FLOAT, [batch, 64, n // 4, n // 4]))
    graph = helper.make_graph(nodes, "seespot-trunk", [x], outputs, inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    onnx.checker.check_model(model)
    return model


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--weights", default="models/stack.safetensors")
    ap.add_argument("--iterations", type=int, default=20)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    batch, n = 16, 112
    weights, metadata = read_safetensors(args.weights)
    model = trunk_graph(weights, batch, n, conv5_dilation(metadata))
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = args.threads
    opts.inter_op_num_threads = 1
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    sess = ort.InferenceSession(model.SerializeToString(), opts, providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    x = (rng.random((batch, 4, n, n), dtype=np.float32) - 0.5).astype(np.float32)
    out = sess.run(None, {"x": x})  # warm-up
    assert [o.shape for o in out] == [(batch, 64, n // 4, n // 4)] * 2, [o.shape for o in out]
    times = []
    for _ in range(args.iterations):
        t = time.perf_counter()
        sess.run(None, {"x": x})
        times.append(1e3 * (time.perf_counter() - t))
    times.sort()
    print(json.dumps({
        "onnxruntime": ort.__version__,
        "onnx": onnx.__version__,
        "weights": args.weights,
        "threads": args.threads,
        "batch": [2, batch, 4, n, n],
        "iterations": args.iterations,
        "trunk_ms_median": times[len(times) // 2],
        "trunk_ms_min": times[0],
    }))


if __name__ == "__main__":
    main()
