"""A trial as a meshcat animation: one standalone HTML file to attach to a
report or send by email, that opens in any browser with no server running.

seespot has three 3-D/replay views; each answers another question:

- :mod:`seespot.viz.viser` is **live and two-way**: a client of a running
  ``seespot view`` server (the debugger page), it shows that session as it
  changes and sends back what you do (step, reset, drag a block, demonstrate).
- the **rerun** recordings (``seespot record``, ``seespot view``) keep every
  image and tensor of every phase (heightmaps, Q maps, distance maps) with
  time travel in rerun's viewer.
- **meshcat** (this module) is a **light standalone animation**: the table,
  the four blocks moving through the trial's actions, the gripper at each
  action (green: grasp, orange: place) and, for See-SPOT-Run trials, the
  chosen pair's demonstration beside the table with the match (demo action
  -> F, white) and the rematch (F -> rematch, orange) as rods. It is built
  in Python (no server, no socket): :func:`record_trial` runs the trial,
  :func:`save_html` writes the file with meshcat's viewer script inline.

Frames and units: metres in the table frame (the workspace square
``WORKSPACE_SIZE`` centred on the origin, +z up), block poses as
``float32[4, 7]`` (position x, y, z, then the quaternion x, y, z, w, as
:meth:`seespot.Trial.block_poses`), gripper poses ``(x, y, z, yaw)`` with z
at the action height (the highest point in the finger window) and yaw
``rotation * 22.5`` degrees about +z.

The animation has a keyframe at the start and, for action ``k`` (from 1), one
when the gripper arrives at its pose (``k - APPROACH_S`` seconds) and one when
the action is done (``k`` seconds): a grasped block rides in the gripper until
it is placed. meshcat's own server (``meshcat.Visualizer()``) listens on every
network interface, so seespot never starts it: :func:`show` opens the file in
a browser, or draws into a ``Visualizer`` you made yourself.

Run it (the ``[meshcat]`` extra)::

    python -m seespot.viz.meshcat --task stack --seed 1 --out trial.html
"""

from __future__ import annotations

import argparse
import base64
import html
import json
import math
import tempfile
import webbrowser
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from seespot._core import DEFAULT_RESOLUTION, METHODS
from seespot.viz.viser import BLOCK_COLORS, BLOCK_SIZE, DEMO_OFFSET, WORKSPACE_SIZE, pixel_to_world

#: Where the simulator parks a held block, out of the camera's view (metres;
#: ``PARK_POSITION`` in app/sim/src/world.rs).
PARK_POSITION = (0.0, 0.6, 0.4)
#: Gap between a placed block's bottom and the action height, metres
#: (``PLACE_CLEARANCE`` in app/sim/src/world.rs).
PLACE_CLEARANCE = 0.004
#: How far the gripper lifts after an action, metres (a grasp lifts 10 cm).
LIFT = 0.1
#: Seconds per action in the animation, and how long before an action's end
#: the gripper reaches its pose.
SECONDS_PER_ACTION = 1.0
APPROACH_S = 0.4
#: Animation frames per second (meshcat's default).
FPS = 30
#: Where the gripper waits before the first action (metres, yaw).
HOME_POSE = (0.0, 0.0, 0.25, 0.0)
#: Colours, as on the debugger page and in the rerun recordings.
GRASP_COLOR = 0x00E676
PLACE_COLOR = 0xFFAA00
MATCH_COLOR = 0xFFFFFF
REMATCH_COLOR = 0xFFAA00
TABLE_COLOR = 0x787880
#: Height of the match rods above the action heights, and of the rematch
#: rods above the match rods (metres).
ROD_HEIGHT = 0.02
ROD_GAP = 0.02
#: Camera position relative to the view's centre (metres, table frame).
CAMERA_OFFSET = (0.0, -0.32, 0.52)
#: Methods decided here with :class:`seespot.Ssr` (with the pair explanation):
#: every See-SPOT-Run method, its extensions acting through ``Ssr.act``; the
#: others are run by :class:`seespot.Evaluator` and replayed.
SSR_METHODS = tuple(m for m in METHODS if m.startswith("ssr-"))


