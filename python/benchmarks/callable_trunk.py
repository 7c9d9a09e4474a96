"""What a Python function costs as See-SPOT-Run's embeddings (issue 58):
``seespot bench ssr`` on the stack fold's three shipped policies, in one
process and interleaved, four ways:

- ``native``: seespot's own trunk (``models/<task>.safetensors``);
- ``onnx``: the same policies as ONNX files in tract (``seespot export onnx``);
- ``numpy``: the same trunks as a Python function in NumPy (im2col and a
  matrix product per convolution);
- ``torch``: the same trunks as a ``torch.nn.Module`` (when PyTorch is
  installed).

Each function's features are checked against the native trunk's first
(the largest difference is printed). Prints each round's Embed and decision
times (ms) and the medians' ratios against native and ONNX. Run from the
repository root, with the seespot package installed::

    python python/benchmarks/callable_trunk.py [--rounds 5] [--iterations 9]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import statistics
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import seespot
from seespot import _core, cli

TASKS = ["unstack", "row", "vertical-square"]


def read_policy(path: Path) -> dict[str, np.ndarray]:
    """The tensors of a seespot policy file (safetensors layout, float32)."""
    raw = path.read_bytes()
    (n,) = struct.unpack("<Q", raw[:8])
    header = json.loads(raw[8 : 8 + n])
    out = {}
    for name, info in header.items():
        if name == "__metadata__":
            continue
        start, end = info["data_offsets"]
        out[name] = np.frombuffer(raw[8 + n + start : 8 + n + end], dtype="<f4").reshape(info["shape"])
    return out


def specs(path: Path) -> list[tuple[str, int, int]]:
    """(name, stride, dilation) of the trunk's five convolutions."""
    raw = path.read_bytes()
    (n,) = struct.unpack("<Q", raw[:8])
    arch = json.loads(raw[8 : 8 + n])["__metadata__"]["architecture"]
    d5 = int(arch.rsplit("-d", 1)[1])
    return [("conv1", 2, 1), ("conv2", 2, 1), ("conv3", 1, 1), ("conv4", 1, 2), ("conv5", 1, d5)]


def numpy_trunk(path: Path, primitive: str):
    w = read_policy(path)
    layers = [(w[f"{primitive}.{c}.weight"], w[f"{primitive}.{c}.bias"], s, d) for c, s, d in specs(path)]

    def conv(x: np.ndarray, weight: np.ndarray, bias: np.ndarray, stride: int, dil: int) -> np.ndarray:
        r, c, h, _ = x.shape
        p = np.pad(x, ((0, 0), (0, 0), (dil, dil), (dil, dil)))
        out = (h + 2 * dil - 2 * dil - 1) // stride + 1
        cols = np.empty((r, out, out, c, 3, 3), np.float32)
        for ky in range(3):
            for kx in range(3):
                ys, xs = ky * dil, kx * dil
                patch = p[:, :, ys : ys + stride * out : stride, xs : xs + stride * out : stride]
                cols[:, :, :, :, ky, kx] = patch.transpose(0, 2, 3, 1)
        y = cols.reshape(r * out * out, c * 9) @ weight.reshape(weight.shape[0], -1).T + bias
        return np.maximum(y, 0).reshape(r, out, out, -1).transpose(0, 3, 1, 2)

    def trunk(scene: np.ndarray) -> np.ndarray:
        h = scene
        for weight, bias, s, d in layers:
            h = conv(h, weight, bias, s, d)
        return np.ascontiguousarray(h)

    trunk.__name__ = f"numpy-{path.stem}-{primitive}"
    return trunk


