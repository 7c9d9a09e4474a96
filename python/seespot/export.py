"""seespot demonstrations and evaluation trials as a LeRobotDataset (format
v3.0), for the Hugging Face dataset tools.

Each demonstration folder (``demos/<task>/<seed>/``, ``demos/custom/NAME/<n>/``)
becomes one episode, and each of its steps one frame: the scene before the
action and the action taken in it. From a records folder (``results/trials``
or one ``.jsonl.gz`` file of ``seespot eval``), each trial becomes one episode:
it is re-simulated from its seed and its logged actions (the simulator is
deterministic), checking every action's progress against the record, so the
frames are the scenes the method acted on (without a noisy run's sensor noise,
which the records do not keep).

``meta/info.json``
    The format version (``v3.0``), counts, the path templates and every
    feature's dtype, shape and names.
``meta/stats.json``
    Each feature's min, max, mean, std and count.
``meta/tasks.parquet``
    The tasks as LeRobot writes them: a pandas table indexed by the task (the
    seespot task id, e.g. ``stack`` or ``custom:l-shape``) with its
    ``task_index`` (:func:`tasks_table`).
``meta/episodes/chunk-000/file-000.parquet``
    One row per episode: its task, length, where its frames are
    (``data/chunk_index``, ``data/file_index``, ``dataset_from_index``,
    ``dataset_to_index``) and its per-episode stats.
``data/chunk-000/file-000.parquet``
    The frames. ``observation.images.color`` is the colour heightmap (a
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

    seespot export lerobot --demos demos --out /tmp/seespot-demos
    seespot export lerobot --records results/trials/ssr-ccd --out /tmp/seespot-ssr

(``python -m seespot.export lerobot ...`` is the same.)
"""

from __future__ import annotations

import argparse
import io
import json
import sys
from dataclasses import dataclass, field
from collections.abc import Iterable, Iterator
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
HEIGHTMAP = "observation.heightmap"
#: A data file is closed, and the next begun, once it holds this many MB.
DATA_FILE_MB = 100
#: Files per chunk folder.
CHUNKS_SIZE = 1000
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
    such as ``112px/``, are demonstrations folders of their own)."""
    builtin = [p.parent for p in demos.glob("*/*/meta.json") if p.parent.parent.name != "custom"]
    custom = [p.parent for p in demos.glob("custom/*/*/meta.json")]
    found = sorted(builtin + custom)
    if not found:
        raise ValueError(f"{demos}: holds no demonstration (no */meta.json)")
    return found


@dataclass
class _Frame:
    """One action of an episode: the scene before it and the action."""

    color_png: bytes
    depth: np.ndarray
    progress: int
    action: list[float]
    pose: list[float]


@dataclass
class _Episode:
    task: str
    seed: int
    source: str
    frames: list[_Frame] = field(default_factory=list)
    #: More per-episode columns, under ``seespot/``.
    extra: dict[str, Any] = field(default_factory=dict)


def _action(primitive: str, rotation: int, y: int, x: int) -> list[float]:
    return [0.0 if primitive == "grasp" else 1.0, float(rotation), float(y), float(x)]


def _check_out(out: Path, overwrite: bool) -> None:
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise FileExistsError(f"{out}: not empty; pass overwrite=True (--overwrite) to write into it")


def _one_resolution(resolutions: set[int], where: Path) -> int:
    if len(resolutions) != 1:
        raise ValueError(
            f"{where}: holds episodes at several resolutions {sorted(resolutions)}; "
            "a dataset has one image shape: export each resolution's folder on its own"
        )
    return resolutions.pop()


def export_demos(demos: str | Path, out: str | Path, overwrite: bool = False) -> dict[str, Any]:
    """Writes the demonstrations under ``demos`` as a LeRobotDataset v3.0 in
    ``out`` (refused when ``out`` exists and is not empty, unless
    ``overwrite``); returns ``info.json``'s contents."""
    _pyarrow()
    demos, out = Path(demos), Path(out)
    _check_out(out, overwrite)
    dirs = demo_dirs(demos)
    metas = []
    for d in dirs:
        try:
            metas.append(json.loads((d / "meta.json").read_text()))
        except (OSError, json.JSONDecodeError) as e:
            raise ValueError(f"{d / 'meta.json'}: cannot read: {e}") from e
    n = _one_resolution({m["resolution"] for m in metas}, demos)
    return _write((_demo_episode(d, meta) for d, meta in zip(dirs, metas)), n, out)


