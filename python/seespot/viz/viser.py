"""A 3-D view of a live seespot trial in viser, beside the 2-D debugger page.

It is a client of a running ``seespot view`` server (its page URL), so the 3-D
view and the page show the same session: the table, the four blocks at their
poses, the live colour heightmap as a point cloud, the demo heightmap of the
chosen pair beside the table, the chosen action's gripper pose, and the match
(demo action -> F) and rematch (F -> rematch) as lines. The GUI steps the trial
(next phase, next action, back, live) and resets it (task, seed). Blocks can be
dragged: dropping one sends the four poses to the server (``set_blocks``), which
starts a new trial from them, settles the physics and decides again, so the
page and this view show what See-SPOT-Run would do now.

Demonstrate mode works here as on the page: **Demonstrate** starts a
demonstration of the task typed in **demonstrate** (built-in, or
``custom:NAME``), a click on the table grasps or places at that point with the
gripper turned to **rotation** (0-15), and **Undo**, **Save** and **Leave**
send what the page's buttons send, so both views show the same demonstration.

The viser server binds to 127.0.0.1 only and its share button (a tunnel
through an outside service) is off.

Run it::

    seespot view --no-viewer &          # prints "seespot page: http://127.0.0.1:8765/"
    python -m seespot.viz.viser http://127.0.0.1:8765/ --port 8081
"""

from __future__ import annotations

import argparse
import base64
import json
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from typing import Any, Callable

import numpy as np

#: Edge of a block, metres.
BLOCK_SIZE = 0.05
#: Side of the square workspace, metres (centred on the origin).
WORKSPACE_SIZE = 0.448
#: Block colours in id order: red, blue, green, yellow.
BLOCK_COLORS = [(255, 87, 89), (78, 121, 167), (89, 161, 79), (237, 201, 72)]
#: Where the demo heightmap is drawn, relative to the live one (metres).
DEMO_OFFSET = (WORKSPACE_SIZE + 0.08, 0.0, 0.0)
LOOPBACK = ("127.0.0.1", "localhost", "::1")


def pixel_to_world(py: float, px: float, resolution: int) -> tuple[float, float]:
    """World ``(x, y)`` of heightmap pixel ``(y, x)`` (seespot's grid)."""
    res = WORKSPACE_SIZE / resolution
    return (-WORKSPACE_SIZE / 2 + px * res, -WORKSPACE_SIZE / 2 + py * res)


