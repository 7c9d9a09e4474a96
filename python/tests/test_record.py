"""A trial record from Python equals the one `seespot eval` writes."""

from __future__ import annotations

import gzip
import json
import subprocess
from pathlib import Path

import seespot

from conftest import without_timing


def cli_eval(seespot_bin: Path, out: Path, method: str, task: str, trials: int) -> None:
    """`seespot eval` of `trials` test seeds into `out`."""
    subprocess.run(
        [str(seespot_bin), "eval", "--method", method, "--task", task, "--trials", str(trials),
         "--seed", "1", "--out", str(out)],
        check=True,
        capture_output=True,
    )


def test_oracle_record_equals_cli(tmp_path: Path, seespot_bin: Path) -> None:
    cli_eval(seespot_bin, tmp_path, "oracle", "stack", 2)
    path = seespot.records_path(tmp_path, "oracle", "stack")
    cli = [json.loads(line) for line in gzip.decompress(Path(path).read_bytes()).decode().splitlines()]
    assert [r["seed"] for r in cli] == [1, 3]
    for index, r in enumerate(cli):
        py = seespot.run_trial("oracle", "stack", r["seed"], index=index)
        assert without_timing(py) == without_timing(r)


def test_transporter_record_equals_cli(tmp_path: Path, seespot_bin: Path) -> None:
    assert "transporter" in seespot.METHODS
    cli_eval(seespot_bin, tmp_path, "transporter", "unstack", 1)
    path = seespot.records_path(tmp_path, "transporter", "unstack")
    (r,) = [json.loads(line) for line in gzip.decompress(Path(path).read_bytes()).decode().splitlines()]
    assert r["provenance"]["files"]["models/transporter/unstack.safetensors"]
    py = seespot.run_trial("transporter", "unstack", 1, index=0)
    assert without_timing(py) == without_timing(r)


def test_every_shipped_record_name_reads_as_a_run() -> None:
    """Python reads a record name with the Rust RunSpec the report uses: every
    records folder the project ships names a run, and names round-trip."""
    from conftest import ROOT

    names = {p.name for p in ROOT.glob("results/**/trials/*") if p.is_dir()}
    assert "ssr-ccd" in names and "good-robot-finetuned" in names
    for name in names:
        assert seespot.run_spec(name)["name"] == name
    gr = seespot.run_spec("good-robot-finetuned")
    assert gr == {"name": "good-robot-finetuned", "method": "spot-q",
                  "display_name": "Good Robot finetuned", "finetuned": True, "noisy": False,
                  "correspond": None}
    plain = seespot.run_spec(seespot.record_name("ssr-l2cd", "plain"))
    assert (plain["name"], plain["correspond"]) == ("ssr-l2cd-plain", "plain")
    assert seespot.run_spec("ssr-ccd-global-rematch")["correspond"] == "reference+global-rematch"
    for bad in ["ssr-ccd-plian", "oracle-finetuned", ""]:
        try:
            seespot.run_spec(bad)
        except ValueError as e:
            assert "name" in str(e)
        else:
            raise AssertionError(f"{bad!r} was read as a run")
