"""seespot.dist refuses, as ``seespot eval`` does, to add a seed of one split
(test, validation, training) to a records file holding another's (issue 59).
No Ray needed: the check runs before Ray starts."""

from __future__ import annotations

from pathlib import Path

import pytest

import seespot
from seespot import dist


def test_split_of_follows_the_seed_scheme() -> None:
    assert [dist.split_of(s) for s in (1, 9_999, 10_001, 30_001, 0, 2)] == [
        "test", "test", "validation", "validation", "training", "training",
    ]
    # The same boundaries as the Rust seed ranges: a run may not cross them.
    seespot.test_seeds(9_999, 1)
    with pytest.raises(ValueError):
        seespot.test_seeds(9_999, 2)


def test_a_seed_of_another_split_is_refused_naming_the_file(tmp_path: Path) -> None:
    path = tmp_path / "trials" / "oracle" / "stack.jsonl.gz"
    with pytest.raises(ValueError, match="holds test seeds .*seed 30001 is a validation seed"):
        dist.check_split(path, [1, 3], [30_001])
    with pytest.raises(ValueError, match=str(path)):
        dist.check_split(path, [10_001], [2])
    # Same split, or nothing new: no refusal.
    dist.check_split(path, [1, 3], [5, 7])
    dist.check_split(path, [1, 3], [])
    dist.check_split(path, [], [30_001])


def test_append_record_refuses_a_seed_of_another_split_or_one_recorded(tmp_path: Path) -> None:
    """The Python writer (``seespot.append_record``, which ``seespot.dist``
    and any loop over ``Evaluator.run`` use) refuses what ``seespot eval``
    refuses, before writing anything."""
    from seespot import _core

    path = tmp_path / "trials" / "oracle" / "stack.jsonl.gz"
    ev = _core.Evaluator("oracle", "stack")
    _core.append_record(path, ev.run(1, 0))
    before = path.read_bytes()
    with pytest.raises(ValueError, match=r"holds test seeds \(seed 1\); seed 10001 is a validation seed"):
        _core.append_record(path, ev.run(10_001, 0))
    with pytest.raises(ValueError, match="seed 1 is recorded already"):
        _core.append_record(path, ev.run(1, 0))
    assert path.read_bytes() == before
    _core.append_record(path, ev.run(3, 1))
    assert [r for r in _core.read_records(path)][1].count('"seed":3') == 1
