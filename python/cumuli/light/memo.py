"""The light step's memo: light objects by what they depend on (least recently used dropped
first), so rendering the same scene again does not repeat its light passes."""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import Any

import numpy as np

#: Light objects kept by the memo (least recently used dropped first).
MEMO_SIZE = 64
#: The memo (key → value) and the lock that guards it.
store: OrderedDict[Any, Any] = OrderedDict()
lock = threading.Lock()


def remember(key: Any, make: Callable[[], Any]) -> Any:
    """The value memoised under ``key``, made by ``make()`` when there is none."""
    with lock:
        if key in store:
            store.move_to_end(key)
            return store[key]
    value = make()
    with lock:
        store[key] = value
        while len(store) > MEMO_SIZE:
            store.popitem(last=False)
    return value


def content_digest(*arrays: np.ndarray) -> str:
    """A short hash of arrays (their shapes and bytes), for memo keys."""
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        h.update(str(a.shape).encode())
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()
