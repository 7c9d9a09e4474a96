"""The viser 3-D view against a live `seespot view` server: loopback only, the
scene holds the four blocks at the trial's poses, and a dragged block changes
the next decision (the drag-end handler is called as viser would)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

from conftest import ROOT, serving_view
from seespot.viz.viser import ViserView, pixel_to_world


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def page_url(seespot_bin):
    with serving_view(seespot_bin, "--task", "stack", "--seed", "1") as (url, _):
        yield url


def test_viser_view_shows_the_trial_and_a_drag_changes_the_decision(page_url, tmp_path):
    view = ViserView(page_url, port=free_port())
    try:
        assert view.server.get_host() == "127.0.0.1"
        with pytest.raises(ValueError):
            ViserView(page_url, host="0.0.0.0", port=free_port())
        state = view.client.state()
        assert len(view.boxes) == 4
        for i, c in enumerate(view.controls):
            want = state["blocks"][i]["position"]
            assert all(abs(float(a) - b) < 1e-6 for a, b in zip(c.position, want)), i
        view.step("next_phase")
        before = view.client.get("/api/decision")["action"]
        x, y = pixel_to_world(before["y"], before["x"], state["resolution"])
        # The block under the decided grasp goes to a far corner.
        i = min(
            range(4),
            key=lambda k: (view.controls[k].position[0] - x) ** 2
            + (view.controls[k].position[1] - y) ** 2,
        )
        # As a drag does: from its start on, redraws leave the block where the
        # hand puts it (a redraw still running after the step must not put it back).
        view._on_gizmo(i, "start")
        view.controls[i].position = (0.17 if x < 0 else -0.17, 0.17, 0.025)
        t0 = time.perf_counter()
        after_state = view.drop(i)
        print(f"viser: drop -> new trial settled and decided in {1e3 * (time.perf_counter() - t0):.0f} ms")
        assert after_state is not None, view.gui_status.content
        assert after_state["phase"] == "embed" and after_state["action_index"] == 0
        after = view.client.get("/api/decision")["action"]
        assert after != before
        moved = view.client.state()["blocks"][i]["position"]
        assert abs(moved[1] - 0.17) < 3e-3
        # The layout saves as a scene file from Python too.
        text = view.client.save_layout(str(tmp_path / "layout.toml"))
        assert text.count("[[blocks]]") == 4 and "task = \"stack\"" in text
        # Back in time and live again, through the GUI's handlers.
        assert view.back()["history"]["viewing"] is not None
        assert view.step("live")["history"]["viewing"] is None
    finally:
        view.close()


def test_viser_page_renders_in_chromium(page_url, tmp_path):
    """A screenshot of the viser page (WebGL, headless Chromium) with the four
    blocks drawn; into $SEESPOT_SCREENSHOTS (scripts/screenshots) or a temp dir."""
    import shutil

    node = shutil.which("node")
    shoot = ROOT / "web" / "shoot.mjs"
    if node is None or not (ROOT / "web" / "node_modules" / "playwright-core").exists():
        pytest.skip("node and web/node_modules (npm --prefix web ci) are needed")
    out_dir = Path(os.environ.get("SEESPOT_SCREENSHOTS", tmp_path))
    out_dir.mkdir(parents=True, exist_ok=True)
    out = out_dir / "viser-3d.png"
    view = ViserView(page_url, port=free_port())
    try:
        view.step("next_phase")
        url = f"http://127.0.0.1:{view.server.get_port()}/"
        subprocess.run([node, str(shoot), url, str(out), "6000"], cwd=ROOT, check=True, timeout=180)
    finally:
        view.close()
    from PIL import Image  # viser depends on imageio, which brings Pillow

    img = Image.open(out).convert("RGB")
    colours = img.getcolors(maxcolors=1 << 20) or []
    red = sum(n for n, (r, g, b) in colours if r > 180 and g < 120 and b < 120)
    assert red > 200, f"no red block in {out} ({red} red pixels)"


def test_viser_demonstrates_by_clicks_on_the_table(page_url):
    """A click on the table (the handler viser calls, with a ray from above)
    becomes the demonstration's action, as on the page: the oracle's first
    actions from its demonstration of stack, seed 0, clicked at their world
    poses, give the same actions."""
    view = ViserView(page_url, port=free_port())
    try:
        meta = json.loads((ROOT / "demos" / "stack" / "0" / "meta.json").read_text())
        state = view.demonstrate("stack", meta["seed"])
        assert state["demonstrate"]["task"] == "stack" and state["demonstrate"]["actions"] == []
        for k, step in enumerate(meta["steps"][:4]):
            x, y = step["world_pose"][0], step["world_pose"][1]
            view.gui_rotation.value = step["action"]["rotation"]
            ray = SimpleNamespace(ray_origin=(x, y, 0.6), ray_direction=(0.0, 0.0, -1.0))
            view._on_click(ray)
            done = view.client.state()["demonstrate"]["actions"]
            assert done[k] == step["action"], (k, done)
        # Undo through the same request the GUI's button sends.
        assert len(view.step("demo_undo")["demonstrate"]["actions"]) == 3
        # A click outside the workspace is refused with what is wrong.
        with pytest.raises(RuntimeError, match="outside the"):
            view.click_table(0.5, 0.0)
        assert view.step("demo_stop")["demonstrate"] is None
    finally:
        view.close()


def test_the_end_reads_as_the_page_says_it() -> None:
    from seespot.viz.viser import end_words

    failed = {"end": "action_limit", "end_words": "failed: action limit reached",
              "failure": {"kind": "repeated-action", "label": "repeated identical action"}}
    assert end_words(failed) == "failed: repeated identical action"
    assert end_words({"end": "success", "end_words": "success", "failure": None}) == "success"
