"""Demonstrating from Python: ``seespot.record_demo`` drives the recorder a
click in the debugger's Demonstrate mode drives, so the shipped demonstrations
of a custom task are remade from their actions byte for byte."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import seespot

ROOT = Path(__file__).resolve().parents[2]


def actions_of(meta: dict) -> list[tuple[str, int, int, int]]:
    return [
        (s["action"]["primitive"], s["action"]["rotation"], s["action"]["y"], s["action"]["x"])
        for s in meta["steps"]
    ]


def test_a_list_of_actions_remakes_the_shipped_custom_demonstrations(tmp_path: Path) -> None:
    shipped = ROOT / "demos" / "custom" / "pyramid"
    for n in ["0", "1"]:
        meta = json.loads((shipped / n / "meta.json").read_text())
        out = tmp_path / "custom" / "pyramid" / n
        saved = seespot.record_demo("custom:pyramid", meta["seed"], actions_of(meta), out)
        assert saved == len(meta["steps"])
        for f in sorted((shipped / n).iterdir()):
            assert (out / f.name).read_bytes() == f.read_bytes(), f.name
    # Saving over a demonstration needs overwrite.
    meta = json.loads((shipped / "0" / "meta.json").read_text())
    with pytest.raises(ValueError, match="overwrite"):
        seespot.record_demo("custom:pyramid", meta["seed"], actions_of(meta), tmp_path / "custom" / "pyramid" / "0")


def test_bad_demonstrations_name_what_is_wrong(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="holds no path"):
        seespot.record_demo("custom:../up", 0, [("grasp", 0, 5, 5)], tmp_path / "x")
    with pytest.raises(ValueError, match="unknown primitive 'push' \\(expected grasp or place\\)"):
        seespot.record_demo("stack", 0, [("push", 0, 5, 5)], tmp_path / "x")
    with pytest.raises(ValueError, match="action 0: .*outside the 224 x 224 workspace"):
        seespot.record_demo("stack", 0, [("grasp", 0, 500, 5)], tmp_path / "x")
    with pytest.raises(ValueError, match="no actions"):
        seespot.record_demo("custom:empty", 0, [], tmp_path / "x")
    assert not (tmp_path / "x").exists()


def test_a_custom_task_runs_from_its_demonstrations() -> None:
    """A trial of a custom task reads its goal from demos/custom/NAME (the
    tests run from the repository root); one with no demonstrations is
    refused by name instead of failing later."""
    t = seespot.Trial("custom:pyramid", 1)
    assert t.task == "custom:pyramid"
    assert 1 <= t.progress <= 4
    with pytest.raises(ValueError, match="no demonstrations of custom:never-shown"):
        seespot.Trial("custom:never-shown", 1)