def _demo_episode(d: Path, meta: dict[str, Any]) -> _Episode:
    """One demonstration folder's episode, from its PNGs and meta.json."""
    ep = _Episode(task=meta["task"], seed=int(meta["seed"]), source=str(d))
    for i, s in enumerate(meta["steps"]):
        a = s["action"]
        depth = _png((d / f"{i:03d}_depth.png").read_bytes()).astype(np.float32) * np.float32(DEPTH_UNIT)
        ep.frames.append(
            _Frame(
                color_png=(d / f"{i:03d}_color.png").read_bytes(),
                depth=depth,
                progress=int(s["progress_before"]),
                action=_action(a["primitive"], a["rotation"], a["y"], a["x"]),
                pose=[float(v) for v in s["world_pose"]],
            )
        )
    return ep


def records_files(records: Path) -> list[Path]:
    """The ``.jsonl.gz`` records files of ``records`` (itself when it is one), in
    path order."""
    if records.is_file():
        return [records]
    found = sorted(records.rglob("*.jsonl.gz"))
    if not found:
        raise ValueError(f"{records}: holds no records file (*.jsonl.gz)")
    return found


def _png_bytes(pixels: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="PNG")
    return buf.getvalue()


def _replay(path: Path, line_no: int, record: dict[str, Any], demos: Path) -> _Episode:
    """One trial record re-simulated from its seed and actions."""
    from seespot import _core, replay

    resolution = record["provenance"]["settings"]["resolution"]
    task, seed = record["task"], int(record["seed"])
    trial = _core.Trial(task, seed, resolution, demos)
    ep = _Episode(
        task=task,
        seed=seed,
        source=str(path),
        extra={
            "method": record["method"],
            "trial": int(record["trial"]),
            "success": bool(record["success"]),
            "end": str(record["end"]),
        },
    )
    for entry, step, (color, depth) in replay(trial, record, f"{path}: record {line_no}", observe=True):
        a = entry["action"]
        ep.frames.append(
            _Frame(
                color_png=_png_bytes(np.asarray(color)),
                depth=np.asarray(depth, np.float32),
                progress=int(step["progress_before"]),
                action=_action(a["primitive"], a["rotation"], a["y"], a["x"]),
                pose=[float(v) for v in step["pose"]],
            )
        )
    return ep


def export_records(
    records: str | Path,
    out: str | Path,
    overwrite: bool = False,
    demos: str | Path = "demos",
    progress: bool = False,
) -> dict[str, Any]:
    """Writes the trials of a records folder (or one records file) as a
    LeRobotDataset v3.0 in ``out``, each re-simulated from its seed and
    actions; returns ``info.json``'s contents. A custom task is defined by its
    demonstrations under ``demos`` (the folder its evaluation used: a trial
    re-simulated against another goal is refused where its progress differs).
    Records of several resolutions are refused (one dataset has one image
    shape)."""
    from seespot import _core

    _pyarrow()
    records, out, demos = Path(records), Path(out), Path(demos)
    _check_out(out, overwrite)
    lines: list[tuple[Path, int, dict[str, Any]]] = []
    for f in records_files(records):
        try:
            lines += [(f, i + 1, json.loads(t)) for i, t in enumerate(_core.read_records(f))]
        except ValueError as e:
            raise ValueError(str(e) if str(f) in str(e) else f"{f}: {e}") from e
    if not lines:
        raise ValueError(f"{records}: holds no trial")
    # Every record's resolution first, so a mixed folder fails before the work.
    resolutions = set()
    for f, i, r in lines:
        res = (r.get("provenance") or {}).get("settings", {}).get("resolution")
        if not isinstance(res, int):
            raise ValueError(
                f"{f}: record {i}: field `provenance.settings.resolution` is missing "
                "(an older record), so its heightmaps' size is unknown"
            )
        resolutions.add(res)
    n = _one_resolution(resolutions, records)

    def episodes() -> Iterator[_Episode]:
        tty = progress and sys.stderr.isatty()
        for k, (f, i, r) in enumerate(lines):
            yield _replay(f, i, r, demos)
            if tty:
                print(f"\r{k + 1}/{len(lines)} trials re-simulated", end="", file=sys.stderr, flush=True)
        if tty:
            print(file=sys.stderr)

    return _write(episodes(), n, out)


