"""The wheel alone gives the whole command line: a fresh virtual environment
with only the built wheel (and its declared dependencies) runs `seespot
--help`, an oracle evaluation and `seespot view`, whose page answers; and
`seespot export lerobot` turns trial records into a dataset."""

from __future__ import annotations

import gzip
import json
import os
import re
import subprocess
import sys
import urllib.request
from pathlib import Path

import pytest

from conftest import ROOT, serving_view


@pytest.fixture(scope="module")
def wheel_seespot(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The `seespot` console script of a fresh venv holding only the wheel
    that scripts/test-python built (SEESPOT_WHEEL)."""
    wheel = os.environ.get("SEESPOT_WHEEL")
    if not wheel:
        pytest.fail("SEESPOT_WHEEL is not set: run the Python tests with scripts/test-python")
    venv = tmp_path_factory.mktemp("wheel-venv")
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    # The wheel's dependencies (numpy, gymnasium) at the versions the tests pin.
    pins = [
        line.strip()
        for line in (ROOT / "python" / "requirements-test.txt").read_text().splitlines()
        if line.startswith(("numpy==", "gymnasium=="))
    ]
    subprocess.run(
        [str(venv / "bin" / "python"), "-m", "pip", "install", "--quiet", "--disable-pip-version-check", wheel, *pins],
        check=True,
    )
    return venv / "bin" / "seespot"


def test_the_wheel_runs_help_and_an_oracle_evaluation(wheel_seespot: Path, tmp_path: Path) -> None:
    help_text = subprocess.run([str(wheel_seespot), "--help"], capture_output=True, text=True, check=True).stdout
    for command in ["view", "eval", "record", "review", "export"]:
        assert re.search(rf"^\s+{command}\s", help_text, re.M), command
    bad = subprocess.run([str(wheel_seespot), "eval", "--task", "stak"], capture_output=True, text=True)
    assert bad.returncode != 0 and "stak" in bad.stderr

    out = tmp_path / "results"
    run = subprocess.run(
        [str(wheel_seespot), "eval", "--method", "oracle", "--task", "stack", "--trials", "2", "--out", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr
    records = [json.loads(line) for line in gzip.decompress((out / "trials" / "oracle" / "stack.jsonl.gz").read_bytes()).decode().splitlines()]
    assert [r["trial"] for r in records] == [0, 1]
    assert all(r["method"] == "oracle" and r["task"] == "stack" for r in records)


def test_the_wheel_serves_the_debugger_page(wheel_seespot: Path) -> None:
    with serving_view(wheel_seespot, "--task", "stack", "--seed", "1") as (url, proc):
        with urllib.request.urlopen(url, timeout=30) as page:
            assert page.status == 200
            assert "<html" in page.read().decode().lower()
        with urllib.request.urlopen(url.rstrip("/") + "/api/state", timeout=60) as state:
            assert json.loads(state.read())["task"] == "stack"
    assert proc.returncode == 0


def test_export_lerobot_resimulates_trial_records(wheel_seespot: Path, tmp_path: Path) -> None:
    """`seespot export lerobot --records`: each trial one episode, re-simulated
    from its seed and actions; the frames' actions are the records'."""
    pq = pytest.importorskip("pyarrow.parquet")
    records = ROOT / "results" / "trials" / "oracle" / "stack.jsonl.gz"
    want = [json.loads(line) for line in gzip.decompress(records.read_bytes()).decode().splitlines()]
    out = tmp_path / "lerobot"
    run = subprocess.run(
        [str(wheel_seespot), "export", "lerobot", "--records", str(records), "--out", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        # The exporter runs in the interpreter that has pyarrow.
        env={**os.environ, "SEESPOT_PYTHON": sys.executable},
    )
    assert run.returncode == 0, run.stderr
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["total_episodes"] == len(want)
    assert info["total_frames"] == sum(len(r["actions_log"]) for r in want)
    frames = pq.read_table(out / "data" / "chunk-000" / "file-000.parquet")
    actions = frames.column("action").to_pylist()
    flat = [a["action"] for r in want for a in r["actions_log"]]
    assert [[int(v) for v in a[1:]] for a in actions] == [[a["rotation"], a["y"], a["x"]] for a in flat]
    assert [a[0] for a in actions] == [0.0 if a["primitive"] == "grasp" else 1.0 for a in flat]
    progress = frames.column("observation.progress").to_pylist()
    assert progress == [a["progress_before"] for r in want for a in r["actions_log"]]
    episodes = pq.read_table(out / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pylist()
    assert [e["seespot/seed"] for e in episodes] == [r["seed"] for r in want]
    assert [e["seespot/success"] for e in episodes] == [r["success"] for r in want]

    # A record the simulator does not reproduce is refused, naming file and field.
    bad = dict(want[0])
    bad["actions_log"] = [dict(a) for a in want[0]["actions_log"]]
    bad["actions_log"][0]["progress_after"] += 1
    bad_file = tmp_path / "bad" / "oracle" / "stack.jsonl.gz"
    bad_file.parent.mkdir(parents=True)
    bad_file.write_bytes(gzip.compress((json.dumps(bad) + "\n").encode()))
    run = subprocess.run(
        [str(wheel_seespot), "export", "lerobot", "--records", str(bad_file), "--out", str(tmp_path / "x")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "SEESPOT_PYTHON": sys.executable},
    )
    assert run.returncode == 1
    assert str(bad_file) in run.stderr and "actions_log[0]" in run.stderr
