"""Shared fixtures: the repository root (models/, demos/) and the seespot binary."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _in_root(monkeypatch: pytest.MonkeyPatch) -> None:
    """Tests use the relative `models` and `demos` paths, as the CLI does."""
    monkeypatch.chdir(ROOT)


@pytest.fixture
def seespot_bin() -> Path:
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    path = Path(os.environ.get("SEESPOT_BIN", target / "release" / "seespot"))
    if not path.exists():
        pytest.fail(f"{path}: no seespot binary (cargo build --release -p seespot)")
    return path


def without_timing(record: dict) -> dict:
    """A record less its wall-clock fields (decide_ms), which differ run to run."""
    r = dict(record)
    r["actions_log"] = [{k: v for k, v in a.items() if k != "decide_ms"} for a in r["actions_log"]]
    return r
