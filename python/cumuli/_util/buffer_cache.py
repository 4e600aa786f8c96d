"""The light step's buffer cache: idle blocks of memory kept for the next light step.

The light step makes the same arrays (a cloud's lattices, the diffusion's sources, solves and
results: hundreds of kilobytes to megabytes each) afresh for every cloud and every frame. Memory
fresh from the system costs a page fault per 4 KiB page on first touch, a tenth of a default
cumulus's light step. The core therefore keeps the blocks of 64 KiB or more that it frees (the
arrays it hands to numpy included, once numpy lets go of them) in one process-wide cache, up to
a limit, and reuses a block of the same size before asking the system. The limit is 256 MiB
(about what a sixteen-cloud scene's light step frees) unless ``CUMULI_BUFFER_CACHE`` or
`set_buffer_cache_limit` says otherwise. The cache changes no result: every array the core makes
is filled before it is read.
"""

from __future__ import annotations

import os
import warnings
from typing import TypedDict

from cumuli import _core
from cumuli._util.budget import parse_amount

#: The environment variable that sets the cache's starting limit (``"256M"``, ``"0"``: none).
ENV_BUFFER_CACHE = "CUMULI_BUFFER_CACHE"


class BufferCacheStats(TypedDict):
    """What the cache holds (``idle_blocks``, ``idle_bytes``), its ``limit_bytes``, and since
    the process started the blocks it handed out again (``hits``) and those made afresh
    (``misses``)."""

    idle_blocks: int
    idle_bytes: int
    limit_bytes: int
    hits: int
    misses: int


def buffer_cache_stats() -> BufferCacheStats:
    """The buffer cache's state and counts (:class:`BufferCacheStats`)."""
    return BufferCacheStats(**_core.buffer_cache_stats())


def set_buffer_cache_limit(limit: int | str) -> int:
    """Sets the most bytes the cache keeps idle (an int, or ``"256M"``-style text; 0: keep
    nothing), giving back at once what is over it. Returns the previous limit in bytes."""
    if isinstance(limit, str):
        nbytes = 0 if limit.strip() == "0" else parse_amount(limit, "buffer cache limit")
    elif isinstance(limit, int) and not isinstance(limit, bool):
        nbytes = limit
    else:
        raise TypeError(f"buffer cache limit must be an int or a str, got {type(limit).__name__}")
    if not 0 <= nbytes < 1 << 62:
        raise ValueError(f"buffer cache limit must be between 0 and 2**62 bytes, got {limit!r}")
    return int(_core.set_buffer_cache_limit(nbytes))


def release_buffer_cache() -> int:
    """Gives every idle block back to the system (the cache stays on); returns the bytes."""
    return int(_core.release_buffer_cache())


def _from_environment() -> None:
    text = os.environ.get(ENV_BUFFER_CACHE)
    if not text:
        return
    try:
        set_buffer_cache_limit(text)
    except ValueError as err:  # a bad setting must not stop `import cumuli`
        warnings.warn(f"{ENV_BUFFER_CACHE} ignored: {err}", RuntimeWarning, stacklevel=2)


_from_environment()