def heightmap_points(
    color_b64: str, depth_b64: str, resolution: int, offset=(0.0, 0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray]:
    """Points ``N x 3`` (metres) and colours ``N x 3`` (uint8) of a heightmap."""
    n = resolution
    color = np.frombuffer(base64.b64decode(color_b64), dtype=np.uint8).reshape(n * n, 3)
    depth = np.frombuffer(base64.b64decode(depth_b64), dtype="<f4").reshape(n * n)
    ys, xs = np.mgrid[0:n, 0:n]
    x, y = pixel_to_world(ys.reshape(-1), xs.reshape(-1), n)
    pts = np.stack([x, y, depth], axis=1).astype(np.float32) + np.asarray(offset, np.float32)
    return pts, color.copy()



def end_words(state: dict[str, Any]) -> str:
    """How a finished trial ended, in the words the page's trial box uses: a
    failure as ``seespot review`` files it ("failed: repeated identical
    action"), else the trial's own end ("success")."""
    failure = state.get("failure")
    if failure:
        return f"failed: {failure['label']}"
    return str(state["end_words"])

class DebuggerClient:
    """HTTP and WebSocket client of a ``seespot view`` page server."""

    def __init__(self, page_url: str, timeout: float = 120.0):
        parsed = urllib.parse.urlparse(page_url)
        if parsed.scheme != "http" or not parsed.hostname:
            raise ValueError(f"page_url: expected http://HOST:PORT/, got {page_url!r}")
        self.base = f"http://{parsed.netloc}"
        self.ws_url = f"ws://{parsed.netloc}/ws"
        self.timeout = timeout
        self._lock = threading.Condition()
        self._state: dict[str, Any] | None = None
        self._errors: list[str] = []
        self._listeners: list[Callable[[dict[str, Any]], None]] = []
        from websockets.sync.client import connect

        self._ws = connect(self.ws_url, open_timeout=timeout, max_size=None)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def get(self, path: str) -> Any:
        """``GET path`` as JSON."""
        with urllib.request.urlopen(self.base + path, timeout=self.timeout) as r:
            return json.loads(r.read())

    def state(self) -> dict[str, Any]:
        return self.get("/api/state")

    def save_layout(self, path: str) -> str:
        """Writes the session's current block layout as a scene file
        (``seespot view --scene PATH`` starts from it) and returns its text."""
        try:
            with urllib.request.urlopen(self.base + "/api/scene", timeout=self.timeout) as r:
                text = r.read().decode()
        except urllib.error.HTTPError as e:
            raise RuntimeError(e.read().decode()) from e
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        return text

    def on_state(self, listener: Callable[[dict[str, Any]], None]) -> None:
        """Calls ``listener(state)`` (from a background thread) on every change."""
        self._listeners.append(listener)

    def request(self, message: dict[str, Any]) -> dict[str, Any]:
        """Sends one message and waits for the state it leads to; a refusal
        raises ``RuntimeError`` with the server's message."""
        before = self.state()["version"]
        with self._lock:
            self._errors.clear()
        self._ws.send(json.dumps(message))
        deadline = time.monotonic() + self.timeout
        with self._lock:
            while True:
                if self._errors:
                    raise RuntimeError(self._errors.pop(0))
                if self._state is not None and self._state["version"] > before:
                    return self._state
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"no answer to {message['type']} in {self.timeout} s")
                self._lock.wait(left)

    def close(self) -> None:
        self._ws.close()

    def _read(self) -> None:
        try:
            for text in self._ws:
                m = json.loads(text)
                if m.get("type") == "state":
                    with self._lock:
                        self._state = m
                        self._lock.notify_all()
                    for listener in list(self._listeners):
                        listener(m)
                elif m.get("type") == "error":
                    with self._lock:
                        self._errors.append(m.get("message", "error"))
                        self._lock.notify_all()
        except Exception:  # the connection closed
            pass


