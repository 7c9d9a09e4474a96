"""seespot's extensions by name: Ssr(extensions=[...]) acting on a trial
makes the same decisions as the preset that names the same set."""

from __future__ import annotations

import pytest

import seespot


def test_extensions_are_listed_with_what_they_read() -> None:
    by_name = {name: (reads, needs) for name, reads, needs in seespot.EXTENSIONS}
    assert by_name["loop-break"] == ("heightmaps", [])
    assert by_name["reversal-guard"][0] == "simulator"
    assert by_name["built-guard"][0] == "progress"
    assert by_name["regrasp"][1] == ["loop-break"]


def test_a_set_by_name_acts_as_its_preset() -> None:
    names = ["replace", "built-guard", "regrasp", "loop-break"]
    ssr = seespot.Ssr("row", extensions=names)
    # Registry order, whatever the order asked; labelled by what it reads.
    assert ssr.extensions == ["loop-break", "regrasp", "replace", "built-guard"]
    assert ssr.information == "progress"
    assert "built guard" in ssr.title
    record = seespot.run_trial("ssr-ccd-built", "row", 3)
    trial = seespot.Trial("row", 3)
    for logged in record["actions_log"][:8]:
        d = ssr.act(trial)
        a = logged["action"]
        assert d["action"] == (a["rotation"], a["y"], a["x"])
        assert d["primitive"] == a["primitive"]
        said = [x["why"] for x in d["departures"]]
        assert said == [x["why"] for x in logged.get("departures", [])]
        trial.step(*d["action"])


def test_a_set_that_would_do_nothing_is_refused() -> None:
    with pytest.raises(ValueError, match="needs `loop-break`"):
        seespot.Ssr("row", extensions=["regrasp"])
    with pytest.raises(ValueError, match="did you mean"):
        seespot.Ssr("row", extensions=["loop-brake"])
    assert seespot.Ssr("row", method="ssr-ccd-replace").information == "simulator"
