#!/usr/bin/env python3
"""Makes the PyTorch fixtures of seespot's ONNX tests (docs/embeddings.md,
"From PyTorch"): three small vision networks, each exported the three ways
PyTorch writes ONNX today, and onnxruntime's features for one fixed input.

    python scripts/pytorch-fixtures.py [--out app/policy/tests/fixtures/pytorch]

Needs torch (2.9 or later: its default exporter is the new one), onnx,
onnxscript and onnxruntime; CI needs none of them, since the files it writes
are committed. The networks' weights come from ``torch.manual_seed(0)``.

Networks (each maps the scene ``float32[R, 4, 112, 112]`` to features
``float32[R, D, S, S]``):

- ``resnet``: a convolution with batch norm, a residual block, max pooling
  (stride 4, S = 28, D = 8);
- ``vit``: 8 px patches, LayerNorm, one attention block with a GELU MLP
  (S = 14, D = 16);
- ``upsample``: a stride-8 map upsampled bilinearly to S = 28 (D = 8).

Exports, per network (``<net>-<kind>.onnx``):

- ``legacy``: ``torch.onnx.export(..., dynamo=False)`` (the TorchScript
  exporter), opset 17, a named batch dimension;
- ``dynamo-external``: the default exporter's call, weights in
  ``<file>.data`` beside the model;
- ``dynamo-inline``: the default exporter with ``external_data=False``;
- ``dynamo-opset18``, ``dynamo-opset21``: the same at operator sets 18 and
  21 (the default is 20 in PyTorch 2.9).

``<net>.expected.bin`` holds onnxruntime's output of the legacy file for the
input ``x[i] = 0.5 * sin(0.001 * i)`` (flat index i over ``[2, 4, 112,
112]``), float32 little endian; ``manifest.json`` lists the files, their
shapes and the versions that made them.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

try:
    import numpy as np
    import onnxruntime as ort
    import torch
    import torch.nn.functional as F
    from torch import nn
except ImportError as e:  # pragma: no cover - a message for the user
    sys.exit(
        f"scripts/pytorch-fixtures.py needs PyTorch, onnxscript and onnxruntime ({e}); "
        "install them with `pip install torch onnx onnxscript onnxruntime`"
    )

BATCH = 2


class ResNetLike(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.stem = nn.Sequential(
            nn.Conv2d(4, 8, 3, stride=2, padding=1, bias=False),
            nn.BatchNorm2d(8),
            nn.ReLU(),
        )
        self.block = nn.Sequential(
            nn.Conv2d(8, 8, 3, padding=1, bias=False),
            nn.BatchNorm2d(8),
            nn.ReLU(),
            nn.Conv2d(8, 8, 3, padding=1, bias=False),
            nn.BatchNorm2d(8),
        )
        self.pool = nn.MaxPool2d(3, stride=2, padding=1)
        self.head = nn.Conv2d(8, 8, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.stem(x)
        h = F.relu(h + self.block(h))
        return self.head(self.pool(h))


class TinyViT(nn.Module):
    def __init__(self, dim: int = 16, patch: int = 8) -> None:
        super().__init__()
        self.patch = nn.Conv2d(4, dim, patch, stride=patch)
        self.norm1 = nn.LayerNorm(dim)
        self.qkv = nn.Linear(dim, 3 * dim)
        self.proj = nn.Linear(dim, dim)
        self.norm2 = nn.LayerNorm(dim)
        self.mlp = nn.Sequential(nn.Linear(dim, 2 * dim), nn.GELU(), nn.Linear(2 * dim, dim))
        self.heads = 2
        self.dim = dim

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.patch(x)  # [R, D, 14, 14]
        r, d, s, _ = h.shape
        t = h.flatten(2).transpose(1, 2)  # [R, S*S, D]
        q, k, v = self.qkv(self.norm1(t)).chunk(3, dim=-1)
        split = lambda a: a.reshape(r, s * s, self.heads, d // self.heads).transpose(1, 2)  # noqa: E731
        a = F.scaled_dot_product_attention(split(q), split(k), split(v))
        t = t + self.proj(a.transpose(1, 2).reshape(r, s * s, d))
        t = t + self.mlp(self.norm2(t))
        return t.transpose(1, 2).reshape(r, d, s, s)


class Upsample(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.down = nn.Sequential(
            nn.Conv2d(4, 8, 3, stride=4, padding=1),
            nn.ReLU(),
            nn.Conv2d(8, 8, 3, stride=2, padding=1),
            nn.ReLU(),
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.interpolate(self.down(x), scale_factor=2.0, mode="bilinear", align_corners=False)


NETWORKS = {"resnet": ResNetLike, "vit": TinyViT, "upsample": Upsample}


def fixed_input(batch: int) -> np.ndarray:
    n = batch * 4 * 112 * 112
    i = np.arange(n, dtype=np.float64)
    return (0.5 * np.sin(0.001 * i)).astype(np.float32).reshape(batch, 4, 112, 112)


def export_all(name: str, model: nn.Module, out: Path) -> list[dict]:
    # The example batch is 16, the number of rotations, as a user would
    # pass a real rotated scene; the batch is exported as a named dimension.
    example = torch.from_numpy(fixed_input(16))
    files = []

    legacy = out / f"{name}-legacy.onnx"
    torch.onnx.export(
        model,
        (example,),
        str(legacy),
        dynamo=False,
        input_names=["scene"],
        output_names=["features"],
        dynamic_axes={"scene": {0: "rotations"}, "features": {0: "rotations"}},
        opset_version=17,
    )
    files.append({"file": legacy.name, "kind": "legacy"})

    # The default exporter, in its three forms: weights beside the file at
    # the default operator set, inline, and inline at opsets 18 and 21.
    rotations = torch.export.Dim("rotations", min=1, max=16)
    forms = [("dynamo-external", True, None), ("dynamo-inline", False, None)]
    forms += [(f"dynamo-opset{opset}", False, opset) for opset in (18, 21)]
    for kind, external, opset in forms:
        path = out / f"{name}-{kind}.onnx"
        data = out / f"{path.name}.data"
        data.unlink(missing_ok=True)
        torch.onnx.export(
            model,
            (example,),
            str(path),
            dynamo=True,
            input_names=["scene"],
            output_names=["features"],
            dynamic_shapes=({0: rotations},),
            external_data=external,
            **({} if opset is None else {"opset_version": opset}),
        )
        entry = {"file": path.name, "kind": kind}
        if data.exists():
            entry["data"] = data.name
        files.append(entry)
    return files


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("app/policy/tests/fixtures/pytorch"))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(0)
    manifest = {
        "command": "python scripts/pytorch-fixtures.py",
        "torch": torch.__version__,
        "onnxruntime": ort.__version__,
        "input": "x[i] = 0.5 * sin(0.001 * i), float32[2, 4, 112, 112]",
        "networks": {},
    }
    for name, cls in NETWORKS.items():
        model = cls().eval()
        # Batch norm with statistics that are not the identity.
        for m in model.modules():
            if isinstance(m, nn.BatchNorm2d):
                m.running_mean.uniform_(-0.2, 0.2)
                m.running_var.uniform_(0.5, 1.5)
        with torch.no_grad():
            files = export_all(name, model, args.out)
            x = fixed_input(BATCH)
            session = ort.InferenceSession(str(args.out / f"{name}-legacy.onnx"))
            (expected,) = session.run(None, {"scene": x})
            torch_out = model(torch.from_numpy(x)).numpy()
        gap = float(np.abs(expected - torch_out).max())
        # Each export against onnxruntime on the legacy file.
        for f in files:
            s = ort.InferenceSession(str(args.out / f["file"]))
            (got,) = s.run(None, {s.get_inputs()[0].name: x})
            f["max_abs_vs_expected"] = float(np.abs(got - expected).max())
        expected.astype("<f4").tofile(args.out / f"{name}.expected.bin")
        manifest["networks"][name] = {
            "shape": list(expected.shape),
            "files": files,
            "torch_vs_onnxruntime_max_abs": gap,
        }
        print(f"{name}: {list(expected.shape)}, torch vs onnxruntime {gap:.2e}", flush=True)
    (args.out / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
