"""The LeRobotDataset v3.0 export of the shipped demonstrations
(``seespot.export``): it loads with pyarrow and with ``datasets``, one episode
per demonstration, one frame per step, episode boundaries and feature shapes
as ``meta/`` states them."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from PIL import Image

from conftest import ROOT
from seespot.export import demo_dirs, export_demos


def test_the_shipped_demonstrations_export_as_a_lerobot_v3_dataset(tmp_path: Path) -> None:
    out = tmp_path / "lerobot"
    info = export_demos(ROOT / "demos", out)
    dirs = demo_dirs(ROOT / "demos")
    metas = [json.loads((d / "meta.json").read_text()) for d in dirs]
    steps = [len(m["steps"]) for m in metas]
    assert len(dirs) == 12  # four built-in tasks x 2, two custom tasks x 2
    assert info["codebase_version"] == "v3.0"
    assert (info["total_episodes"], info["total_frames"]) == (len(dirs), sum(steps))
    assert json.loads((out / "meta" / "info.json").read_text()) == info

    # The frames, with pyarrow.
    frames = pq.read_table(out / "data" / "chunk-000" / "file-000.parquet")
    assert frames.num_rows == sum(steps)
    assert set(frames.column_names) == set(info["features"])
    ep = frames.column("episode_index").to_pylist()
    assert frames.column("index").to_pylist() == list(range(sum(steps)))

    # Episode boundaries: the episodes table says where each one's frames are.
    episodes = pq.read_table(out / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pylist()
    assert [e["length"] for e in episodes] == steps
    for e, meta in zip(episodes, metas):
        lo, hi = e["dataset_from_index"], e["dataset_to_index"]
        assert hi - lo == e["length"]
        assert set(ep[lo:hi]) == {e["episode_index"]}
        assert e["tasks"] == [meta["task"]]
        assert frames.column("frame_index").to_pylist()[lo:hi] == list(range(e["length"]))
        assert frames.column("next.done").to_pylist()[hi - 1] is True
    tasks = pq.read_table(out / "meta" / "tasks.parquet").to_pylist()
    assert sorted(t["task"] for t in tasks) == sorted({m["task"] for m in metas})
    assert "custom:l-shape" in {t["task"] for t in tasks}

    # The same frames with the datasets library: images decode, shapes hold.
    datasets = pytest.importorskip("datasets")
    ds = datasets.load_dataset(
        "parquet", data_files=str(out / "data" / "chunk-000" / "file-000.parquet"), split="train"
    )
    assert len(ds) == sum(steps)
    first = ds[0]
    n = metas[0]["resolution"]
    img = first["observation.images.color"]
    assert img.size == (n, n)
    with Image.open(dirs[0] / "000_color.png") as want:
        assert np.array_equal(np.array(img), np.array(want))
    depth = np.asarray(first["observation.heightmap"], dtype=np.float32)
    assert depth.shape == tuple(info["features"]["observation.heightmap"]["shape"])
    with Image.open(dirs[0] / "000_depth.png") as d16:
        assert np.allclose(depth, np.array(d16).astype(np.float32) * 1e-5)
    a = metas[0]["steps"][0]["action"]
    assert first["action"] == [0.0, a["rotation"], a["y"], a["x"]]
    assert np.allclose(first["action.pose"], metas[0]["steps"][0]["world_pose"])

    # Stats for every feature.
    stats = json.loads((out / "meta" / "stats.json").read_text())
    assert set(stats) == set(info["features"])
    assert np.array(stats["observation.images.color"]["mean"]).shape == (3, 1, 1)
    assert stats["action"]["count"] == [sum(steps)]


def test_tasks_parquet_is_indexed_by_the_task_as_lerobot_writes_it(tmp_path: Path) -> None:
    """``meta/tasks.parquet`` is a pandas table whose index is the task string
    (LeRobot names a frame's task by ``tasks.iloc[task_index].name``; a task
    column under a numbered index made every frame's task read as 0)."""
    out = tmp_path / "lerobot"
    export_demos(ROOT / "demos", out)
    table = pq.read_table(out / "meta" / "tasks.parquet")
    pandas_meta = json.loads(table.schema.metadata[b"pandas"])
    assert pandas_meta["index_columns"] == ["task"]
    assert table.column_names == ["task_index", "task"]
    assert str(table.schema.field("task_index").type) == "int64"
    rows = table.to_pylist()
    assert [r["task_index"] for r in rows] == list(range(len(rows)))
    task_of = {r["task_index"]: r["task"] for r in rows}
    # Every frame's task_index names its episode's task.
    episodes = pq.read_table(out / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pylist()
    frames = pq.read_table(out / "data" / "chunk-000" / "file-000.parquet").to_pylist()
    for e in episodes:
        for f in frames[e["dataset_from_index"] : e["dataset_to_index"]]:
            assert [task_of[f["task_index"]]] == e["tasks"]

    try:
        import pandas as pd
    except ImportError:
        return
    tasks = pd.read_parquet(out / "meta" / "tasks.parquet")
    assert list(tasks.index) == [r["task"] for r in rows]
    assert all(tasks.iloc[i].name == task_of[i] for i in task_of)
    assert int(tasks.loc["stack"].task_index) == [r["task"] for r in rows].index("stack")


def test_lerobot_itself_reads_each_frames_task_as_its_words(tmp_path: Path) -> None:
    """Through LeRobot itself (skipped where it is not installed; run with
    lerobot 0.4.4): the dataset opens, every frame's task is its episode's
    words, and a DataLoader batches it."""
    pytest.importorskip("lerobot")
    torch = pytest.importorskip("torch")
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    out = tmp_path / "lerobot"
    export_demos(ROOT / "demos", out)
    episodes = pq.read_table(out / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pylist()
    ds = LeRobotDataset("seespot/demos", root=out)
    assert len(ds) == sum(e["dataset_to_index"] - e["dataset_from_index"] for e in episodes)
    for e in episodes:
        for i in range(e["dataset_from_index"], e["dataset_to_index"]):
            assert ds[i]["task"] == e["tasks"][0]
    batch = next(iter(torch.utils.data.DataLoader(ds, batch_size=8)))
    assert batch["task"] == [ds[i]["task"] for i in range(8)]
    assert tuple(batch["observation.images.color"].shape[:2]) == (8, 3)


def test_export_refuses_a_folder_that_is_not_empty(tmp_path: Path) -> None:
    (tmp_path / "keep.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="not empty"):
        export_demos(ROOT / "demos", tmp_path)
    assert (tmp_path / "keep.txt").read_text() == "mine"
    with pytest.raises(ValueError, match="holds no demonstration"):
        export_demos(tmp_path, tmp_path / "out")


def test_the_export_command_runs(tmp_path: Path) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "seespot.export", "lerobot", "--demos", "demos", "--out", str(tmp_path / "ds")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    assert "12 episodes" in r.stdout
