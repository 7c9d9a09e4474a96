"""A trial record from Python equals the one `seespot eval` writes."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import seespot

from conftest import without_timing


def test_oracle_record_equals_cli(tmp_path: Path, seespot_bin: Path) -> None:
    subprocess.run(
        [str(seespot_bin), "eval", "--method", "oracle", "--task", "stack", "--trials", "2",
         "--seed", "1", "--out", str(tmp_path)],
        check=True,
        capture_output=True,
    )
    path = seespot.records_path(tmp_path, "oracle", "stack")
    cli = [json.loads(line) for line in Path(path).read_text().splitlines()]
    assert [r["seed"] for r in cli] == [1, 3]
    for index, r in enumerate(cli):
        py = seespot.run_trial("oracle", "stack", r["seed"], index=index)
        assert without_timing(py) == without_timing(r)


def test_transporter_record_equals_cli(tmp_path: Path, seespot_bin: Path) -> None:
    assert "transporter" in seespot.METHODS
    subprocess.run(
        [str(seespot_bin), "eval", "--method", "transporter", "--task", "unstack", "--trials", "1",
         "--seed", "1", "--out", str(tmp_path)],
        check=True,
        capture_output=True,
    )
    path = seespot.records_path(tmp_path, "transporter", "unstack")
    (r,) = [json.loads(line) for line in Path(path).read_text().splitlines()]
    assert r["provenance"]["files"]["models/transporter/unstack.safetensors"]
    py = seespot.run_trial("transporter", "unstack", 1, index=0)
    assert without_timing(py) == without_timing(r)
