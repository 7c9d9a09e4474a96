"""The correspondence benchmark from Python (issue 60): seespot.truth returns
the tables and every answer, for the shipped policies and for a function."""

from __future__ import annotations

import numpy as np

import seespot


def test_truth_returns_its_tables_and_answers() -> None:
    report = seespot.truth("row", starts=1)
    task, primitive, overall = report["rows"][-1]
    assert (task, primitive) == ("all", "both")
    assert overall["probes"] == len(report["answers"]) > 0
    share = overall["ccd_selection"]
    assert 0 <= share["hits"] <= share["of"] == overall["probes"]
    verdicts = {p["truth"]["verdict"] for a in report["answers"] for p in a["pairs"]}
    assert verdicts <= {"right", "wrong_block", "miss", "no_progress", "reversal", "out"}
    assert report["split"] == "validation"


def test_truth_takes_a_function() -> None:
    def strided(scene: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(scene[:, :, ::4, ::4])

    report = seespot.truth("stack", starts=1, embeddings=[strided])
    assert report["set"] == "strided"
    assert all(p["policy"] == "strided" for a in report["answers"] for p in a["pairs"])
