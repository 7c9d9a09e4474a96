"""The example notebook (python/examples/notebook.ipynb) runs as written in a
kernel from the repository root: no cell fails, the meshcat cell shows the
standalone animation inline, the debugger cell an iframe of the page, and the
rerun cell rerun's notebook viewer with its assets served on localhost."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("meshcat")

from conftest import ROOT  # noqa: E402

NOTEBOOK = ROOT / "python" / "examples" / "notebook.ipynb"

# Run after the example's cells, in its kernel: the viewer's assets come from
# the kernel's own server on localhost.
ASSETS_CHECK = """
import urllib.request, rerun_notebook
for name in ("widget.js", "re_viewer_bg.wasm"):
    url = rerun_notebook.ESM_MOD.replace("widget.js", name)
    with urllib.request.urlopen(url, timeout=30) as r:
        print("asset", name, url, r.status, len(r.read()))
"""


def seespot_command() -> str | None:
    """The `seespot` command the rerun cell records with: $SEESPOT_BIN, the
    cargo-built binary, or the console script beside this interpreter."""
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    for candidate in (os.environ.get("SEESPOT_BIN"), target / "release" / "seespot"):
        if candidate and Path(candidate).exists():
            return str(candidate)
    return shutil.which("seespot", path=str(Path(sys.executable).parent))


def outputs(cell) -> list:
    return cell.get("outputs", [])


def html_of(cell) -> str:
    return "".join(o.get("data", {}).get("text/html", "") for o in outputs(cell))


def test_the_example_notebook_runs_and_shows_each_view(tmp_path, monkeypatch):
    nb = nbformat.read(NOTEBOOK, as_version=4)
    assert all(not outputs(c) for c in nb.cells if c.cell_type == "code"), "outputs are committed"
    command = seespot_command()
    if command is not None:
        monkeypatch.setenv("SEESPOT_BIN", command)
        nb.cells.append(nbformat.v4.new_code_cell(ASSETS_CHECK))
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # the rerun cell's recording
    monkeypatch.delenv("RERUN_NOTEBOOK_ASSET", raising=False)
    client = nbclient.NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(ROOT)}}
    )
    client.execute()

    errors = [o for c in nb.cells for o in outputs(c) if o.get("output_type") == "error"]
    assert not errors, "\n".join(f"{e['ename']}: {e['evalue']}" for e in errors)
    code = [c for c in nb.cells if c.cell_type == "code"]

    def cell(call: str):
        return next(c for c in code if call in c.source)

    page = html_of(cell("seespot.notebook.meshcat("))
    assert page.startswith("<iframe srcdoc=") and "new MeshCat.Viewer" in page
    assert "unstack · seed 1 · ssr-ccd · success" in page

    assert 'src="http://127.0.0.1:8765/' in html_of(cell("seespot.notebook.debugger("))

    if command is None:
        print("notebook: no seespot command, the rerun cell only said so")
        return
    widgets = [o for o in outputs(cell("seespot.notebook.rerun(")) if "application/vnd.jupyter.widget-view+json" in o.get("data", {})]
    assert widgets, "the rerun cell shows no widget"
    text = "".join(o.get("text", "") for o in outputs(code[-1]))
    served = [line.split() for line in text.splitlines() if line.startswith("asset ")]
    assert [s[1] for s in served] == ["widget.js", "re_viewer_bg.wasm"], text
    for _asset, name, url, status, size in served:
        assert url.startswith("http://localhost:") and status == "200" and int(size) > 100_000, (name, url)
    print(f"notebook: rerun viewer assets served on localhost: {', '.join(f'{s[1]} {int(s[4]) >> 10} KiB' for s in served)}")
