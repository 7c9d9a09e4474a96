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


def test_truth_asks_the_finetuned_policies() -> None:
    report = seespot.truth("unstack", starts=1, finetune_steps=333)
    assert report["set"] == "spot-q-finetuned-333"
    assert report["rows"][-1][2]["probes"] == len(report["answers"]) > 0


def test_truth_takes_a_function() -> None:
    def strided(scene: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(scene[:, :, ::4, ::4])

    report = seespot.truth("stack", starts=1, embeddings=[strided])
    assert report["set"] == "strided"
    assert all(p["policy"] == "strided" for a in report["answers"] for p in a["pairs"])


def test_run_trial_labels_every_decision() -> None:
    plain = seespot.run_trial("ssr-ccd", "unstack", 1)
    labelled = seespot.run_trial("ssr-ccd", "unstack", 1, truth=True)
    assert len(plain["actions_log"]) == len(labelled["actions_log"]) > 0
    for a, b in zip(plain["actions_log"], labelled["actions_log"]):
        a, b = dict(a), dict(b)
        assert "truth" not in a
        truth = b.pop("truth")
        a.pop("decide_ms")
        b.pop("decide_ms")
        # The trial is the same; the labels are added to it.
        assert a == b
        assert len(truth["pairs"]) == 6
        assert truth["chosen"]["verdict"] in {"right", "wrong_block", "miss", "no_progress", "reversal", "out"}
        assert truth["chosen"]["why"]
    # unstack's first grasp, the tower's top, is right.
    assert labelled["actions_log"][0]["truth"]["chosen"]["verdict"] == "right"


def test_env_info_carries_the_truth_of_the_action_taken() -> None:
    import gymnasium as gym

    seespot.register_envs()
    env = gym.make("seespot/Stack-v0", truth=True)
    env.reset(seed=1)
    trial = env.unwrapped._trial
    # A grasp at a free block's centre: the oracle's first grasp.
    oracle = seespot.run_trial("oracle", "stack", 1)
    first = oracle["actions_log"][0]["action"]
    before = trial.truth(first["rotation"], first["y"], first["x"])
    assert before["verdict"] == "right", before
    _, _, _, _, info = env.step(np.array([first["rotation"], first["y"], first["x"]]))
    assert info["truth"] == before
    assert info["primitive_success"]
    # The block set down in a corner, far from the others: no progress,
    # judged as the pair's second half, with its distance to a right place.
    _, _, _, _, info = env.step(np.array([0, 5, 5]))
    assert info["truth"]["verdict"] in {"no_progress", "out"}, info["truth"]
    assert info["truth"]["distance_mm"] > 50
    plain = gym.make("seespot/Stack-v0")
    plain.reset(seed=1)
    _, _, _, _, info = plain.step(np.array([first["rotation"], first["y"], first["x"]]))
    assert "truth" not in info


def test_a_library_call_leaves_the_process_signals_alone() -> None:
    """seespot.truth (and seespot.view from a thread) run the command line in
    this process: SIGPIPE stays as Python set it (ignored), so a closed pipe
    in a notebook is an error, not the end of the kernel."""
    import ctypes
    import signal

    libc = ctypes.CDLL(None)
    libc.signal.restype = ctypes.c_void_p
    libc.signal.argtypes = [ctypes.c_int, ctypes.c_void_p]
    sig_ign = ctypes.c_void_p(1)
    # Python ignores SIGPIPE at start-up (set again here: an earlier test may
    # have run the console script's entry in this process).
    libc.signal(signal.SIGPIPE, sig_ign)
    seespot.truth("unstack", starts=1)
    # Still ignored: the previous disposition reads SIG_IGN (1), not SIG_DFL.
    assert libc.signal(signal.SIGPIPE, sig_ign) == 1