@dataclass
class ChosenPair:
    """The (policy, demonstration) pair See-SPOT-Run acted on (Sec. 4).

    ``demo_action``, ``matched`` (F, Eq. 5) and ``rematch`` (Eq. 6) are
    ``(rotation, y, x)`` pixels of the demo and the live heightmaps;
    ``l`` is L (Eq. 4) and ``c`` C (Eq. 7, pixels); ``demo_blocks`` is the
    demonstration's scene before ``demo_step`` (``float32[4, 7]``) and
    ``demo_pose`` its gripper pose ``(x, y, z, yaw)``.
    """

    policy: str
    demo: int
    demo_step: int
    demo_action: tuple[int, int, int]
    matched: tuple[int, int, int]
    rematch: tuple[int, int, int]
    l: float
    c: float
    demo_blocks: np.ndarray
    demo_pose: tuple[float, float, float, float]


@dataclass
class ActionFrame:
    """One action of a trial and the scene after it.

    ``action`` is ``(rotation, y, x)``; ``pose`` the gripper's ``(x, y, z,
    yaw)`` (metres, radians); ``blocks`` the block poses after the action
    (``float32[4, 7]``; a held block is parked at :data:`PARK_POSITION`).
    """

    primitive: str
    action: tuple[int, int, int]
    pose: tuple[float, float, float, float]
    success: bool
    progress_before: int
    progress_after: int
    blocks: np.ndarray
    pair: ChosenPair | None = None


@dataclass
class TrialFrames:
    """A trial, ready to animate: the start's block poses and every action."""

    task: str
    seed: int
    method: str
    resolution: int
    start: np.ndarray
    actions: list[ActionFrame] = field(default_factory=list)
    end: str | None = None

    def title(self) -> str:
        """One line: task, seed, method and how the trial ended."""
        n = len(self.actions)
        end = self.end or "stopped"
        return f"{self.task} · seed {self.seed} · {self.method} · {end} after {n} action{'s' * (n != 1)}"


# Running a trial.


def demo_dir(demos_dir: str | Path, task: str, index: int) -> Path:
    """The folder of ``task``'s demonstration number ``index`` (a pair's
    ``demo``), as SSR orders them (:func:`seespot.demo_dirs`)."""
    from seespot import _core

    dirs = _core.demo_dirs(task, demos_dir)
    if index >= len(dirs):
        raise ValueError(f"{demos_dir}: {task} has no demonstration number {index}")
    return Path(dirs[index])


def _demo_step(demos_dir: str | Path, task: str, index: int, step: int) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """The block poses before step ``step`` of a demonstration and its gripper pose."""
    meta_path = demo_dir(demos_dir, task, index) / "meta.json"
    try:
        meta = json.loads(meta_path.read_text())
        s = meta["steps"][step]
        blocks = np.zeros((4, 7), np.float32)
        for i, pose in s["blocks_before"]:
            blocks[i, :3] = pose["position"]
            blocks[i, 3:] = pose["rotation"]
        x, y, z, yaw = (float(v) for v in s["world_pose"])
    except (OSError, ValueError, KeyError, IndexError) as e:
        raise ValueError(f"{meta_path}: field `steps[{step}]`: cannot read it: {e}") from e
    return blocks, (x, y, z, yaw)


