"""The Ray evaluation writes the records the serial run writes, and binds to
127.0.0.1 only."""

from __future__ import annotations

import gzip
import json
import os
from pathlib import Path

import psutil
import pytest

import seespot
from seespot import dist

from conftest import without_timing

ray = pytest.importorskip("ray")

# IPv4 loopback, also as seen on an IPv6 socket.
LOOPBACK = {"127.0.0.1", "::ffff:127.0.0.1", "::1"}


def _listening_addresses() -> set[str]:
    """The addresses this process and its children (the local Ray) listen on."""
    me = psutil.Process(os.getpid())
    pids = {me.pid} | {p.pid for p in me.children(recursive=True)}
    return {
        c.laddr.ip
        for c in psutil.net_connections(kind="inet")
        if c.status == psutil.CONN_LISTEN and c.pid in pids
    }


def test_ray_records_equal_serial(tmp_path: Path) -> None:
    methods, tasks, seeds = ["oracle", "random"], ["stack", "row"], seespot.test_seeds(1, 3)
    dist.init_local_ray(num_workers=2, threads_per_worker=1)
    try:
        result = dist.evaluate(methods, tasks, seed=1, trials=3, out_dir=tmp_path, num_workers=2)
        nodes = [n["NodeManagerAddress"] for n in ray.nodes()]
        gcs = ray.get_runtime_context().gcs_address
        addresses = _listening_addresses()
    finally:
        ray.shutdown()
    print(f"\nRay node {nodes}, GCS {gcs}; sockets listening on {sorted(addresses)}")
    assert nodes == ["127.0.0.1"]
    assert gcs.startswith("127.0.0.1:")
    assert addresses and addresses <= LOOPBACK
    equal = 0
    for m in methods:
        for t in tasks:
            path = Path(seespot.records_path(tmp_path, m, t))
            on_disk = sorted((json.loads(x) for x in gzip.decompress(path.read_bytes()).decode().splitlines()), key=lambda r: r["seed"])
            assert [r["seed"] for r in on_disk] == seeds
            assert [without_timing(r) for r in result[(m, t)]] == [without_timing(r) for r in on_disk]
            serial_ev = seespot.Evaluator(m, t)
            serial = [json.loads(serial_ev.run(s, i)) for i, s in enumerate(seeds)]
            assert [without_timing(r) for r in on_disk] == [without_timing(r) for r in serial]
            equal += len(serial)
    print(f"Ray records equal to serial: {equal}/{equal}")


def test_resume_skips_recorded_seeds(tmp_path: Path) -> None:
    path = Path(seespot.records_path(tmp_path, "oracle", "stack"))
    dist.append(path, seespot.Evaluator("oracle", "stack").run(1, 0))
    dist.init_local_ray(num_workers=1, threads_per_worker=1)
    try:
        dist.evaluate(["oracle"], ["stack"], seed=1, trials=2, out_dir=tmp_path, num_workers=1)
    finally:
        ray.shutdown()
    seeds = [json.loads(x)["seed"] for x in gzip.decompress(path.read_bytes()).decode().splitlines()]
    assert seeds == [1, 3]


def test_a_folder_another_evaluation_writes_to_is_refused(tmp_path: Path) -> None:
    """Issue 27: seespot.dist took no lock, so it could write beside a running
    ``seespot eval`` (or another seespot.dist) into one folder."""
    with seespot.OutputLock(tmp_path) as held:
        assert held.held
        with pytest.raises(BlockingIOError, match=f"pid {os.getpid()}"):
            dist.evaluate(["oracle"], ["stack"], seed=1, trials=1, out_dir=tmp_path, num_workers=1)
    assert not held.held
    assert not Path(seespot.records_path(tmp_path, "oracle", "stack")).exists()


