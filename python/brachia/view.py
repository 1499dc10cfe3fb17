"""``brachia.view``: the run page (docs/viewer.md) of a run folder, a ``Plan``, a ``TrackResult`` or a
``TraverseResult``."""

from __future__ import annotations

import os
import tempfile
import webbrowser
from pathlib import Path

from ._brachia import BrachiaError, view_folder


def view(obj, path: str | os.PathLike | None = None, open: bool = False) -> Path:
    """Write the interactive page of ``obj`` and return its path.

    ``obj`` is a run folder (a path: the page is written into it as ``view.html``, as ``brachia view``
    does), a ``Plan``, a scenario's ``TrackResult`` or a ``TraverseResult`` (the page is written to ``path``, or to
    ``view.html`` in a new temporary folder). ``open=True`` also opens it in the default browser.
    In Jupyter a ``Plan`` or ``TrackResult`` shows the same page inline by itself.
    """
    if isinstance(obj, (str, os.PathLike)):
        if path is not None:
            raise BrachiaError("view: path is only for a Plan, TrackResult or TraverseResult; a folder's page is DIR/view.html")
        page = Path(view_folder(os.fspath(obj)))
    else:
        make = getattr(obj, "_view_html", None)
        html = make() if make is not None else None
        if html is None:
            raise BrachiaError(
                f"view: {type(obj).__name__} has no page (a run folder, a Plan with a trajectory, or "
                "a TrackResult of Scenario.track() that tracked, or a TraverseResult with rows)"
            )
        page = Path(path) if path is not None else Path(tempfile.mkdtemp(prefix="brachia-view-")) / "view.html"
        page.write_text(html, encoding="utf-8")
    if open:
        webbrowser.open(page.resolve().as_uri())
    return page
