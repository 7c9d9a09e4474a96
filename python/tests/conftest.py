"""Shared fixtures: the repository root (models/, demos/) and the seespot binary."""

from __future__ import annotations

import os
import re
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
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


@contextmanager
def serving_view(seespot: Path, *args: str) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """`seespot view --port 0 --no-viewer ARGS` from the repository root:
    yields the page's URL (as printed) and the process, then stops it with
    Ctrl-C (SIGINT) and waits for it."""
    with serving([str(seespot), "view", "--port", "0", "--no-viewer", *args]) as served:
        yield served


@contextmanager
def serving(command: list[str]) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """Runs `command` (one that serves the page, such as `seespot view` or
    a Python script calling `seespot.view`) from the repository root:
    yields the page's URL (as printed) and the process, then stops it with
    Ctrl-C (SIGINT) and waits for it."""
    proc = subprocess.Popen(
        command,
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        url = None
        deadline = time.monotonic() + 120
        assert proc.stdout is not None
        while url is None and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line and proc.poll() is not None:
                break
            m = re.search(r"seespot page:\s+(\S+)", line)
            url = m.group(1) if m else None
        assert url, f"{command[0]} printed no page URL"
        yield url, proc
    finally:
        proc.send_signal(2)
        proc.wait(timeout=60)
