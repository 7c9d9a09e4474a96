"""Your own network (ONNX) from Python: Ssr, Evaluator and run_trial take an
embedding set, name it, and refuse a bad file naming it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import seespot

ROOT = Path(__file__).resolve().parents[2]


def _build(tmp_path: Path) -> Path:
    # The example's builder, without running the example's script part.
    source = (ROOT / "python/examples/ssr_onnx_network.py").read_text()
    builder = source.split("# %% Build it.")[0]
    scope: dict[str, object] = {}
    exec(compile(builder, "ssr_onnx_network.py", "exec"), scope)
    return scope["build_network"](tmp_path / "my-network.onnx")  # type: ignore[operator,no-any-return]


def test_ssr_decides_on_an_onnx_network(tmp_path: Path) -> None:
    net = _build(tmp_path)
    ssr = seespot.Ssr("row", str(ROOT / "models"), str(ROOT / "demos"), embeddings=[str(net)])
    assert ssr.policy_names == ["my-network"]
    trial = seespot.Trial("row", 1)
    color, depth = trial.observe()
    d = ssr.decide(color, depth, trial.progress, trial.next_primitive)
    assert len(d["pairs"]) == 2 and {p["policy"] for p in d["pairs"]} == {"my-network"}


def test_run_trial_names_the_set_and_checksums_the_file(tmp_path: Path) -> None:
    net = _build(tmp_path)
    r = seespot.run_trial(
        "ssr-ccd", "row", 1, models_dir=str(ROOT / "models"), demos_dir=str(ROOT / "demos"), embeddings=[str(net)]
    )
    assert r["method"] == "ssr-ccd@my-network"
    assert str(net) in r["provenance"]["files"]
    assert json.dumps(r["provenance"]["settings"]["embeddings"])


def test_a_bad_file_is_refused_naming_it(tmp_path: Path) -> None:
    bad = tmp_path / "broken.onnx"
    bad.write_bytes(b"not a protobuf")
    with pytest.raises(ValueError, match="broken.onnx"):
        seespot.Ssr("row", str(ROOT / "models"), str(ROOT / "demos"), embeddings=[str(bad)])
    with pytest.raises(ValueError, match="broken.onnx"):
        seespot.Evaluator("ssr-ccd", "row", str(ROOT / "models"), str(ROOT / "demos"), embeddings=[str(bad)])
    with pytest.raises(ValueError, match="runs no embedding set"):
        seespot.Evaluator("random", "row", str(ROOT / "models"), str(ROOT / "demos"), embeddings=[str(_build(tmp_path))])
