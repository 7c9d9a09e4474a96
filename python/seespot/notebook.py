"""seespot's views inline in a Jupyter notebook.

- :func:`debugger`: the debugger page of a running ``seespot view`` session
  (an iframe of its URL; the session's server does the work).
- :func:`meshcat`: a trial's meshcat animation (:mod:`seespot.viz.meshcat`)
  as an iframe holding the standalone page itself (``srcdoc``): no server, no
  network, and it stays in the saved notebook.
- :func:`rerun`: a rerun recording (``seespot record``'s ``.rrd``) in rerun's
  notebook viewer, the ``rerun-sdk[notebook]`` extra, pinned to the rerun
  version seespot writes (0.36). By default ``rerun-notebook`` loads its
  viewer (JavaScript and Wasm) from rerun's web site; here its assets are
  served by the kernel from the installed package on localhost
  (``RERUN_NOTEBOOK_ASSET=serve-local``), so it works offline. Set
  ``RERUN_NOTEBOOK_ASSET=inline`` before the first call to send them through
  the notebook instead (for a kernel on another machine; about 30 MB per
  output).

See ``python/examples/notebook.ipynb``.
"""

from __future__ import annotations

import html
import os
import urllib.parse
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from seespot.viz.meshcat import TrialFrames

#: The rerun version of the recordings ``seespot record`` writes.
RERUN_VERSION = "0.36"


def _ipython_display() -> Any:
    try:
        import IPython.display
    except ImportError as e:
        raise ImportError("seespot.notebook needs IPython (a Jupyter kernel): pip install ipykernel") from e
    return IPython.display


def debugger(url: str = "http://127.0.0.1:8765/", height: int = 760) -> Any:
    """The debugger page of a running ``seespot view`` session (the page URL
    it printed) in an iframe ``height`` pixels tall."""
    parsed = urllib.parse.urlparse(url)
    if parsed.scheme not in ("http", "https") or not parsed.hostname:
        raise ValueError(f"url: expected the page URL `seespot view` printed (http://HOST:PORT/), got {url!r}")
    return _ipython_display().IFrame(url, width="100%", height=height)


def meshcat(trial: TrialFrames | str | Path, height: int = 520) -> Any:
    """A trial's meshcat animation in an iframe ``height`` pixels tall: a
    :class:`seespot.viz.meshcat.TrialFrames` (from ``record_trial``) or the
    path of a standalone HTML file ``save_html`` wrote. The page goes into
    the iframe's ``srcdoc``, so nothing is served or fetched."""
    if isinstance(trial, (str, Path)):
        page = Path(trial).read_text(encoding="utf-8")
    else:
        from seespot.viz.meshcat import standalone_html

        page = standalone_html(trial)
    frame = (
        f'<iframe srcdoc="{html.escape(page, quote=True)}" '
        f'style="width: 100%; height: {int(height)}px; border: none" '
        'title="seespot meshcat animation"></iframe>'
    )
    return _ipython_display().HTML(frame)


def rerun(path: str | Path, height: int = 640) -> Any:
    """The rerun recording ``path`` (an ``.rrd`` from ``seespot record``) in
    rerun's notebook viewer, ``height`` pixels tall, its assets served on
    localhost by the kernel (module docs). Returns the widget: leave it last
    in the cell, or ``display`` it."""
    data = Path(path).read_bytes()
    os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")
    try:
        import rerun_notebook  # type: ignore[import-untyped]
    except ImportError as e:
        raise ImportError(
            f"showing a recording needs rerun's notebook viewer: pip install 'rerun-sdk[notebook]=={RERUN_VERSION}.3'"
        ) from e
    if rerun_notebook.ASSET_IS_URL:
        raise RuntimeError(
            f"rerun_notebook was imported before seespot.notebook.rerun and loads its viewer from "
            f"{rerun_notebook.ESM_MOD} (the network); restart the kernel, or set "
            "RERUN_NOTEBOOK_ASSET=serve-local before importing rerun"
        )
    version = getattr(rerun_notebook, "__version__", "unknown")
    if not version.startswith(RERUN_VERSION + "."):
        warnings.warn(
            f"rerun-notebook {version} may not read seespot's recordings (rerun {RERUN_VERSION}): "
            f"pip install 'rerun-sdk[notebook]=={RERUN_VERSION}.3'",
            stacklevel=2,
        )
    viewer = rerun_notebook.Viewer(width="auto", height=height)
    # Queued until the viewer in the page says it is ready.
    viewer.send_rrd(data)
    return viewer
