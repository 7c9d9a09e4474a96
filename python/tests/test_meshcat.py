"""The meshcat animation of a trial: a keyframe at each action's end (and one
as the gripper arrives), blocks that move, one standalone HTML file that needs
no server and no network, and a picture of it in headless Chromium."""

from __future__ import annotations

import base64
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("meshcat")

import meshcat  # noqa: E402
import umsgpack  # noqa: E402

from conftest import ROOT  # noqa: E402
from seespot.viz import meshcat as view  # noqa: E402

ACTIONS = 3


@pytest.fixture(scope="module")
def frames() -> view.TrialFrames:
    return view.record_trial("stack", 1, models_dir=ROOT / "models", demos_dir=ROOT / "demos", max_actions=ACTIONS)


def track(anim, path: str, name: str):
    clip = anim.clips[meshcat.Visualizer(window=view.RecordingWindow("", ""))[path].path]
    return clip.tracks[name]


def test_the_animation_has_a_keyframe_per_action_and_the_blocks_move(frames):
    assert len(frames.actions) == ACTIONS
    assert [a.primitive for a in frames.actions] == ["grasp", "place", "grasp"]
    for a in frames.actions:
        assert a.pair is not None, "See-SPOT-Run actions carry their chosen pair"
        assert a.blocks.shape == (4, 7) and a.pair.demo_blocks.shape == (4, 7)
        x, y, z, _yaw = a.pose
        assert abs(x) <= view.WORKSPACE_SIZE / 2 and abs(y) <= view.WORKSPACE_SIZE / 2 and 0 < z < 0.3

    vis = meshcat.Visualizer(window=view.RecordingWindow("", ""))
    anim = view.draw(frames, vis)
    per_action = round(view.SECONDS_PER_ACTION * view.FPS)
    ends = [k * per_action for k in range(1, ACTIONS + 1)]
    moved = 0
    for i in range(4):
        pos = track(anim, f"seespot/blocks/{i}", "position")
        # The start, then each action's arrival and its end.
        assert len(pos.frames) == 1 + 2 * ACTIONS, pos.frames
        assert set(ends) <= set(pos.frames)
        assert pos.frames[0] == 0
        values = np.array(pos.values)
        moved += int(np.abs(values - values[0]).max() > 0.01)
    assert moved >= 1, "no block moved"
    # The grasped block rides in the gripper: at the grasp's end it hangs
    # BLOCK_SIZE / 2 under the palm.
    grasped = next(i for i in range(4) if view._parked(frames.actions[0].blocks[i]))
    at = track(anim, f"seespot/blocks/{grasped}", "position").frames.index(per_action)
    block = np.array(track(anim, f"seespot/blocks/{grasped}", "position").values[at])
    hand = np.array(track(anim, "seespot/gripper/grasp", "position").values[at])
    assert np.allclose(block, hand - [0, 0, view.BLOCK_SIZE / 2], atol=1e-6)
    # The gripper shows the action's colour: grasp, place, grasp.
    shown = track(anim, "seespot/gripper/place", "visible")
    assert [shown.values[shown.frames.index(t)] for t in ends] == [False, True, False]
    # Each action's pair is shown from its arrival until the next's.
    for k in range(1, ACTIONS + 1):
        v = track(anim, f"seespot/pairs/{k}", "visible")
        assert v.values[0] is False and True in v.values


def test_the_standalone_html_holds_the_viewer_and_fetches_nothing(frames, tmp_path):
    out = view.save_html(frames, tmp_path / "trial.html")
    text = out.read_text(encoding="utf-8")
    viewer_js = (Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js").read_text()
    assert viewer_js[:2000] in text and viewer_js[-2000:] in text, "the viewer script is not inline"
    assert "new MeshCat.Viewer" in text
    assert not re.search(r"<script[^>]*\ssrc\s*=", text, re.I), "a script is loaded from elsewhere"
    assert not re.search(r"<link[^>]*href", text, re.I)
    urls = set(re.findall(r"https?://[^\s\"'<>)\\]+", text))
    assert urls <= {"http://www.w3.org/1999/xhtml"}, urls
    # The commands decode as the viewer reads them: one animation, set last.
    commands = [umsgpack.unpackb(base64.b64decode(c)) for c in re.findall(r'^"([A-Za-z0-9+/=]+)",?$', text, re.M)]
    assert [c["type"] for c in commands].count("set_animation") == 1
    assert commands[-1]["type"] == "set_animation"
    assert frames.title() in text


def test_other_methods_are_replayed_without_pairs(tmp_path):
    frames = view.record_trial("stack", 3, method="oracle", max_actions=2)
    assert len(frames.actions) == 2 and all(a.pair is None for a in frames.actions)
    assert frames.actions[0].primitive == "grasp" and frames.actions[0].success
    # The command line writes the file.
    out = tmp_path / "oracle.html"
    view.main(["--task", "stack", "--seed", "3", "--method", "oracle", "--max-actions", "2", "--out", str(out)])
    assert "stack · seed 3 · oracle" in out.read_text(encoding="utf-8")


def test_the_html_renders_offline_in_chromium(tmp_path):
    """The standalone file in headless Chromium with the network cut off (the
    script fails on any request); the picture shows the red block. Into
    $SEESPOT_SCREENSHOTS (scripts/screenshots) or a temp dir."""
    node = shutil.which("node")
    if node is None or not (ROOT / "web" / "node_modules" / "playwright-core").exists():
        pytest.skip("node and web/node_modules (npm --prefix web ci) are needed")
    frames = view.record_trial("stack", 1)
    html_path = view.save_html(frames, tmp_path / "trial.html")
    out_dir = Path(os.environ.get("SEESPOT_SCREENSHOTS", tmp_path))
    out_dir.mkdir(parents=True, exist_ok=True)
    out = out_dir / "meshcat.png"
    subprocess.run([node, str(ROOT / "web" / "shoot-meshcat.mjs"), str(html_path), str(out)], cwd=ROOT, check=True, timeout=180)
    from PIL import Image

    img = Image.open(out).convert("RGB")
    colours = img.getcolors(maxcolors=1 << 20) or []
    red = sum(n for n, (r, g, b) in colours if r > 180 and g < 120 and b < 120)
    assert red > 200, f"no red block in {out} ({red} red pixels)"


def test_an_extension_decides_with_its_extensions_as_its_records_do():
    # Every See-SPOT-Run method is decided here, its extensions acting (they
    # were not, before Ssr.act): the actions are the committed record's.
    import gzip
    import json

    assert "ssr-ccd-undo-wide-guard" in view.SSR_METHODS
    frames = view.record_trial("row", 3, method="ssr-ccd-replace", max_actions=6)
    path = ROOT / "results" / "trials" / "ssr-ccd-replace" / "row.jsonl.gz"
    lines = gzip.decompress(path.read_bytes()).decode().splitlines()
    record = next(json.loads(x) for x in lines if x.strip() and json.loads(x)["seed"] == 3)
    want = [(a["action"]["rotation"], a["action"]["y"], a["action"]["x"]) for a in record["actions_log"][:6]]
    assert [a.action for a in frames.actions] == want
    assert all(a.pair is not None for a in frames.actions)