class ViserView:
    """The viser scene and GUI of one ``seespot view`` session (module docs)."""

    def __init__(self, page_url: str, host: str = "127.0.0.1", port: int = 8081):
        if host not in LOOPBACK:
            raise ValueError(f"host: the 3-D view binds to loopback only, not {host!r}")
        try:
            import viser
        except ImportError as e:
            raise ImportError(
                "the 3-D view needs viser, which is not installed: "
                "pip install 'seespot[viser]' (or pip install viser==1.1.1)"
            ) from e

        self.client = DebuggerClient(page_url)
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.server.gui.configure_theme(show_share_button=False)
        # Look at the table and the demo beside it from the front, above.
        self.server.initial_camera.position = (0.25, -0.55, 0.55)
        self.server.initial_camera.look_at = (0.25, 0.0, 0.0)
        self.controls: list[Any] = []
        self.boxes: list[Any] = []
        self._dragging: set[int] = set()
        self._refresh_lock = threading.Lock()
        self._build()
        self.client.on_state(lambda _s: self.refresh())
        self.refresh()

    # Scene and GUI.

    def _build(self) -> None:
        s = self.server.scene
        s.add_box(
            "/table",
            color=(120, 120, 128),
            dimensions=(WORKSPACE_SIZE, WORKSPACE_SIZE, 0.004),
            position=(0.0, 0.0, -0.002),
        )
        for i, rgb in enumerate(BLOCK_COLORS):
            c = s.add_transform_controls(
                f"/blocks/{i}", scale=0.08, disable_rotations=False, depth_test=False
            )
            b = s.add_box(f"/blocks/{i}/box", color=rgb, dimensions=(BLOCK_SIZE,) * 3)
            c.on_update(lambda e, i=i: self._on_gizmo(i, e.phase))
            self.controls.append(c)
            self.boxes.append(b)
        g = self.server.gui
        self.gui_status = g.add_markdown("connecting…")
        self.gui_task = g.add_dropdown("task", ("stack", "row", "unstack", "vertical-square"))
        self.gui_seed = g.add_number("seed", 1, min=0, step=1)
        g.add_button("Reset").on_click(lambda _e: self.reset())
        g.add_button("Next phase").on_click(lambda _e: self.step("next_phase"))
        g.add_button("Next action").on_click(lambda _e: self.step("next_action"))
        g.add_button("Back").on_click(lambda _e: self.back())
        g.add_button("Live").on_click(lambda _e: self.step("live"))
        with g.add_folder("Demonstrate"):
            self.gui_demo_task = g.add_text("demonstrate", "stack")
            self.gui_rotation = g.add_slider("rotation", min=0, max=15, step=1, initial_value=0)
            self.gui_colours = g.add_checkbox("colours matter", False)
            self.gui_overwrite = g.add_checkbox("overwrite", False)
            g.add_button("Demonstrate").on_click(
                lambda _e: self._guarded(
                    lambda: self.demonstrate(
                        self.gui_demo_task.value, int(self.gui_seed.value), self.gui_colours.value
                    )
                )
            )
            g.add_button("Undo").on_click(lambda _e: self._guarded(lambda: self.step("demo_undo")))
            g.add_button("Save").on_click(
                lambda _e: self._guarded(lambda: self.demo_save(self.gui_overwrite.value))
            )
            g.add_button("Leave").on_click(lambda _e: self._guarded(lambda: self.step("demo_stop")))
        s.on_click()(self._on_click)

    def _guarded(self, f: Callable[[], Any]) -> Any:
        """Runs a GUI action; a refusal shows in the status line."""
        try:
            return f()
        except RuntimeError as e:
            self.gui_status.content = f"**refused:** {e}"
            return None

    def _on_click(self, event: Any) -> None:
        """A click in the scene: where its ray meets the table, demonstrate."""
        o, d = event.ray_origin, event.ray_direction
        if o is None or d is None or abs(d[2]) < 1e-9:
            return
        t = -o[2] / d[2]
        if t <= 0:
            return
        self._guarded(lambda: self.click_table(o[0] + t * d[0], o[1] + t * d[1]))

    def demonstrate(self, task: str, seed: int, colours_matter: bool = False) -> dict[str, Any]:
        """Starts a demonstration of ``task`` from the start of ``seed``."""
        return self.client.request(
            {"type": "demonstrate", "task": task, "seed": seed, "colours_matter": colours_matter}
        )

    def click_table(self, x: float, y: float, rotation: int | None = None) -> dict[str, Any]:
        """A click on the table at world ``(x, y)``: the next primitive at the
        heightmap pixel under it, turned to ``rotation`` (default: the GUI's)."""
        state = self.client.state()
        if state.get("demonstrate") is None:
            raise RuntimeError("not demonstrating: press Demonstrate first")
        n = state["resolution"]
        res = WORKSPACE_SIZE / n
        px, py = round((x + WORKSPACE_SIZE / 2) / res), round((y + WORKSPACE_SIZE / 2) / res)
        r = int(self.gui_rotation.value) if rotation is None else rotation
        action = {"primitive": state["primitive"], "rotation": r, "y": py, "x": px}
        return self.client.request({"type": "demo_act", "action": action})

    def demo_save(self, overwrite: bool = False) -> dict[str, Any]:
        """Saves the demonstration (see the page's Save)."""
        return self.client.request({"type": "demo_save", "overwrite": overwrite})

    def _on_gizmo(self, i: int, phase: str) -> None:
        if phase == "start":
            self._dragging.add(i)
        elif phase == "end":
            self.drop(i)

    def step(self, kind: str) -> dict[str, Any]:
        return self.client.request({"type": kind})

    def back(self) -> dict[str, Any]:
        h = self.client.state()["history"]
        at = (h["viewing"] if h["viewing"] is not None else h["len"] - 1) - 1
        return self.client.request({"type": "goto", "index": max(at, 0)})

    def reset(self) -> dict[str, Any]:
        return self.client.request(
            {"type": "reset", "task": self.gui_task.value, "seed": int(self.gui_seed.value)}
        )

    def block_poses(self) -> list[dict[str, list[float]]]:
        """The blocks as the gizmos hold them: position and ``[x, y, z, w]``."""
        out = []
        for c in self.controls:
            w, x, y, z = (float(v) for v in c.wxyz)
            px, py, pz = (float(v) for v in c.position)
            out.append({"position": [px, py, max(pz, BLOCK_SIZE / 2)], "rotation": [x, y, z, w]})
        return out

    def drop(self, i: int) -> dict[str, Any] | None:
        """A block was dropped: start a new trial from the four poses shown
        and decide again (``set_blocks``)."""
        self._dragging.discard(i)
        try:
            return self.client.request({"type": "set_blocks", "blocks": self.block_poses()})
        except RuntimeError as e:
            self.gui_status.content = f"**refused:** {e}"
            self.refresh()
            return None

    def refresh(self) -> None:
        """Redraws everything from the server's state, decision and frame."""
        with self._refresh_lock:
            state = self.client.state()
            self._draw_blocks(state)
            decision = self.client.get("/api/decision")
            pair = state.get("chosen")
            if pair is None:
                pair = decision["chosen"] if decision else 0
            frame = self.client.get(f"/api/frame?pair={pair}")
            self._draw_heightmaps(frame)
            self._draw_action(state, decision, frame)
            h = state["history"]
            where = "live" if h["viewing"] is None else f"history {h['viewing'] + 1}/{h['len']}"
            self.gui_status.content = (
                f"**{state['task']}** seed {state['seed']} · action {state['action_number']} · "
                f"phase {state['phase'] or '–'} · progress {state['progress']}/4 · {where}"
                + (f" · **{end_words(state)}**" if state["end"] else "")
            )

    def _draw_blocks(self, state: dict[str, Any]) -> None:
        for i, pose in enumerate(state["blocks"]):
            if i in self._dragging:
                continue
            x, y, z = pose["position"]
            qx, qy, qz, qw = pose["rotation"]
            inside = abs(x) <= WORKSPACE_SIZE / 2 and abs(y) <= WORKSPACE_SIZE / 2
            self.controls[i].position = (x, y, z)
            self.controls[i].wxyz = (qw, qx, qy, qz)
            self.controls[i].visible = inside
            self.boxes[i].visible = inside

    def _draw_heightmaps(self, frame: dict[str, Any]) -> None:
        n = frame["resolution"]
        pts, cols = heightmap_points(frame["live"]["color"], frame["live"]["depth"], n, (0, 0, 0.001))
        self.server.scene.add_point_cloud("/live", pts, cols, point_size=WORKSPACE_SIZE / n)
        if frame.get("demo"):
            d = frame["demo"]
            pts, cols = heightmap_points(d["color"], d["depth"], n, DEMO_OFFSET)
            self.server.scene.add_point_cloud("/demo", pts, cols, point_size=WORKSPACE_SIZE / n)

    def _draw_action(self, state, decision, frame) -> None:
        s = self.server.scene
        if not decision or state["phase"] is None:
            s.add_line_segments("/match", np.zeros((0, 2, 3), np.float32), colors=(255, 255, 255))
            return
        n = frame["resolution"]
        p = decision["pairs"][frame["pair"]]

        def at(a, offset=(0.0, 0.0, 0.0)):
            x, y = pixel_to_world(a["y"], a["x"], n)
            return np.array([x + offset[0], y + offset[1], 0.08 + offset[2]], np.float32)

        f, demo = at(p["matched"]), at(p["demo_action"], DEMO_OFFSET)
        segs = [[demo, f]]
        if state["phase"] in ("verify", "act"):
            segs.append([f, at(p["rematch"], DEMO_OFFSET)])
        colors = np.array([[[255, 255, 255]] * 2, [[255, 170, 0]] * 2][: len(segs)], np.uint8)
        s.add_line_segments("/match", np.array(segs, np.float32), colors=colors, thickness=3.0, thickness_units="screen")
        a = decision["action"]
        yaw = a["rotation"] * 2 * np.pi / 16
        x, y = pixel_to_world(a["y"], a["x"], n)
        s.add_frame(
            "/gripper",
            axes_length=0.05,
            axes_radius=0.003,
            position=(x, y, 0.1),
            wxyz=(np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)),
        )

    def close(self) -> None:
        self.client.close()
        self.server.stop()


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("page_url", help="the page URL `seespot view` printed")
    ap.add_argument("--port", type=int, default=8081, help="viser's port (127.0.0.1)")
    args = ap.parse_args(argv)
    view = ViserView(args.page_url, port=args.port)
    print(f"seespot 3-D view: http://127.0.0.1:{view.server.get_port()}/  (Ctrl-C stops)")
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        view.close()


if __name__ == "__main__":
    main()
