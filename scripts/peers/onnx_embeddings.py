"""The onnxruntime peer of seespot's ONNX embedding path (`seespot bench ssr
--embeddings`, `embed_live_ms`): the live-scene Embed of one SSR decision,
each model's `grasp` features (or its one shared output) for the 16
rotations of a 4 x 112 x 112 scene, for every model file given (the same
files seespot runs). Inputs are uniform in [-0.5, 0.5), the range of the
normalised colour channels. Prints one JSON object: the median and best of
`--iterations` timed runs after a warm-up, in ms.
"""
import argparse
import json
import time

import numpy as np
import onnxruntime as ort


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("models", nargs="+")
    ap.add_argument("--iterations", type=int, default=9)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = args.threads
    opts.inter_op_num_threads = 1
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    sessions = []
    for path in args.models:
        s = ort.InferenceSession(path, opts, providers=["CPUExecutionProvider"])
        names = [o.name for o in s.get_outputs()]
        out = "grasp" if "grasp" in names else [n for n in names if not n.endswith("_q")][0]
        sessions.append((s, s.get_inputs()[0].name, out))
    rng = np.random.default_rng(0)
    x = (rng.random((16, 4, 112, 112), dtype=np.float32) - 0.5).astype(np.float32)

    def embed():
        for s, inp, out in sessions:
            s.run([out], {inp: x})

    embed()  # warm-up
    times = []
    for _ in range(args.iterations):
        t = time.perf_counter()
        embed()
        times.append(1e3 * (time.perf_counter() - t))
    times.sort()
    print(json.dumps({
        "onnxruntime": ort.__version__,
        "models": args.models,
        "threads": args.threads,
        "iterations": args.iterations,
        "embed_ms_median": times[len(times) // 2],
        "embed_ms_min": times[0],
    }))


if __name__ == "__main__":
    main()
