"""The light step's memo: light objects by what they depend on (least recently used dropped
first), so rendering the same scene again does not repeat its light passes."""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

import numpy as np

#: Light objects kept by the memo (least recently used dropped first).
MEMO_SIZE = 64
#: The memo (key → value) and the lock that guards it.
store: OrderedDict[Any, Any] = OrderedDict()
lock = threading.Lock()
#: What the physical light of a medium keeps apart from its sun and sky (its extinction lattice,
#: its sky visibility), in a store of its own so that it does not crowd the lights out of
#: ``store``; entries kept (two per drawable).
MEDIA_MEMO_SIZE = 32
media_store: OrderedDict[Any, Any] = OrderedDict()
#: Small geometric facts about drawables (a drawable's extent along the sun's axes), many per
#: scene, in a store of their own; entries kept.
GEOMETRY_MEMO_SIZE = 4096
geometry_store: OrderedDict[Any, Any] = OrderedDict()
#: The values being made now, by key (in any store): what the other threads wait for.
pending: dict[Any, Future] = {}


def remember(key: Any, make: Callable[[], Any], media: bool = False, geometry: bool = False) -> Any:
    """The value memoised under ``key``, made by ``make()`` when there is none (in
    :data:`media_store` with ``media``, :data:`geometry_store` with ``geometry``).

    Safe from several threads: a value being made by one thread is waited for by the others
    that ask for it (the light step lights clouds side by side, and each reads the sun lattices
    of the clouds upstream of it), not made twice. A ``make`` that raises leaves nothing behind:
    the next caller tries again."""
    if geometry:
        where, size = geometry_store, GEOMETRY_MEMO_SIZE
    else:
        where, size = (media_store, MEDIA_MEMO_SIZE) if media else (store, MEMO_SIZE)
    with lock:
        if key in where:
            where.move_to_end(key)
            return where[key]
        making = pending.get(key)
        if making is None:
            making = pending[key] = Future()
            mine = True
        else:
            mine = False
    if not mine:
        return making.result()
    try:
        value = make()
    except BaseException as exc:
        with lock:
            del pending[key]
        making.set_exception(exc)
        raise
    with lock:
        where[key] = value
        while len(where) > size:
            where.popitem(last=False)
        del pending[key]
    making.set_result(value)
    return value


def known(key: Any) -> bool:
    """Whether :data:`store` holds ``key`` now (made, not being made); it does not count as a
    use."""
    with lock:
        return key in store


def clear() -> None:
    """Forget every memoised value."""
    with lock:
        store.clear()
        media_store.clear()
        geometry_store.clear()


def content_digest(*arrays: np.ndarray) -> str:
    """A short hash of arrays (their shapes and bytes), for memo keys."""
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        h.update(str(a.shape).encode())
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()
