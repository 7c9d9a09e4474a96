"""The README and the documentation pages as a newcomer follows them: the
Python snippet of docs/python.md and every example under python/examples/
run exactly as written, from the repository root; the quick start's
commands run (in cheap form); and every `seespot` command the README and
docs/*.md show is accepted by the binary (its flags and values parse)."""

from __future__ import annotations

import re
import shlex
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

import pytest

from conftest import ROOT

README = (ROOT / "README.md").read_text()
PYTHON_PAGE = (ROOT / "docs" / "python.md").read_text()
PAGES = [README, *(p.read_text() for p in sorted((ROOT / "docs").glob("*.md")))]


def _blocks(lang: str, text: str = README) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", text, flags=re.S)


def _section(title: str) -> str:
    start = README.index(f"## {title}\n")
    end = README.find("\n## ", start + 1)
    return README[start : end if end > 0 else None]


def _run_python(args: list[str], timeout: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=timeout
    )


def test_the_readme_python_snippet_runs_as_written() -> None:
    [snippet] = _blocks("python", PYTHON_PAGE)
    r = _run_python(["-c", snippet], timeout=600)
    assert r.returncode == 0, f"the README's snippet failed:\n{r.stdout}\n{r.stderr}"
    assert "F (" in r.stdout and "C " in r.stdout, r.stdout


@pytest.mark.parametrize(
    "example", sorted(p.name for p in (ROOT / "python" / "examples").glob("*.py"))
)
def test_every_example_runs_as_written(example: str) -> None:
    path = ROOT / "python" / "examples" / example
    if "import ray" in path.read_text() or "seespot import dist" in path.read_text():
        pytest.importorskip("ray")
    if "import torch" in path.read_text():
        pytest.importorskip("torch")
    r = _run_python([str(path.relative_to(ROOT))], timeout=900)
    assert r.returncode == 0, f"{example} failed:\n{r.stdout}\n{r.stderr}"


def _readme_commands() -> list[list[str]]:
    """Every `seespot ...` command the README and docs/*.md show (inline or
    in a block), as argument lists, less those with placeholders (`...`,
    FILE, shell variables, alternatives)."""
    found: list[str] = []
    for line in "\n".join(PAGES).splitlines():
        for m in re.finditer(r"`((?:seespot|cargo run --release -p seespot --) [^`]+)`", line):
            found.append(m.group(1))
        m = re.match(r"\s*(cargo run --release -p seespot -- .*)", line)
        if m:
            found.append(m.group(1))
    out = []
    for cmd in found:
        cmd = cmd.split("#")[0].strip().replace("cargo run --release -p seespot --", "seespot")
        if re.search(r"\.\.\.|…|\||\$|\bFILE\b|\bN\b|\bDIR\b|\bARGS\b|\bCOMMAND\b|\bTASK\b|\bPORT\b|<", cmd):
            continue
        out.append(shlex.split(cmd)[1:])
    return out


def test_every_seespot_command_in_the_readme_parses(seespot_bin: Path) -> None:
    commands = _readme_commands()
    assert len(commands) >= 20, commands
    bad = []
    for args in commands:
        r = subprocess.run(
            [str(seespot_bin), *args, "--help"], cwd=ROOT, capture_output=True, text=True, timeout=60
        )
        if r.returncode != 0:
            bad.append(f"seespot {shlex.join(args)}: {r.stderr.strip()}")
    assert not bad, "\n".join(bad)


def test_the_quick_start_commands_run(seespot_bin: Path) -> None:
    quick = _section("Quick start")
    commands = [c.strip() for c in _blocks("sh", quick)]
    assert commands == ["cargo run --release -p seespot -- view", "scripts/test"], commands
    # `scripts/test` is what runs this test; it must be there to run.
    assert (ROOT / "scripts" / "test").stat().st_mode & 0o111
    # `view`, cheaply: the page alone on a free port; it serves the page.
    server = subprocess.Popen(
        [str(seespot_bin), "view", "--port", "0", "--no-viewer"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        assert server.stdout is not None
        url = None
        for line in server.stdout:
            m = re.match(r"seespot page:\s+(\S+)", line)
            if m:
                url = m.group(1)
                break
        assert url, "view printed no page URL"
        with urllib.request.urlopen(url, timeout=60) as page:
            assert page.status == 200
            assert b"Next phase" in page.read()
    finally:
        server.send_signal(signal.SIGINT)
        server.wait(timeout=60)
