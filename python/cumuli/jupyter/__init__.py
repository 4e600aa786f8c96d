"""Jupyter: images that display themselves (`Image`, `show`) and the interactive `Viewer`.

Nothing here is needed to render; the widget's packages (anywidget) are imported only when a
`Viewer` is made, so `import cumuli` works without them."""

from __future__ import annotations

from cumuli.jupyter.display import Image, show

__all__ = ["Image", "show"]
