"""A Python function as See-SPOT-Run's embeddings, without exporting it
(issue 58): it decides as the ONNX file of the same network, goes through the
same contract checks, is named in the records, and says that it cannot be
replayed without it."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from onnx import TensorProto, helper, numpy_helper, save

import seespot


def strided(scene: np.ndarray) -> np.ndarray:
    """Every fourth pixel of the four channels: float32[R, 4, 28, 28]."""
    return np.ascontiguousarray(scene[:, :, ::4, ::4])


def strided_onnx(path: Path) -> Path:
    """The same network as an ONNX file: a 1 x 1 convolution of stride 4 with
    identity weights, which gives the same bits (each output is one input
    times 1 plus zeros)."""
    x = helper.make_tensor_value_info("scene", TensorProto.FLOAT, ["rotations", 4, 112, 112])
    y = helper.make_tensor_value_info("features", TensorProto.FLOAT, ["rotations", 4, 28, 28])
    w = numpy_helper.from_array(np.eye(4, dtype=np.float32).reshape(4, 4, 1, 1), "w")
    conv = helper.make_node("Conv", ["scene", "w"], ["features"], kernel_shape=[1, 1], strides=[4, 4])
    model = helper.make_model(
        helper.make_graph([conv], "strided", [x], [y], [w]), opset_imports=[helper.make_opsetid("", 17)]
    )
    model.ir_version = 8
    save(model, str(path))
    return path


def test_a_function_decides_as_the_onnx_file_of_the_same_network(tmp_path: Path) -> None:
    path = strided_onnx(tmp_path / "strided.onnx")
    from_file = seespot.run_trial("ssr-ccd", "row", 1, embeddings=[str(path)])
    from_function = seespot.run_trial("ssr-ccd", "row", 1, embeddings=[strided])
    actions = [[e["action"] for e in r["actions_log"]] for r in (from_file, from_function)]
    assert len(actions[0]) > 1
    assert actions[0] == actions[1]
    assert from_function["method"] == "ssr-ccd@strided"
    files = from_function["provenance"]["files"]
    assert "cannot be replayed without it" in files["callable:strided"]
    assert from_function["provenance"]["settings"]["embeddings"] == {"files": ["callable:strided"]}


def test_ssr_takes_a_function_and_a_grasp_place_pair() -> None:
    def zero_place(scene: np.ndarray) -> np.ndarray:
        return np.zeros_like(strided(scene))

    ssr = seespot.Ssr("row", embeddings=[strided, (strided, zero_place)])
    assert ssr.policy_names == ["strided", "strided-zero_place"]
    trial = seespot.Trial("row", 1)
    color, depth = trial.observe()
    d = ssr.decide(color, depth, trial.progress, trial.next_primitive)
    assert {p["policy"] for p in d["pairs"]} == {"strided", "strided-zero_place"}


def test_a_function_that_breaks_the_contract_is_refused_naming_it() -> None:
    def flat(scene: np.ndarray) -> np.ndarray:
        return scene.reshape(scene.shape[0], -1)

    with pytest.raises(ValueError, match=r"embedding function `flat` refused: .*rank is not 4"):
        seespot.Ssr("row", embeddings=[flat])

    def odd(scene: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(scene[:, :, ::3, ::3])

    with pytest.raises(ValueError, match="side dividing 112"):
        seespot.Ssr("row", embeddings=[odd])

    def broken(scene: np.ndarray) -> np.ndarray:
        raise RuntimeError("out of memory on the GPU")

    with pytest.raises(ValueError, match="Python raised RuntimeError: out of memory on the GPU"):
        seespot.Evaluator("ssr-ccd", "row", embeddings=[broken])

    def nan(scene: np.ndarray) -> np.ndarray:
        return strided(scene) * np.float32("nan")

    with pytest.raises(ValueError, match="non-finite"):
        seespot.run_trial("ssr-ccd", "row", 1, embeddings=[nan])


def test_a_function_not_in_this_process_cannot_be_replayed() -> None:
    with pytest.raises(ValueError, match="no such function in this process"):
        seespot.Evaluator("ssr-ccd", "row", embeddings=["callable:gone"])


@pytest.mark.skipif(importlib.util.find_spec("torch") is None, reason="PyTorch is not installed")
def test_a_torch_module_runs_through_the_same_path() -> None:
    import torch

    class Strided(torch.nn.Module):
        def forward(self, scene: torch.Tensor) -> torch.Tensor:
            return scene[:, :, ::4, ::4].contiguous()

    a = seespot.run_trial("ssr-ccd", "row", 1, embeddings=[Strided()])
    b = seespot.run_trial("ssr-ccd", "row", 1, embeddings=[strided])
    assert a["method"] == "ssr-ccd@strided"
    assert "callable:Strided" in a["provenance"]["files"]
    assert [e["action"] for e in a["actions_log"]] == [e["action"] for e in b["actions_log"]]


def test_the_page_runs_on_a_function(tmp_path: Path) -> None:
    """seespot.view(..., embeddings=[fn]): the page's server, in the Python
    process that holds the function, decides with it."""
    import sys
    import textwrap

    from conftest import serving
    from seespot.viz.viser import DebuggerClient

    script = textwrap.dedent(
        """
        import numpy as np
        import seespot

        def strided(scene):
            return np.ascontiguousarray(scene[:, :, ::4, ::4])

        seespot.view("--port", "0", "--no-viewer", "--task", "row", "--seed", "1", embeddings=[strided])
        """
    )
    with serving([sys.executable, "-c", script]) as (url, _):
        client = DebuggerClient(url)
        try:
            client.request({"type": "next_phase"})
            decision = client.get("/api/decision")
        finally:
            client.close()
    assert [p["policy"] for p in decision["pairs"]] == ["strided", "strided"]
    assert decision["embed_ms"] > 0
