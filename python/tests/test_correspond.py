"""Correspond on bring-your-own embeddings, and argument validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

import seespot

# R = 1, H = W = 2, D = 2; action (r, y, x).
LIVE = np.array([[[[0, 0], [1, 0]], [[0, 1], [1, 1]]]], dtype=np.float32)
DEMO = np.array([[[[0.9, 1.2], [0, 1]], [[1, 0], [1, 1]]]], dtype=np.float32)


def test_hand_computed_pair() -> None:
    # The demo action (0, 0, 0) has embedding (0.9, 1.2): its nearest live
    # action is (0, 1, 1) = (1, 1), L = sqrt(0.1^2 + 0.2^2). (1, 1) rematches
    # exactly to the demo's (0, 1, 1), so C = |(0, 0, 0) - (0, 1, 1)| = sqrt(2).
    p = seespot.correspond(LIVE, DEMO, (0, 0, 0))
    assert p["matched"] == (0, 1, 1)
    assert p["l"] == pytest.approx(math.sqrt(0.05), rel=1e-5)
    assert p["rematch"] == (0, 1, 1)
    assert p["rematch_l"] == pytest.approx(0.0, abs=1e-6)
    assert p["c"] == pytest.approx(math.sqrt(2.0))
    assert p["match_map"].shape == (2, 2) and p["match_map"].dtype == np.float32
    assert p["match_map"][1, 1] == pytest.approx(math.sqrt(0.05), rel=1e-5)
    assert p["rematch_map"][0, 0] == pytest.approx(math.sqrt(0.05), rel=1e-5)


def test_match_rematch_ccd_separately() -> None:
    actions, distances = seespot.match_queries(LIVE, np.array([[0.9, 1.1], [0.1, -0.1]], np.float32))
    assert actions.tolist() == [[0, 1, 1], [0, 0, 0]]
    assert distances[1] == pytest.approx(math.sqrt(0.02), rel=1e-5)
    assert seespot.rematch(DEMO, np.array([1, 0], np.float32), rotation=0) == ((0, 1, 0), 0.0)
    assert seespot.ccd((0, 0, 0), (0, 3, 4)) == pytest.approx(5.0)


def test_mask_excludes_actions() -> None:
    mask = np.ones((1, 2, 2), bool)
    mask[0, 1, 1] = False
    actions, _ = seespot.match_queries(LIVE, np.array([[1, 1]], np.float32), mask=mask)
    assert actions.tolist()[0] != [0, 1, 1]


@pytest.mark.parametrize(
    ("call", "arg"),
    [
        (lambda: seespot.correspond(LIVE[0], DEMO, (0, 0, 0)), "live"),
        (lambda: seespot.correspond(LIVE.astype(np.float64), DEMO, (0, 0, 0)), "live"),
        (lambda: seespot.correspond(LIVE, np.full_like(DEMO, np.nan), (0, 0, 0)), "demo"),
        (lambda: seespot.correspond(LIVE, DEMO[..., :1].copy(), (0, 0, 0)), "demo"),
        (lambda: seespot.correspond(LIVE, DEMO, (0, 2, 0)), "demo_action"),
        (lambda: seespot.correspond(LIVE, DEMO, (0, 0, 0), live_mask=np.ones((1, 2), bool)), "live_mask"),
        (lambda: seespot.match_queries(LIVE, np.zeros((1, 3), np.float32)), "queries"),
        (lambda: seespot.match_queries(LIVE, [[0.0, 1.0]]), "queries"),
        (lambda: seespot.rematch(DEMO, np.zeros(2, np.float32), rotation=1), "rotation"),
        (lambda: seespot.distance_map(LIVE, np.zeros(2, np.float32), -1), "rotation"),
        (lambda: seespot.ccd((0, -1, 0), (0, 0, 0)), "demo_action"),
        (lambda: seespot.Trial("stack", -1), "seed"),
        (lambda: seespot.Trial("stak", 1), "task"),
        (lambda: seespot.Trial("stack", 1, resolution=100), "resolution"),
        (lambda: seespot.Trial("stack", 1, resolution=64).step(16, 0, 0), "rotation"),
        (lambda: seespot.test_seeds(9999, 5), "start/count"),
    ],
)
def test_bad_arguments_raise_value_error(call, arg: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match=f"^{arg}"):
        call()


def test_bad_heightmaps() -> None:
    trial = seespot.Trial("stack", 1, resolution=64)
    color, depth = trial.observe()
    policy = seespot.Policy("models/stack.safetensors")
    with pytest.raises(ValueError, match="^depth"):
        policy.q_values(color, depth[:32], "grasp")
    with pytest.raises(ValueError, match="^color"):
        policy.q_values(color.astype(np.float32), depth, "grasp")
    with pytest.raises(ValueError, match="^primitive"):
        policy.q_values(color, depth, "push")


def test_correspond_options_are_the_records_settings() -> None:
    """Correspond's options from Python: a name, or a dict with the keys
    records' settings use, converted by the rules the command line uses."""
    assert seespot.record_name("ssr-ccd") == "ssr-ccd"
    assert seespot.record_name("ssr-ccd", "plain") == "ssr-ccd-plain"
    assert seespot.record_name("ssr-ccd", {"rematch": "global"}) == "ssr-ccd-global-rematch"
    both = {"correspond": "reference", "smoothing": "normalized", "demo_features": "real"}
    assert seespot.record_name("ssr-l2cd", both) == "ssr-l2cd-normalized-demo-real"
    with pytest.raises(ValueError, match="`rematch` applies to correspond reference only, not plain"):
        seespot.record_name("ssr-ccd", {"correspond": "plain", "rematch": "global"})
    with pytest.raises(ValueError, match="unknown key 'rematch_area'"):
        seespot.record_name("ssr-ccd", {"rematch_area": "global"})
    with pytest.raises(ValueError, match="unknown variant `wide`"):
        seespot.record_name("ssr-ccd", {"rematch": "wide"})
    with pytest.raises(ValueError, match="expected None, a name or a dict"):
        seespot.record_name("ssr-ccd", 3)  # type: ignore[arg-type]