#: The features every frame has, in column order (``info.json``'s ``features``
#: with the heightmap's side filled in by :func:`_features`).
def _features(n: int) -> dict[str, dict[str, Any]]:
    scalar = {"shape": [1], "names": None}
    return {
        "observation.images.color": {
            "dtype": "image",
            "shape": [n, n, 3],
            "names": ["height", "width", "channels"],
        },
        "observation.heightmap": {"dtype": "float32", "shape": [n, n], "names": ["height", "width"]},
        "observation.progress": {"dtype": "int64", **scalar},
        "action": {"dtype": "float32", "shape": [4], "names": ["primitive", "rotation", "y", "x"]},
        "action.pose": {"dtype": "float32", "shape": [4], "names": ["x", "y", "z", "yaw"]},
        "timestamp": {"dtype": "float32", **scalar},
        "frame_index": {"dtype": "int64", **scalar},
        "episode_index": {"dtype": "int64", **scalar},
        "index": {"dtype": "int64", **scalar},
        "task_index": {"dtype": "int64", **scalar},
        "next.done": {"dtype": "bool", **scalar},
    }


def _hf_features(features: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The ``datasets`` library's description of the columns (the parquet
    files' ``huggingface`` metadata)."""
    hf: dict[str, Any] = {}
    for name, f in features.items():
        if f["dtype"] == "image":
            hf[name] = {"_type": "Image"}
        elif f["shape"] == [1]:
            hf[name] = {"dtype": f["dtype"], "_type": "Value"}
        elif len(f["shape"]) == 1:
            hf[name] = {
                "feature": {"dtype": f["dtype"], "_type": "Value"},
                "length": f["shape"][0],
                "_type": "Sequence",
            }
        else:
            # Array2D is what datasets expects for a fixed 2-D shape.
            hf[name] = {"shape": f["shape"], "dtype": f["dtype"], "_type": "Array2D"}
    return hf


class _Moments:
    """Running min, max, sum and sum of squares of one feature (float64), so
    the stats need no second pass and no frame is kept. ``samples`` counts
    the rows the mean is over (pixels, for an image); ``frames`` is the count
    the stats report."""

    def __init__(self) -> None:
        self.samples = 0
        self.frames = 0
        self.lo: np.ndarray | None = None
        self.hi: np.ndarray | None = None
        self.sum: np.ndarray | None = None
        self.sq: np.ndarray | None = None

    def add(self, values: np.ndarray, frames: int) -> None:
        """Adds the rows of ``values`` (samples along axis 0) from ``frames`` frames."""
        v = values.astype(np.float64)
        self._combine(v.min(0), v.max(0), v.sum(0), (v * v).sum(0))
        self.samples += v.shape[0]
        self.frames += frames

    def merge(self, other: _Moments) -> None:
        if other.lo is None or other.hi is None or other.sum is None or other.sq is None:
            return
        self._combine(other.lo, other.hi, other.sum, other.sq)
        self.samples += other.samples
        self.frames += other.frames

    def _combine(self, lo: np.ndarray, hi: np.ndarray, sm: np.ndarray, sq: np.ndarray) -> None:
        if self.lo is None or self.hi is None or self.sum is None or self.sq is None:
            self.lo, self.hi, self.sum, self.sq = lo, hi, sm, sq
        else:
            self.lo, self.hi = np.minimum(self.lo, lo), np.maximum(self.hi, hi)
            self.sum, self.sq = self.sum + sm, self.sq + sq

    def stats(self, shape: tuple[int, ...] | None = None) -> dict[str, Any]:
        """min, max, mean, std (each shaped ``shape`` when given) and count."""
        assert self.lo is not None and self.hi is not None and self.sum is not None and self.sq is not None
        mean = self.sum / max(self.samples, 1)
        std = np.sqrt(np.maximum(self.sq / max(self.samples, 1) - mean**2, 0.0))

        def out(v: np.ndarray) -> Any:
            return (v.reshape(shape) if shape else v).tolist()

        return {"min": out(self.lo), "max": out(self.hi), "mean": out(mean), "std": out(std), "count": [self.frames]}


def _episode_table(pa: Any, features: dict[str, dict[str, Any]], columns: dict[str, Any], n: int) -> Any:
    """One episode's frames as a pyarrow table: scalars as their own type,
    vectors as fixed-size lists, the heightmap as an n x n list of lists
    (built from the numpy buffer, without Python lists per pixel)."""
    arrays = {}
    for name, f in features.items():
        values = columns[name]
        if f["dtype"] == "image":
            arrays[name] = pa.array(values, pa.struct([("bytes", pa.binary()), ("path", pa.string())]))
            continue
        t = {"float32": pa.float32(), "int64": pa.int64(), "bool": pa.bool_()}[f["dtype"]]
        if f["shape"] == [1]:
            arrays[name] = pa.array(values, t)
        elif len(f["shape"]) == 1:
            flat = pa.array(np.asarray(values).ravel(), t)
            arrays[name] = pa.FixedSizeListArray.from_arrays(flat, f["shape"][0])
        else:
            flat = pa.array(np.ascontiguousarray(values, np.float32).ravel(), t)
            rows = pa.FixedSizeListArray.from_arrays(flat, n)
            arrays[name] = pa.FixedSizeListArray.from_arrays(rows, n)
    return pa.table(arrays)


def _write(episodes: Iterable[_Episode], n: int, out: Path) -> dict[str, Any]:
    """Writes ``episodes`` (heightmaps ``n`` x ``n``) as the dataset in ``out``,
    one episode at a time: a data file is closed and the next begun once it
    holds ``DATA_FILE_MB`` (the format's ``data_files_size_in_mb``)."""
    pa, pq = _pyarrow()
    features = _features(n)
    hf_meta = json.dumps({"info": {"features": _hf_features(features)}})
    numeric = [name for name, f in features.items() if f["dtype"] != "image"]
    totals = {name: _Moments() for name in numeric}
    colour_total = _Moments()
    tasks: list[str] = []
    ep_rows: list[dict[str, Any]] = []
    chunk, file, file_bytes, index = 0, 0, 0, 0
    writer: Any = None
    for ep in episodes:
        # A trial that ended before its first action (none do today) has no frame.
        if not ep.frames:
            continue
        if ep.task not in tasks:
            tasks.append(ep.task)
        length = len(ep.frames)
        e = len(ep_rows)
        columns: dict[str, Any] = {
            "observation.images.color": [{"bytes": fr.color_png, "path": None} for fr in ep.frames],
            "observation.heightmap": np.stack([fr.depth for fr in ep.frames]).astype(np.float32),
            "observation.progress": [fr.progress for fr in ep.frames],
            "action": np.asarray([fr.action for fr in ep.frames], np.float32),
            "action.pose": np.asarray([fr.pose for fr in ep.frames], np.float32),
            "timestamp": [float(i) / FPS for i in range(length)],
            "frame_index": list(range(length)),
            "episode_index": [e] * length,
            "index": list(range(index, index + length)),
            "task_index": [tasks.index(ep.task)] * length,
            "next.done": [i == length - 1 for i in range(length)],
        }
        if writer is not None and file_bytes >= DATA_FILE_MB * 1024 * 1024:
            writer.close()
            writer, file_bytes = None, 0
            file += 1
            if file == CHUNKS_SIZE:
                chunk, file = chunk + 1, 0
        if writer is None:
            data_file = out / DATA_PATH.format(chunk_index=chunk, file_index=file)
            data_file.parent.mkdir(parents=True, exist_ok=True)
            table = _episode_table(pa, features, columns, n).replace_schema_metadata({"huggingface": hf_meta})
            writer = pq.ParquetWriter(data_file, table.schema)
        else:
            table = _episode_table(pa, features, columns, n).replace_schema_metadata({"huggingface": hf_meta})
        writer.write_table(table)
        file_bytes += table.nbytes

        ep_stats: dict[str, dict[str, Any]] = {}
        for name in numeric:
            m = _Moments()
            values = np.asarray(columns[name], np.float64).reshape(length, -1)
            if name == HEIGHTMAP:
                # Over all pixels, as LeRobot reduces an image over its
                # height and width: one value, shaped [1, 1].
                m.add(values.reshape(-1, 1), length)
                ep_stats[name] = m.stats((1, 1))
            else:
                m.add(values, length)
                ep_stats[name] = m.stats()
            totals[name].merge(m)
        colour = _Moments()
        for fr in ep.frames:
            colour.add(_png(fr.color_png).reshape(-1, 3).astype(np.float64) / 255.0, 1)
        colour_total.merge(colour)
        ep_stats["observation.images.color"] = colour.stats((3, 1, 1))
        ep_rows.append(
            {
                "episode_index": e,
                "tasks": [ep.task],
                "length": length,
                "data/chunk_index": chunk,
                "data/file_index": file,
                "dataset_from_index": index,
                "dataset_to_index": index + length,
                "meta/episodes/chunk_index": 0,
                "meta/episodes/file_index": 0,
                "seespot/source": ep.source,
                "seespot/seed": ep.seed,
                **{f"seespot/{k}": v for k, v in ep.extra.items()},
                **{
                    f"stats/{fname}/{k}": np.asarray(v, np.float64).ravel().tolist()
                    for fname, fs in ep_stats.items()
                    for k, v in fs.items()
                },
            }
        )
        index += length
    if writer is not None:
        writer.close()
    if not ep_rows:
        raise ValueError("no episode has a frame: nothing to export")

    stats = {name: totals[name].stats((1, 1) if name == HEIGHTMAP else None) for name in numeric}
    # The colour image per channel, in [0, 1], shaped [3, 1, 1] as LeRobot keeps it.
    stats["observation.images.color"] = colour_total.stats((3, 1, 1))
    (out / "meta").mkdir(parents=True, exist_ok=True)
    (out / "meta" / "stats.json").write_text(json.dumps(stats, indent=2))

    ep_file = out / EPISODES_PATH.format(chunk_index=0, file_index=0)
    ep_file.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(pa.table({k: [row[k] for row in ep_rows] for k in ep_rows[0]}), ep_file)
    pq.write_table(tasks_table(pa, tasks), out / "meta" / "tasks.parquet")
    info = {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": "seespot-parallel-jaw-gripper",
        "total_episodes": len(ep_rows),
        "total_frames": index,
        "total_tasks": len(tasks),
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": DATA_FILE_MB,
        "video_files_size_in_mb": 500,
        "fps": FPS,
        "splits": {"train": f"0:{len(ep_rows)}"},
        "data_path": DATA_PATH,
        "video_path": None,
        "features": features,
    }
    (out / "meta" / "info.json").write_text(json.dumps(info, indent=2))
    return info


def tasks_table(pa: Any, tasks: list[str]) -> Any:
    """``meta/tasks.parquet`` as LeRobot writes it: a pandas table indexed by
    the task string (index named ``task``) with a ``task_index`` column.
    LeRobot reads it with ``pd.read_parquet`` and names a frame's task by the
    row's index (``tasks.iloc[task_index].name``), so the index must be the
    task, not a number. Written with pyarrow and the pandas metadata that
    makes ``task`` the index, as ``DataFrame.to_parquet`` writes it, so the
    export needs no pandas."""
    pandas_meta = {
        "index_columns": ["task"],
        "column_indexes": [
            {
                "name": None,
                "field_name": None,
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": {"encoding": "UTF-8"},
            }
        ],
        "columns": [
            {
                "name": "task_index",
                "field_name": "task_index",
                "pandas_type": "int64",
                "numpy_type": "int64",
                "metadata": None,
            },
            {"name": "task", "field_name": "task", "pandas_type": "unicode", "numpy_type": "object", "metadata": None},
        ],
        "attributes": {},
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": "2.2.3",
    }
    table = pa.table({"task_index": pa.array(range(len(tasks)), pa.int64()), "task": pa.array(tasks, pa.string())})
    return table.replace_schema_metadata({b"pandas": json.dumps(pandas_meta).encode()})


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m seespot.export", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="format", required=True)
    le = sub.add_parser("lerobot", help="a LeRobotDataset v3.0 of demonstrations or trials")
    le.add_argument(
        "--demos",
        default="demos",
        help="a demonstrations folder to export (default: demos); with --records, where "
        "custom tasks are defined (the folder their evaluation used)",
    )
    le.add_argument("--records", help="a records folder (results/trials) or file: its trials, re-simulated")
    le.add_argument("--out", required=True, help="the dataset folder to write")
    le.add_argument("--overwrite", action="store_true", help="write into a folder that is not empty")
    args = p.parse_args(argv)
    try:
        if args.records is not None:
            info = export_records(
                args.records, args.out, overwrite=args.overwrite, demos=args.demos, progress=True
            )
        else:
            info = export_demos(args.demos, args.out, overwrite=args.overwrite)
    except (ValueError, FileExistsError, ImportError) as e:
        print(f"Error: {e}", file=sys.stderr)
        sys.exit(1)
    print(
        f"{args.out}: LeRobotDataset {info['codebase_version']}, {info['total_episodes']} episodes, "
        f"{info['total_frames']} frames, {info['total_tasks']} tasks"
    )


if __name__ == "__main__":
    main()