def test_a_seed_recorded_twice_is_refused(tmp_path: Path) -> None:
    """A trial twice is refused when it is appended, and a file holding one
    twice (written by other means) when it is read, as ``seespot eval`` reads
    it: an error naming the file and line, not a silent overwrite."""
    path = Path(seespot.records_path(tmp_path, "oracle", "stack"))
    line = seespot.Evaluator("oracle", "stack").run(1, 0)
    dist.append(path, line)
    with pytest.raises(ValueError, match="seed 1 is recorded already"):
        dist.append(path, line)
    path.write_bytes(gzip.compress((line + "\n").encode()) * 2)
    with pytest.raises(ValueError, match="stack.jsonl.gz, line 2.*again"):
        dist.recorded(path)
    # A record cut short by a kill (half its gzip member) is dropped, and the
    # next append cuts it off.
    member = gzip.compress((line + "\n").encode())
    path.write_bytes(member + member[: len(member) // 2])
    assert list(dist.recorded(path)) == [1]
    dist.append(path, seespot.Evaluator("oracle", "stack").run(3, 1))
    assert [json.loads(x)["seed"] for x in gzip.decompress(path.read_bytes()).decode().splitlines()] == [1, 3]


def test_ray_runs_an_embedding_set_into_its_named_records(tmp_path: Path) -> None:
    patches = str(Path(__file__).resolve().parents[2] / "models" / "embeddings" / "raw-patches.onnx")
    dist.init_local_ray(num_workers=2, threads_per_worker=1)
    try:
        result = dist.evaluate(
            ["ssr-ccd"], ["unstack"], seed=1, trials=2, out_dir=tmp_path, num_workers=2, embeddings=[patches]
        )
    finally:
        ray.shutdown()
    path = Path(seespot.records_path(tmp_path, "ssr-ccd@raw-patches", "unstack"))
    on_disk = [json.loads(x) for x in gzip.decompress(path.read_bytes()).decode().splitlines()]
    assert {r["method"] for r in on_disk} == {"ssr-ccd@raw-patches"}
    serial = seespot.Evaluator("ssr-ccd", "unstack", embeddings=[patches])
    want = [without_timing(json.loads(serial.run(s, i))) for i, s in enumerate(seespot.test_seeds(1, 2))]
    assert [without_timing(r) for r in sorted(on_disk, key=lambda r: r["seed"])] == want
    assert [without_timing(r) for r in result[("ssr-ccd", "unstack")]] == want


def test_ray_runs_the_finetuned_noisy_and_custom_rows_as_the_serial_run(tmp_path: Path) -> None:
    root = Path(__file__).resolve().parents[2]
    noise = str(root / "scenes" / "noise-224.toml")
    rows = [
        # (method, task, options): a finetuned row (a few reference steps),
        # sensor noise, a task no policy saw, the TransporterNet.
        ("spot-q", "row", {"finetune_steps": 3}),
        ("ssr-ccd", "unstack", {"noise": noise}),
        ("ssr-ccd", "custom:pyramid", {}),
        ("transporter", "stack", {}),
    ]
    seeds = seespot.test_seeds(1, 2)
    for method, task, options in rows:
        out = tmp_path / f"{method}-{task.replace(':', '-')}"
        dist.init_local_ray(num_workers=2, threads_per_worker=1)
        try:
            result = dist.evaluate([method], [task], seed=1, trials=2, out_dir=out, num_workers=2, **options)
        finally:
            ray.shutdown()
        serial = seespot.Evaluator(method, task, out_dir=str(out), **options)
        want = [without_timing(json.loads(serial.run(s, i))) for i, s in enumerate(seeds)]
        path = Path(seespot.records_path(out, serial.record_name, task))
        on_disk = sorted((json.loads(x) for x in gzip.decompress(path.read_bytes()).decode().splitlines()), key=lambda r: r["seed"])
        assert [without_timing(r) for r in on_disk] == want, (method, task, options)
        assert [without_timing(r) for r in result[(method, task)]] == want


def test_the_command_line_runs_the_global_rematch_row(tmp_path: Path) -> None:
    """Every row of ``scripts/eval-all`` runs from the command line, Correspond's
    options included (``--rematch global`` was not accepted): the records are
    the serial run's, under the row's name."""
    dist.main(["--method", "ssr-ccd", "--task", "stack", "--trials", "1", "--workers", "2",
               "--rematch", "global", "--out", str(tmp_path)])
    serial = seespot.Evaluator("ssr-ccd", "stack", correspond={"rematch": "global"})
    assert serial.record_name == "ssr-ccd-global-rematch"
    path = Path(seespot.records_path(tmp_path, serial.record_name, "stack"))
    on_disk = [json.loads(x) for x in gzip.decompress(path.read_bytes()).decode().splitlines()]
    assert [without_timing(r) for r in on_disk] == [without_timing(json.loads(serial.run(1, 0)))]


def test_the_command_line_labels_every_decision(tmp_path: Path) -> None:
    """``--truth`` labels the records with the simulator's truth, as
    ``seespot eval --truth`` does: the same trial, each decision labelled."""
    dist.main(["--method", "ssr-ccd", "--task", "unstack", "--trials", "1", "--workers", "1",
               "--truth", "--out", str(tmp_path)])
    path = Path(seespot.records_path(tmp_path, "ssr-ccd", "unstack"))
    [record] = [json.loads(x) for x in gzip.decompress(path.read_bytes()).decode().splitlines()]
    assert all(len(a["truth"]["pairs"]) == 6 for a in record["actions_log"])
    serial = json.loads(seespot.Evaluator("ssr-ccd", "unstack", truth=True).run(1, 0))
    assert without_timing(record) == without_timing(serial)