def record_trial(
    task: str,
    seed: int,
    method: str = "ssr-ccd",
    models_dir: str | Path = "models",
    demos_dir: str | Path = "demos",
    resolution: int = DEFAULT_RESOLUTION,
    correspond: str = "reference",
    max_actions: int | None = None,
) -> TrialFrames:
    """Runs a trial of ``method`` on ``task`` from ``seed`` and keeps what the
    animation shows. See-SPOT-Run methods (:data:`SSR_METHODS`) decide here
    with :class:`seespot.Ssr`, so each action carries its chosen pair; the
    other methods (``oracle``, ``spot-q``, ``random``, ``transporter``) run as
    ``seespot eval`` does and their logged actions are replayed (the simulator
    is deterministic). ``max_actions`` stops early (e.g. for a short test)."""
    from seespot import _core, replay, run_trial

    trial = _core.Trial(task, seed, resolution, demos_dir)
    n = trial.resolution
    frames = TrialFrames(task=task, seed=seed, method=method, resolution=n, start=trial.block_poses())
    limit = _core.MAX_TRIAL_ACTIONS if max_actions is None else max_actions

    def keep(action: tuple[int, int, int], step: dict[str, Any], pair: ChosenPair | None) -> None:
        x, y, z, yaw = (float(v) for v in step["pose"])
        frames.actions.append(
            ActionFrame(
                primitive=step["primitive"],
                action=action,
                pose=(x, y, z, yaw),
                success=bool(step["primitive_success"]),
                progress_before=int(step["progress_before"]),
                progress_after=int(step["progress_after"]),
                blocks=trial.block_poses(),
                pair=pair,
            )
        )

    if method in SSR_METHODS:
        ssr = _core.Ssr(task, models_dir, demos_dir, method=method, correspond=correspond)
        while trial.end is None and len(frames.actions) < limit:
            d = ssr.act(trial)
            p = d["pairs"][d["chosen"]]
            demo_blocks, demo_pose = _demo_step(demos_dir, task, int(p["demo"]), int(p["demo_step"]))
            pair = ChosenPair(
                policy=p["policy"],
                demo=int(p["demo"]),
                demo_step=int(p["demo_step"]),
                demo_action=tuple(p["demo_action"]),
                matched=tuple(p["matched"]),
                rematch=tuple(p["rematch"]),
                l=float(p["l"]),
                c=float(p["c"]),
                demo_blocks=demo_blocks,
                demo_pose=demo_pose,
            )
            action = tuple(d["action"])
            keep(action, trial.step(*action), pair)
    else:
        record = run_trial(
            method, task, seed, models_dir=str(models_dir), demos_dir=str(demos_dir), resolution=n, correspond=correspond
        )
        for entry, step, _ in replay(trial, record, f"{method} {task} seed {seed}", limit=limit):
            a = entry["action"]
            keep((int(a["rotation"]), int(a["y"]), int(a["x"])), step, None)
    frames.end = trial.end
    return frames


# Geometry: 4 x 4 transforms in the table frame.


def _translation(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def _yaw_pose(x: float, y: float, z: float, yaw: float) -> np.ndarray:
    m = _translation(x, y, z)
    c, s = math.cos(yaw), math.sin(yaw)
    m[:2, :2] = ((c, -s), (s, c))
    return m


def block_matrix(pose: np.ndarray) -> np.ndarray:
    """The 4 x 4 transform of a block pose ``[x, y, z, qx, qy, qz, qw]``."""
    x, y, z, qx, qy, qz, qw = (float(v) for v in pose)
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw) or 1.0
    qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
    m = _translation(x, y, z)
    m[:3, :3] = (
        (1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)),
        (2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)),
        (2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)),
    )
    return m


