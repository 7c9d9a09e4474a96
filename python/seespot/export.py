"""seespot demonstrations as a LeRobotDataset (format v3.0), for the Hugging
Face dataset tools.

Each demonstration folder (``demos/<task>/<seed>/``, ``demos/custom/NAME/<n>/``)
becomes one episode, and each of its steps one frame: the scene before the
action and the action taken in it.

``meta/info.json``
    The format version (``v3.0``), counts, the path templates and every
    feature's dtype, shape and names.
``meta/stats.json``
    Each feature's min, max, mean, std and count.
``meta/tasks.parquet``
    The tasks, by ``task_index`` (a task is the seespot task id, e.g. ``stack``
    or ``custom:l-shape``).
``meta/episodes/chunk-000/file-000.parquet``
    One row per episode: its task, length, where its frames are
    (``data/chunk_index``, ``data/file_index``, ``dataset_from_index``,
    ``dataset_to_index``) and its per-episode stats.
``data/chunk-000/file-000.parquet``
    The frames. ``observation.images.color`` is the colour heightmap (the
    demonstration's own PNG, an image feature); ``observation.heightmap`` is
    the depth heightmap in metres above the table (float32 H x W);
    ``observation.progress`` is the task's progress P before the action;
    ``action`` is ``[primitive (0 grasp, 1 place), rotation index, pixel y,
    pixel x]``; ``action.pose`` is the gripper's metric pose ``[x, y, z, yaw]``
    (metres, radians). Then the format's own columns: ``timestamp``,
    ``frame_index``, ``episode_index``, ``index``, ``task_index``, ``next.done``.

Written with pyarrow and Pillow (``pip install 'seespot[lerobot]'``), so it
needs neither ``lerobot`` nor ``datasets``; the tests load the result with both
pyarrow and ``datasets``.

Run it::

    python -m seespot.export lerobot --demos demos --out /tmp/seespot-demos
"""

from __future__ import annotations

import argparse
import io
import json
from pathlib import Path
from typing import Any

import numpy as np

#: The LeRobotDataset format written.
CODEBASE_VERSION = "v3.0"
#: Frames per second stated in ``info.json``: one action per second (the
#: steps of a demonstration are actions, not a sampled clock).
FPS = 1
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
EPISODES_PATH = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
#: Depth PNG unit of a demonstration, metres per level.
DEPTH_UNIT = 1e-5


def _pyarrow() -> Any:
    try:
        import PIL  # noqa: F401
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as e:
        raise ImportError(
            "the LeRobot export needs pyarrow and Pillow: pip install 'seespot[lerobot]'"
        ) from e
    return pa, pq


def _png(data: bytes) -> np.ndarray:
    """A PNG's pixels (Pillow): uint8 H x W x 3 for colour, uint16 H x W for
    seespot's 16-bit grey depth."""
    from PIL import Image

    with Image.open(io.BytesIO(data)) as im:
        return np.array(im)


def demo_dirs(demos: Path) -> list[Path]:
    """Every demonstration folder of a demonstrations folder, in path order:
    ``<task>/<seed>/`` and ``custom/NAME/<n>/`` (other sets kept inside it,
    such as ``paper-scale/``, are demonstrations folders of their own)."""
    builtin = [p.parent for p in demos.glob("*/*/meta.json") if p.parent.parent.name != "custom"]
    custom = [p.parent for p in demos.glob("custom/*/*/meta.json")]
    found = sorted(builtin + custom)
    if not found:
        raise ValueError(f"{demos}: holds no demonstration (no */meta.json)")
    return found


def _stats(values: np.ndarray, axis: tuple[int, ...]) -> dict[str, Any]:
    v = values.astype(np.float64)
    return {
        "min": v.min(axis=axis).tolist(),
        "max": v.max(axis=axis).tolist(),
        "mean": v.mean(axis=axis).tolist(),
        "std": v.std(axis=axis).tolist(),
        "count": [int(values.shape[0])],
    }