def torch_trunk(path: Path, primitive: str):
    import torch

    w = read_policy(path)

    class Trunk(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.convs = torch.nn.ModuleList()
            for c, s, d in specs(path):
                weight = torch.from_numpy(w[f"{primitive}.{c}.weight"].copy())
                conv = torch.nn.Conv2d(weight.shape[1], weight.shape[0], 3, stride=s, padding=d, dilation=d)
                conv.weight.data = weight
                conv.bias.data = torch.from_numpy(w[f"{primitive}.{c}.bias"].copy())
                self.convs.append(conv)

        def forward(self, scene: torch.Tensor) -> torch.Tensor:
            h = scene
            for conv in self.convs:
                h = torch.relu(conv(h))
            return h

    Trunk.__name__ = f"torch-{path.stem}-{primitive}"
    return Trunk()


def bench(paths: list[str], iterations: int) -> dict:
    """``seespot bench ssr --json`` in this process; its stdout read back."""
    with tempfile.TemporaryFile() as out:
        saved = os.dup(1)
        sys.stdout.flush()
        os.dup2(out.fileno(), 1)
        try:
            code = cli.main(["bench", "ssr", "--iterations", str(iterations), "--json", "--embeddings", *paths])
        finally:
            os.dup2(saved, 1)
            os.close(saved)
        out.seek(0)
        text = out.read().decode()
    if code != 0:
        raise SystemExit(f"bench ssr failed ({code}): {text}")
    return json.loads(text)


def decide(paths: list[str]) -> dict:
    """One stack decision from seed 3's start with these embeddings."""
    trial = seespot.Trial("stack", 3)
    color, depth = trial.observe()
    return seespot.Ssr("stack", embeddings=paths).decide(color, depth, trial.progress, trial.next_primitive)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--iterations", type=int, default=9)
    args = ap.parse_args()
    native = [f"models/{t}.safetensors" for t in TASKS]
    tmp = tempfile.mkdtemp()
    subprocess.run([sys.executable, "-m", "seespot.cli", "export", "onnx", "--out", tmp], check=True, capture_output=True)
    onnx = [f"{tmp}/{t}.onnx" for t in TASKS]
    ways = {"native": native, "onnx": onnx}
    pairs = [(numpy_trunk(Path(p), "grasp"), numpy_trunk(Path(p), "place")) for p in native]
    ways["numpy"] = _core.register_embeddings(pairs)
    if importlib.util.find_spec("torch") is not None:
        import torch

        torch.set_num_threads(os.cpu_count() or 1)
        mods = [(torch_trunk(Path(p), "grasp"), torch_trunk(Path(p), "place")) for p in native]
        ways["torch"] = _core.register_embeddings(mods)
    # Each way decides as the native trunk does (the sums run in other
    # orders, so L differs in the last digits).
    ref = decide(native)
    for k, paths in ways.items():
        d = decide(paths)
        gap = max(abs(a["l"] - b["l"]) / max(abs(a["l"]), 1e-6) for a, b in zip(ref["pairs"], d["pairs"]))
        print(f"{k}: action {d['action']} (native {ref['action']}), largest relative difference in L {gap:.1e}")
    rows: dict[str, list[tuple[float, float]]] = {k: [] for k in ways}
    print("round | " + " | ".join(f"{k} embed / decision ms" for k in ways))
    for r in range(args.rounds):
        cells = []
        for k, paths in ways.items():
            d = bench(paths, args.iterations)["decision"]
            rows[k].append((d["embed_live_ms"], d["decision_ms"]))
            cells.append(f"{d['embed_live_ms']:.1f} / {d['decision_ms']:.1f}")
        print(f"{r + 1} | " + " | ".join(cells), flush=True)
    med = {k: (statistics.median(e for e, _ in v), statistics.median(d for _, d in v)) for k, v in rows.items()}
    for k, (e, d) in med.items():
        print(
            f"{k}: Embed {e:.1f} ms ({e / med['native'][0]:.2f} x native, {e / med['onnx'][0]:.2f} x ONNX), "
            f"decision {d:.1f} ms ({d / med['native'][1]:.2f} x native, {d / med['onnx'][1]:.2f} x ONNX)"
        )


if __name__ == "__main__":
    main()