def _rod(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """The transform taking a box along +z centred on the origin onto the
    segment ``a -> b``, and the segment's length."""
    d = b - a
    length = float(np.linalg.norm(d))
    z = d / length if length > 0 else np.array([0.0, 0.0, 1.0])
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, (a + b) / 2
    return m, length


def _parked(pose: np.ndarray) -> bool:
    return bool(np.linalg.norm(pose[:3] - np.asarray(PARK_POSITION)) < 1e-3)


def _hand_z(primitive: str, pose: tuple[float, float, float, float]) -> float:
    """Height of the bottom of the gripper's palm: the top of the block it
    holds (a grasp's action height is the block's top; a place releases the
    block ``PLACE_CLEARANCE`` above it)."""
    z = pose[2]
    return z if primitive == "grasp" else z + PLACE_CLEARANCE + BLOCK_SIZE


def _in_hand(blocks: np.ndarray, hand: np.ndarray) -> np.ndarray:
    """``blocks`` (``float32[4, 7]``) as 4 x 4 transforms, a parked block
    hanging in the gripper at ``hand`` (the palm's transform)."""
    out = np.stack([block_matrix(p) for p in blocks])
    for i, p in enumerate(blocks):
        if _parked(p):
            out[i] = hand @ _translation(0.0, 0.0, -BLOCK_SIZE / 2)
    return out


@dataclass
class _Key:
    """What one keyframe shows."""

    time: float
    blocks: np.ndarray  # 4 x 4 x 4 transforms
    hand: np.ndarray  # 4 x 4
    primitive: str | None


def _keys(frames: TrialFrames) -> list[_Key]:
    """The start, then for each action its arrival and its end."""
    home = _yaw_pose(*HOME_POSE)
    keys = [_Key(0.0, _in_hand(frames.start, home), home, None)]
    before = frames.start
    for k, a in enumerate(frames.actions, start=1):
        x, y, _z, yaw = a.pose
        hand = _yaw_pose(x, y, _hand_z(a.primitive, a.pose), yaw)
        lifted = _translation(0.0, 0.0, LIFT) @ hand
        t = k * SECONDS_PER_ACTION
        keys.append(_Key(t - APPROACH_S, _in_hand(before, hand), hand, a.primitive))
        keys.append(_Key(t, _in_hand(a.blocks, lifted), lifted, a.primitive))
        before = a.blocks
    return keys


# Drawing: works on a meshcat Visualizer (live or recorded).

#: Where the trial is drawn in the meshcat scene tree.
SCENE_ROOT = "seespot"


def _meshcat() -> Any:
    try:
        import meshcat  # type: ignore[import-untyped]
        import meshcat.animation  # type: ignore[import-untyped]
        import meshcat.geometry  # type: ignore[import-untyped]
    except ImportError as e:
        raise ImportError(
            "the meshcat animation needs meshcat, which is not installed: "
            "pip install 'seespot[meshcat]' (or pip install meshcat==0.3.2)"
        ) from e
    return meshcat


def _centre(frames: TrialFrames) -> tuple[float, float, float]:
    """The view's centre: the table, or between the table and the demonstration."""
    has_demo = any(a.pair is not None for a in frames.actions)
    return (DEMO_OFFSET[0] / 2, 0.0, 0.0) if has_demo else (0.0, 0.0, 0.0)


def draw(frames: TrialFrames, vis: Any) -> Any:
    """Draws the trial into the meshcat ``Visualizer`` ``vis`` under
    ``/seespot`` (the table, blocks, gripper and pairs), points the camera at
    it and starts the animation; returns the :class:`meshcat.animation.Animation`."""
    mc = _meshcat()
    g = mc.geometry
    root = vis[SCENE_ROOT]
    cx, cy, cz = _centre(frames)
    # The orbit camera turns about the origin: move the scene so its centre is there.
    root.set_transform(_translation(-cx, -cy, -cz))
    vis["/Grid"].set_property("visible", False)
    vis["/Axes"].set_property("visible", False)
    # The camera sits in the viewer's y-up frame: table (x, y, z) is (x, z, -y) there.
    ox, oy, oz = CAMERA_OFFSET
    vis["/Cameras/default/rotated/<object>"].set_property("position", [ox, oz, -oy])

    def table(path: str, offset: tuple[float, float, float]) -> None:
        vis[path].set_object(g.Box([WORKSPACE_SIZE, WORKSPACE_SIZE, 0.004]), g.MeshLambertMaterial(color=TABLE_COLOR))
        vis[path].set_transform(_translation(offset[0], offset[1], offset[2] - 0.002))

    def blocks(path: str, opacity: float) -> None:
        for i, (r, gr, b) in enumerate(BLOCK_COLORS):
            colour = (r << 16) | (gr << 8) | b
            vis[f"{path}/{i}"].set_object(g.Box([BLOCK_SIZE] * 3), g.MeshLambertMaterial(color=colour, opacity=opacity))

    table(f"{SCENE_ROOT}/table", (0.0, 0.0, 0.0))
    blocks(f"{SCENE_ROOT}/blocks", 1.0)
    for primitive, colour in (("grasp", GRASP_COLOR), ("place", PLACE_COLOR)):
        _gripper(vis[f"{SCENE_ROOT}/gripper/{primitive}"], g, colour)

    anim = mc.animation.Animation(default_framerate=FPS)
    keys = _keys(frames)
    for key in keys:
        with anim.at_frame(vis, round(key.time * FPS)) as f:
            for i in range(4):
                f[f"{SCENE_ROOT}/blocks/{i}"].set_transform(key.blocks[i])
            for primitive in ("grasp", "place"):
                f[f"{SCENE_ROOT}/gripper/{primitive}"].set_transform(key.hand)
                shown = key.primitive == primitive or (key.primitive is None and primitive == "grasp")
                f[f"{SCENE_ROOT}/gripper/{primitive}"].set_property("visible", "boolean", shown)

    if any(a.pair is not None for a in frames.actions):
        _draw_pairs(frames, vis, anim, g, table, blocks)
    vis.set_animation(anim, play=True, repetitions=1)
    return anim


def _gripper(v: Any, g: Any, colour: int) -> None:
    """A parallel-jaw gripper: palm, wrist and two fingers along the closing
    axis (local x), its frame at the bottom of the palm."""
    material = g.MeshLambertMaterial(color=colour)
    gap = BLOCK_SIZE / 2 + 0.006
    parts = {
        "palm": ([2 * gap + 0.02, 0.024, 0.012], (0.0, 0.0, 0.006)),
        "wrist": ([0.018, 0.018, 0.06], (0.0, 0.0, 0.042)),
        "finger-a": ([0.008, 0.02, 0.05], (gap, 0.0, -0.02)),
        "finger-b": ([0.008, 0.02, 0.05], (-gap, 0.0, -0.02)),
    }
    for name, (size, at) in parts.items():
        v[name].set_object(g.Box(size), material)
        v[name].set_transform(_translation(*at))


def _draw_pairs(frames: TrialFrames, vis: Any, anim: Any, g: Any, table: Any, blocks: Any) -> None:
    """The chosen pair of each action: the demonstration's scene beside the
    table and the match and rematch rods, each shown from the action's
    arrival until the next's."""
    n = frames.resolution
    table(f"{SCENE_ROOT}/demo/table", DEMO_OFFSET)
    blocks(f"{SCENE_ROOT}/demo/blocks", 0.75)
    to_demo = _translation(*DEMO_OFFSET)
    last = round(len(frames.actions) * SECONDS_PER_ACTION * FPS)
    per_action = round(SECONDS_PER_ACTION * FPS)

    def at(px: tuple[int, int, int], z: float, offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
        x, y = pixel_to_world(px[1], px[2], n)
        return np.array([x + offset[0], y + offset[1], z + offset[2]])

    for k, a in enumerate(frames.actions, start=1):
        p = a.pair
        if p is None:
            continue
        start = round((k * SECONDS_PER_ACTION - APPROACH_S) * FPS)
        stop = start + per_action  # the next action's arrival
        # The demonstration's scene, held still from this action's arrival to the next's.
        x, y, _z, yaw = p.demo_pose
        demo = _in_hand(p.demo_blocks, _yaw_pose(x, y, _hand_z(a.primitive, p.demo_pose), yaw))
        hold = [0] if k == 1 else []
        hold += [start] + ([stop - 1] if stop <= last else [last])
        for frame in hold:
            with anim.at_frame(vis, frame) as f:
                for i in range(4):
                    f[f"{SCENE_ROOT}/demo/blocks/{i}"].set_transform(to_demo @ demo[i])
        # The rods: demo action -> F (match) and F -> rematch, above the action
        # heights; the rematch a little higher, so that both show when C = 0.
        live_z, demo_z = a.pose[2] + ROD_HEIGHT, p.demo_pose[2] + ROD_HEIGHT
        f_at = at(p.matched, live_z)
        rods = {
            "match": (at(p.demo_action, demo_z, DEMO_OFFSET), f_at, MATCH_COLOR),
            "rematch": (at(p.matched, live_z + ROD_GAP), at(p.rematch, demo_z + ROD_GAP, DEMO_OFFSET), REMATCH_COLOR),
        }
        group = f"{SCENE_ROOT}/pairs/{k}"
        for name, (a0, a1, colour) in rods.items():
            m, length = _rod(a0, a1)
            vis[f"{group}/{name}"].set_object(
                g.Box([0.005, 0.005, max(length, 1e-4)]), g.MeshBasicMaterial(color=colour)
            )
            vis[f"{group}/{name}"].set_transform(m)
            vis[f"{group}/{name}-end"].set_object(g.Sphere(0.007), g.MeshBasicMaterial(color=colour))
            vis[f"{group}/{name}-end"].set_transform(_translation(*a1))
        shown = [(0, False), (start, True)] + ([(stop, False)] if stop <= last else [])
        for frame, visible in shown:
            with anim.at_frame(vis, frame) as f:
                f[group].set_property("visible", "boolean", visible)


# Standalone HTML: the same Visualizer calls, recorded instead of sent.


class RecordingWindow:
    """Stands in for meshcat's ``ViewerWindow``: keeps the commands a
    ``Visualizer`` sends (msgpack, as the viewer reads them) instead of sending
    them to a server, and writes them into one HTML file with the viewer
    (``Visualizer(window=RecordingWindow(...)).static_html()``)."""

    def __init__(self, title: str, legend: str):
        self.commands: list[bytes] = []
        self.title = title
        self.legend = legend

    def send(self, command: Any) -> None:
        import umsgpack  # type: ignore[import-untyped]

        self.commands.append(umsgpack.packb(command.lower()))

    def get_scene(self) -> str:
        """The HTML page: meshcat's viewer script and the commands, inline."""
        viewer_js = (Path(_meshcat().__file__).parent / "viewer" / "dist" / "main.min.js").read_text()
        commands = ",\n".join(json.dumps(base64.b64encode(c).decode()) for c in self.commands)
        return _PAGE.format(
            title=html.escape(self.title),
            # The script is inline: "</script" inside it would end the tag.
            viewer_js=viewer_js.replace("</script", "<\\/script"),
            commands=commands,
            legend=f"<b>{html.escape(self.title)}</b><br>{self.legend}",
        )


_PAGE = """<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
body {{ margin: 0; }}
#meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
#seespot-legend {{ position: absolute; left: 10px; top: 10px; padding: 6px 10px; font: 13px sans-serif;
  color: #eee; background: rgba(30, 30, 36, 0.75); border-radius: 4px; pointer-events: none; }}
</style>
</head>
<body>
<div id="meshcat-pane"></div>
<div id="seespot-legend">{legend}</div>
<script>
{viewer_js}
</script>
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
window.viewer = viewer;
var commands = [
{commands}
];
for (var i = 0; i < commands.length; i++) {{
  var bytes = atob(commands[i]);
  var data = new Uint8Array(bytes.length);
  for (var j = 0; j < bytes.length; j++) data[j] = bytes.charCodeAt(j);
  viewer.handle_command_bytearray(data);
}}
</script>
</body>
</html>
"""


def standalone_html(frames: TrialFrames) -> str:
    """The animation as one HTML page with the viewer script inline: it opens
    from a file, with no server and no network."""
    mc = _meshcat()
    legend = '<span style="color:#00e676">&#9632;</span> grasp <span style="color:#ffaa00">&#9632;</span> place'
    if any(a.pair is not None for a in frames.actions):
        legend += "<br>right: the chosen demonstration; match (white) and rematch (orange)"
    window = RecordingWindow(frames.title(), legend)
    vis = mc.Visualizer(window=window)
    draw(frames, vis)
    html_text: str = vis.static_html()
    return html_text


def save_html(frames: TrialFrames, path: str | Path) -> Path:
    """Writes :func:`standalone_html` to ``path`` (making its folder) and returns it."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(standalone_html(frames), encoding="utf-8")
    return out


def show(frames: TrialFrames, vis: Any = None) -> Any:
    """Shows the trial: drawn into ``vis`` (a ``meshcat.Visualizer`` you
    started) when given, else written to a temporary HTML file and opened in
    the browser. Returns ``vis``, or the file's path."""
    if vis is not None:
        draw(frames, vis)
        return vis
    with tempfile.NamedTemporaryFile("w", suffix=".html", prefix="seespot-", delete=False, encoding="utf-8") as f:
        f.write(standalone_html(frames))
    webbrowser.open(Path(f.name).as_uri())
    return Path(f.name)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m seespot.viz.meshcat", description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("--task", default="stack", help="stack, row, unstack, vertical-square or custom:NAME")
    ap.add_argument("--seed", type=int, default=1, help="the trial's seed (odd: test seeds)")
    ap.add_argument(
        "--method",
        default="ssr-ccd",
        help="a method of seespot.METHODS: ssr-ccd, ssr-l2cd, an extension (ssr-ccd-undo-wide-guard, ...), oracle, ...",
    )
    ap.add_argument("--models", default="models", help="the policies' folder")
    ap.add_argument("--demos", default="demos", help="the demonstrations' folder")
    ap.add_argument("--resolution", type=int, default=DEFAULT_RESOLUTION)
    ap.add_argument("--max-actions", type=int, default=None, help="stop after this many actions")
    ap.add_argument("--out", default=None, help="write the HTML file here (default: open it in the browser)")
    args = ap.parse_args(argv)
    frames = record_trial(
        args.task,
        args.seed,
        method=args.method,
        models_dir=args.models,
        demos_dir=args.demos,
        resolution=args.resolution,
        max_actions=args.max_actions,
    )
    if args.out is None:
        print(f"seespot meshcat: {show(frames)}")
    else:
        print(f"seespot meshcat: {frames.title()} -> {save_html(frames, args.out)}")


if __name__ == "__main__":
    main()