def export_demos(demos: str | Path, out: str | Path, overwrite: bool = False) -> dict[str, Any]:
    """Writes the demonstrations under ``demos`` as a LeRobotDataset v3.0 in
    ``out`` (refused when ``out`` exists and is not empty, unless
    ``overwrite``); returns ``info.json``'s contents."""
    pa, pq = _pyarrow()
    demos, out = Path(demos), Path(out)
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise FileExistsError(f"{out}: not empty; pass overwrite=True (--overwrite) to write into it")
    dirs = demo_dirs(demos)
    metas = []
    for d in dirs:
        try:
            metas.append(json.loads((d / "meta.json").read_text()))
        except (OSError, json.JSONDecodeError) as e:
            raise ValueError(f"{d / 'meta.json'}: cannot read: {e}") from e
    resolutions = {m["resolution"] for m in metas}
    if len(resolutions) != 1:
        raise ValueError(
            f"{demos}: demonstrations at several resolutions {sorted(resolutions)}; "
            "a dataset has one image shape: export each resolution's folder on its own"
        )
    n = resolutions.pop()
    tasks = sorted({m["task"] for m in metas})
    rows: dict[str, list[Any]] = {
        k: []
        for k in [
            "observation.images.color",
            "observation.heightmap",
            "observation.progress",
            "action",
            "action.pose",
            "timestamp",
            "frame_index",
            "episode_index",
            "index",
            "task_index",
            "next.done",
        ]
    }
    episodes: list[dict[str, Any]] = []
    index = 0
    for e, (d, meta) in enumerate(zip(dirs, metas)):
        start = index
        steps = meta["steps"]
        for i, s in enumerate(steps):
            a = s["action"]
            colour = (d / f"{i:03d}_color.png").read_bytes()
            depth = _png((d / f"{i:03d}_depth.png").read_bytes()).astype(np.float32) * np.float32(DEPTH_UNIT)
            rows["observation.images.color"].append({"bytes": colour, "path": None})
            rows["observation.heightmap"].append(depth)
            rows["observation.progress"].append([int(s["progress_before"])])
            rows["action"].append(
                [0.0 if a["primitive"] == "grasp" else 1.0, float(a["rotation"]), float(a["y"]), float(a["x"])]
            )
            rows["action.pose"].append([float(v) for v in s["world_pose"]])
            rows["timestamp"].append([float(i) / FPS])
            rows["frame_index"].append([i])
            rows["episode_index"].append([e])
            rows["index"].append([index])
            rows["task_index"].append([tasks.index(meta["task"])])
            rows["next.done"].append([i == len(steps) - 1])
            index += 1
        episodes.append(
            {
                "episode_index": e,
                "tasks": [meta["task"]],
                "length": len(steps),
                "data/chunk_index": 0,
                "data/file_index": 0,
                "dataset_from_index": start,
                "dataset_to_index": index,
                "meta/episodes/chunk_index": 0,
                "meta/episodes/file_index": 0,
                "seespot/source": str(d),
                "seespot/seed": int(meta["seed"]),
            }
        )

    features: dict[str, dict[str, Any]] = {
        "observation.images.color": {
            "dtype": "image",
            "shape": [n, n, 3],
            "names": ["height", "width", "channels"],
        },
        "observation.heightmap": {"dtype": "float32", "shape": [n, n], "names": ["height", "width"]},
        "observation.progress": {"dtype": "int64", "shape": [1], "names": None},
        "action": {
            "dtype": "float32",
            "shape": [4],
            "names": ["primitive", "rotation", "y", "x"],
        },
        "action.pose": {"dtype": "float32", "shape": [4], "names": ["x", "y", "z", "yaw"]},
        "timestamp": {"dtype": "float32", "shape": [1], "names": None},
        "frame_index": {"dtype": "int64", "shape": [1], "names": None},
        "episode_index": {"dtype": "int64", "shape": [1], "names": None},
        "index": {"dtype": "int64", "shape": [1], "names": None},
        "task_index": {"dtype": "int64", "shape": [1], "names": None},
        "next.done": {"dtype": "bool", "shape": [1], "names": None},
    }

    # Frames: scalars as their own type, vectors as fixed-size lists.
    def column(name: str) -> Any:
        f = features[name]
        values = rows[name]
        if f["dtype"] == "image":
            return pa.array(values, pa.struct([("bytes", pa.binary()), ("path", pa.string())]))
        t = {"float32": pa.float32(), "int64": pa.int64(), "bool": pa.bool_()}[f["dtype"]]
        if f["shape"] == [1]:
            return pa.array([v[0] for v in values], t)
        if len(f["shape"]) == 1:
            return pa.array(values, pa.list_(t, f["shape"][0]))
        return pa.array([np.asarray(v).tolist() for v in values], pa.list_(pa.list_(t, n), n))

    hf_features = {}
    for name, f in features.items():
        if f["dtype"] == "image":
            hf_features[name] = {"_type": "Image"}
        elif f["shape"] == [1]:
            hf_features[name] = {"dtype": f["dtype"], "_type": "Value"}
        elif len(f["shape"]) == 1:
            hf_features[name] = {
                "feature": {"dtype": f["dtype"], "_type": "Value"},
                "length": f["shape"][0],
                "_type": "Sequence",
            }
        else:
            hf_features[name] = {"shape": f["shape"], "dtype": f["dtype"], "_type": "Array2D"}
    table = pa.table({name: column(name) for name in features})
    hf_meta = json.dumps({"info": {"features": hf_features}})
    table = table.replace_schema_metadata({"huggingface": hf_meta})
    # Array2D columns are what datasets expects for a fixed 2-D shape.
    data_file = out / DATA_PATH.format(chunk_index=0, file_index=0)
    data_file.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, data_file)

    # Stats over all frames, and per episode (in the episodes table).
    def feature_stats(lo: int, hi: int) -> dict[str, dict[str, Any]]:
        st: dict[str, dict[str, Any]] = {}
        for name, f in features.items():
            if f["dtype"] == "image":
                continue
            vals = np.asarray(rows[name][lo:hi], dtype=np.float64)
            st[name] = _stats(vals, (0,) if vals.ndim == 2 else (0,))
        # The colour image per channel, in [0, 1], shaped [3, 1, 1] as LeRobot keeps it.
        st["observation.images.color"] = _image_stats(rows["observation.images.color"][lo:hi])
        return st

    stats = feature_stats(0, index)
    (out / "meta").mkdir(parents=True, exist_ok=True)
    (out / "meta" / "stats.json").write_text(json.dumps(stats, indent=2))

    ep_columns: dict[str, list[Any]] = {k: [ep[k] for ep in episodes] for k in episodes[0]}
    for ep in episodes:
        st = feature_stats(ep["dataset_from_index"], ep["dataset_to_index"])
        for fname, fs in st.items():
            for k, v in fs.items():
                ep_columns.setdefault(f"stats/{fname}/{k}", []).append(np.asarray(v, np.float64).ravel().tolist())
    ep_table = pa.table(ep_columns)
    ep_file = out / EPISODES_PATH.format(chunk_index=0, file_index=0)
    ep_file.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(ep_table, ep_file)

    pq.write_table(
        pa.table({"task_index": pa.array(range(len(tasks)), pa.int64()), "task": pa.array(tasks)}),
        out / "meta" / "tasks.parquet",
    )
    info = {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": "seespot-parallel-jaw-gripper",
        "total_episodes": len(episodes),
        "total_frames": index,
        "total_tasks": len(tasks),
        "chunks_size": 1000,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 500,
        "fps": FPS,
        "splits": {"train": f"0:{len(episodes)}"},
        "data_path": DATA_PATH,
        "video_path": None,
        "features": features,
    }
    (out / "meta" / "info.json").write_text(json.dumps(info, indent=2))
    return info


