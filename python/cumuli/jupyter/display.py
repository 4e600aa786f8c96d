"""`Image`: a linear render with its display settings, shown by notebooks as PNG; `show`."""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from typing import Any

import numpy as np

from cumuli.io.images import (
    DISPLAY_EXPOSURE,
    DISPLAY_TONEMAP,
    TONEMAPS,
    display_for,
    to_srgb8,
)
from cumuli.io.png import png_bytes
from cumuli.light.prepare import LitScene
from cumuli.rendering.compositor import render
from cumuli.scene import Scene

#: The size `show` renders a scene at when none is given (width, height).
DEFAULT_SIZE = (640, 360)


class Image:
    """A linear ``(H, W, 3|4)`` float image with the settings that turn it into display bytes.

    Notebooks show it inline (``_repr_png_``, ``_repr_html_`` with a caption); ``np.asarray``
    gives the linear pixels back unchanged. The RGB of a render already holds the sky, so the
    display is opaque (alpha, ``1 − T``, is kept in `pixels` but not shown).
    """

    def __init__(
        self,
        pixels: Any,
        exposure: float = DISPLAY_EXPOSURE,
        tonemap: str = DISPLAY_TONEMAP,
        title: str = "",
    ) -> None:
        arr = np.asarray(pixels)
        # to_srgb8 checks the array (float, (H, W, 3|4), finite) and the settings.
        self._srgb = to_srgb8(arr, exposure, tonemap)[..., :3]
        if not isinstance(title, str):
            raise TypeError(f"title must be a str, got {type(title).__name__}")
        self.pixels: np.ndarray = arr
        self.exposure = float(exposure)
        self.tonemap: str = tonemap
        self.title = title

    @property
    def shape(self) -> tuple[int, ...]:
        """The linear pixels' shape ``(H, W, C)``."""
        return tuple(self.pixels.shape)

    def srgb8(self) -> np.ndarray:
        """The displayed bytes: ``(H, W, 3)`` uint8 sRGB after exposure and tone map."""
        return self._srgb.copy()

    def png(self) -> bytes:
        """The displayed bytes as a PNG file's contents."""
        return png_bytes(self._srgb)

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        return self.pixels if dtype is None else self.pixels.astype(dtype)

    def _repr_png_(self) -> bytes:
        return self.png()

    def _repr_html_(self) -> str:
        h, w = self.pixels.shape[:2]
        data = base64.b64encode(self.png()).decode("ascii")
        caption = f"{w}×{h}, exposure {self.exposure:g}, tone map {self.tonemap}"
        if self.title:
            caption = f"{html.escape(self.title)} — {caption}"
        return (
            f'<figure style="margin:0"><img src="data:image/png;base64,{data}" '
            f'width="{w}" height="{h}" alt="{html.escape(self.title or "cumuli image")}"/>'
            f'<figcaption style="font-size:small">{caption}</figcaption></figure>'
        )

    def __repr__(self) -> str:
        h, w, c = self.pixels.shape
        name = f" {self.title!r}" if self.title else ""
        return f"<cumuli.Image{name} {w}×{h}×{c}, exposure {self.exposure:g}, {self.tonemap}>"


class Gallery:
    """Several `Image` objects side by side (wrapping), each with its caption."""

    def __init__(self, images: list[Image]) -> None:
        self.images = list(images)

    def _repr_html_(self) -> str:
        cells = "".join(f"<div>{img._repr_html_()}</div>" for img in self.images)
        return f'<div style="display:flex;flex-wrap:wrap;gap:8px">{cells}</div>'

    def __repr__(self) -> str:
        return f"<cumuli gallery of {len(self.images)} images>"


def _size(size: Any) -> tuple[int, int]:
    if size is None:
        return DEFAULT_SIZE
    try:
        w, h = size
    except (TypeError, ValueError):
        raise TypeError(f"size must be (width, height), got {size!r}") from None
    return w, h  # render checks the values


