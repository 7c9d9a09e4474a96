"""See-SPOT-Run on a PyTorch network, both ways (docs/embeddings.md, "From
PyTorch"): exported by PyTorch's default exporter (weights in a `.onnx.data`
file beside the model), and given to seespot as the module itself, with no
export. Both decide the first actions of a row trial from seed 5 (six at most); the
example checks that they choose the same actions.

    .venv-py/bin/pip install torch onnxscript          # PyTorch, if missing
    .venv-py/bin/python python/examples/ssr_pytorch_network.py [--view]

Run it from the repository root (it reads models/ and demos/). With
``--view`` it then opens the debugger page on the module itself.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

try:
    import torch
    from torch import nn
except ImportError:
    sys.exit("this example needs PyTorch: pip install torch onnxscript (into the Python that has seespot)")

import seespot


class SmallNet(nn.Module):
    """Two stride-2 convolutions with batch norm: scene [R, 4, 112, 112] ->
    features [R, 16, 28, 28]."""

    def __init__(self) -> None:
        super().__init__()
        self.body = nn.Sequential(
            nn.Conv2d(4, 16, 3, stride=2, padding=1),
            nn.BatchNorm2d(16),
            nn.ReLU(),
            nn.Conv2d(16, 16, 3, stride=2, padding=1),
            nn.ReLU(),
        )

    def forward(self, scene: torch.Tensor) -> torch.Tensor:
        return self.body(scene)


def main() -> None:
    torch.manual_seed(0)
    net = SmallNet().eval()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "small_net.onnx"
        torch.onnx.export(
            net,
            (torch.zeros(16, 4, 112, 112),),
            str(path),
            input_names=["scene"],
            output_names=["features"],
            dynamic_shapes=({0: torch.export.Dim("rotations")},),
        )
        print(f"exported {path.name} with {path.name}.data beside it")
        from_file = seespot.Ssr("row", embeddings=[str(path)])
        from_module = seespot.Ssr("row", embeddings=[net])
        trial = seespot.Trial("row", seed=5)
        same = steps = 0
        while steps < 6 and trial.end is None:
            color, depth = trial.observe()
            a = from_file.decide(color, depth, trial.progress, trial.next_primitive)
            b = from_module.decide(color, depth, trial.progress, trial.next_primitive)
            steps += 1
            print(f"action {steps}: file {a['action']}, module {b['action']}")
            same += a["action"] == b["action"]
            trial.step(*a["action"])
        print(f"{same} of {steps} actions the same")
        if same != steps:
            sys.exit("the module and its export chose differently")
    if "--view" in sys.argv:
        seespot.view("--task", "row", embeddings=[net])


if __name__ == "__main__":
    main()
