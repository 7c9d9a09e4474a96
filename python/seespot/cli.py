"""The ``seespot`` command, installed with the Python package.

``pip install .`` puts ``seespot`` on the PATH: the same command line as the
cargo-built binary (``view``, ``eval``, ``record``, ``review``, ``train``, ...),
compiled into the wheel's Rust core and run in this process, so a Python user
never calls cargo. Run it from a folder holding ``models/`` and ``demos/`` (the
repository root), as the binary is run.

``seespot export`` runs :mod:`seespot.export` with this interpreter.
"""

from __future__ import annotations

import os
import signal
import sys

from seespot import _core


def main(argv: list[str] | None = None) -> int:
    """Runs ``seespot ARGS`` and returns its exit status (the console script
    exits with it)."""
    args = list(sys.argv if argv is None else ["seespot", *argv])
    # The command line handles Ctrl-C and SIGTERM itself where it needs to (a
    # live view finishing its recording); elsewhere Ctrl-C ends the process,
    # as it ends the binary, instead of waiting for Python's handler.
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    # `seespot export` runs `python -m seespot.export` with this interpreter.
    os.environ.setdefault("SEESPOT_PYTHON", sys.executable)
    return _core.cli(args)


if __name__ == "__main__":
    sys.exit(main())