def _image_stats(images: list[dict[str, Any]]) -> dict[str, Any]:
    """Per-channel stats of PNG colour images, in [0, 1], shaped ``[3, 1, 1]``."""
    total = np.zeros(3)
    sq = np.zeros(3)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    count = 0
    for im in images:
        px = _png(im["bytes"]).reshape(-1, 3).astype(np.float64) / 255.0
        total += px.sum(0)
        sq += (px**2).sum(0)
        lo, hi = np.minimum(lo, px.min(0)), np.maximum(hi, px.max(0))
        count += px.shape[0]
    mean = total / max(count, 1)
    std = np.sqrt(np.maximum(sq / max(count, 1) - mean**2, 0.0))
    shape = lambda v: np.asarray(v).reshape(3, 1, 1).tolist()  # noqa: E731
    return {"min": shape(lo), "max": shape(hi), "mean": shape(mean), "std": shape(std), "count": [len(images)]}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m seespot.export", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="format", required=True)
    le = sub.add_parser("lerobot", help="a LeRobotDataset v3.0 of the demonstrations")
    le.add_argument("--demos", default="demos", help="a demonstrations folder (default: demos)")
    le.add_argument("--out", required=True, help="the dataset folder to write")
    le.add_argument("--overwrite", action="store_true", help="write into a folder that is not empty")
    args = p.parse_args(argv)
    info = export_demos(args.demos, args.out, overwrite=args.overwrite)
    print(
        f"{args.out}: LeRobotDataset {info['codebase_version']}, {info['total_episodes']} episodes, "
        f"{info['total_frames']} frames, {info['total_tasks']} tasks"
    )


if __name__ == "__main__":
    main()