def as_image(
    obj: Any,
    *,
    exposure: float | None = None,
    tonemap: str | None = None,
    size: Any = None,
    title: str | None = None,
    **render_kwargs: Any,
) -> Image:
    """An `Image` of ``obj``: an image array as it is, a `Scene` or `LitScene` rendered at
    ``size`` (``(width, height)``, default 640×360) with ``render_kwargs`` (``camera``,
    ``backend``, …: :func:`cumuli.render`'s). An `Image` keeps its own exposure, tone map and
    title where these are not given; a scene gets its lighting mode's display
    (:func:`cumuli.io.images.display_for`), an array the package's display defaults
    (:data:`~cumuli.io.images.DISPLAY_EXPOSURE`, :data:`~cumuli.io.images.DISPLAY_TONEMAP`)."""
    if tonemap is not None and tonemap not in TONEMAPS:
        raise ValueError(f"tonemap must be one of {TONEMAPS}, got {tonemap!r}")
    if isinstance(obj, Image):
        exposure = obj.exposure if exposure is None else exposure
        tonemap = obj.tonemap if tonemap is None else tonemap
        title = obj.title if title is None else title
        obj = obj.pixels
    if isinstance(obj, (Scene, LitScene)):
        # A scene is shown as its lighting mode is meant to be seen (the paper mode untoned).
        scene = obj.scene if isinstance(obj, LitScene) else obj
        shown = display_for(scene.settings.lighting)
        exposure = shown[0] if exposure is None else exposure
        tonemap = shown[1] if tonemap is None else tonemap
        w, h = _size(size)
        render_kwargs.setdefault("progress", False)
        obj = render(obj, width=w, height=h, **render_kwargs)
    elif render_kwargs or size is not None:
        raise TypeError("size and render arguments apply to a Scene or LitScene, not an image")
    elif not isinstance(obj, np.ndarray):
        raise TypeError(
            "show takes an image array, a cumuli.Image, Scene or LitScene, "
            f"got {type(obj).__name__}"
        )
    return Image(
        obj,
        exposure=DISPLAY_EXPOSURE if exposure is None else exposure,
        tonemap=DISPLAY_TONEMAP if tonemap is None else tonemap,
        title="" if title is None else title,
    )


def _display(obj: Any) -> None:
    try:
        from IPython.display import display  # IPython comes with every Jupyter kernel
    except ImportError:
        raise ImportError('cumuli.show needs IPython: pip install "cumuli[jupyter]"') from None
    display(obj)


def show(
    obj: Any,
    *,
    exposure: float | None = None,
    tonemap: str | None = None,
    size: Any = None,
    title: str | Sequence[str] | None = None,
    **render_kwargs: Any,
) -> None:
    """Show an image, or render a scene and show it, inline in a notebook.

    ``obj``: a linear ``(H, W, 3|4)`` float image (what :func:`cumuli.render` returns), a
    `cumuli.Image`, a `Scene` or a `LitScene`, or a list of them (shown side by side, ``title``
    then one caption each). ``exposure`` and ``tonemap`` are the display
    settings of :func:`cumuli.to_srgb8`; ``size`` ``(width, height)`` and ``render_kwargs``
    (``camera=``, ``backend=``, …) apply to scenes. A `cumuli.Image` keeps its own settings and
    title where these are not given; otherwise a scene is shown in its lighting mode's display
    and an array with the package's display defaults (exposure 0.8, ACES). Returns nothing,
    like ``plt.show``, so that a cell ending with it shows the image once; :class:`cumuli.Image`
    is the object to keep (it shows itself when it is a cell's value).
    """
    if isinstance(obj, (list, tuple)):
        titles = title if isinstance(title, (list, tuple)) else [title] * len(obj)
        if len(titles) != len(obj):
            raise ValueError(f"title: {len(titles)} titles for {len(obj)} images")
        look = {"exposure": exposure, "tonemap": tonemap}
        scene_kw = {"size": size, **render_kwargs}
        images = [
            as_image(o, title=t, **look, **(scene_kw if isinstance(o, (Scene, LitScene)) else {}))
            for o, t in zip(obj, titles, strict=True)
        ]
        _display(Gallery(images))
        return
    img = as_image(obj, exposure=exposure, tonemap=tonemap, size=size, title=title, **render_kwargs)
    _display(img)
