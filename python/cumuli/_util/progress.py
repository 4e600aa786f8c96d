"""Progress bars (tqdm) for every step that can take more than a few seconds
(docs/conventions.md, "Progress").

A bar appears only once its step has run for :data:`DELAY` seconds, so quick calls print nothing.
Each long step takes ``progress=``: ``None`` (the default) shows bars unless the environment
says ``CUMULI_PROGRESS=0``; ``True`` / ``False`` force them on / off. Python loops (volumes,
drawables, tiles, frames) drive :func:`bar`; a single long C++ call (a light grid, the CPU
marcher) drives :func:`core`, which the core's parallel loops move between their chunks.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any

from tqdm.auto import tqdm

from cumuli._util import validate as check

#: Seconds a step runs before its bar is shown.
DELAY = 2.0

_local = threading.local()


def enabled(progress: Any) -> bool:
    """Whether bars are shown for ``progress`` (None: unless ``CUMULI_PROGRESS=0``)."""
    if progress is None:
        return os.environ.get("CUMULI_PROGRESS", "1").strip() not in ("0", "false", "no", "off")
    return check.flag(progress, "progress")


def bar(
    iterable: Iterable[Any] | None = None,
    *,
    desc: str,
    total: int | None = None,
    unit: str = "it",
    progress: Any = None,
) -> Any:
    """A tqdm bar over ``iterable`` (shown after :data:`DELAY` s unless ``progress`` says no)."""
    return tqdm(
        iterable, desc=desc, total=total, unit=unit, delay=DELAY, disable=not enabled(progress),
        leave=False, dynamic_ncols=True,
    )  # fmt: skip


@contextmanager
def core(desc: str, progress: Any = None) -> Iterator[None]:
    """A bar moved by the C++ loops run inside the ``with`` body (by chunks, per loop)."""
    from cumuli import _core

    if not enabled(progress) or getattr(_local, "core", False):
        yield
        return
    started = time.monotonic()
    shown: Any = None  # the bar, made on the loops' first report

    def update(done: int, total: int) -> None:
        nonlocal shown
        if shown is None:  # the loops report from 50 ms on: a quick call never builds a bar
            shown = tqdm(
                total=total, desc=desc, delay=max(0.0, DELAY - (time.monotonic() - started)),
                leave=False, dynamic_ncols=True,
                bar_format="{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}]",
            )  # fmt: skip
        if shown.total != total or done < shown.n:  # a new loop (not tqdm.reset: it would
            shown.total = total  # show the bar before its delay)
            shown.n = shown.last_print_n = 0
        shown.update(done - shown.n)

    previous = _core.set_progress(update)
    _local.core = True
    try:
        yield
    finally:
        _local.core = False
        _core.set_progress(previous)
        if shown is not None:
            shown.close()
