"""Shipped policies' Q maps and embeddings, and See-SPOT-Run's explanation."""

from __future__ import annotations

import numpy as np

import seespot


def test_policy_q_values_and_embeddings() -> None:
    policy = seespot.Policy("models/stack.safetensors")
    n = policy.resolution
    color, depth = seespot.Trial("stack", 1, resolution=n).observe()
    q = policy.q_values(color, depth, "grasp")
    assert q.shape == (16, n, n) and q.dtype == np.float32
    e = policy.embed(color, depth, "grasp")
    assert e.shape == (16, n, n, 64) and e.dtype == np.float32
    assert np.isfinite(e).all()


def test_ssr_decide_explains_every_pair() -> None:
    ssr = seespot.Ssr("stack")
    assert ssr.policy_names == [t for t in seespot.TASKS if t != "stack"]
    trial = seespot.Trial("stack", 1)
    color, depth = trial.observe()
    d = ssr.decide(color, depth, trial.progress, trial.next_primitive)
    assert len(d["pairs"]) == 6
    chosen = d["pairs"][d["chosen"]]
    assert d["action"] == chosen["matched"]
    n = trial.resolution
    for p in d["pairs"]:
        assert p["match_map"].shape == (n, n) and p["rematch_map"].dtype == np.float32
        assert p["c"] >= 0.0 and p["l"] >= 0.0
    trial.step(*d["action"])
