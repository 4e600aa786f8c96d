"""Bad input found by the review: each case raises a clear ValueError/TypeError/OSError naming the
parameter (never a crash, a huge allocation or a partial file)."""

from __future__ import annotations

import io
import json
import os
import stat
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import cumuli as cu
from cumuli import _core
from cumuli import renderer as renderer_mod
from cumuli.cloud import MAX_PRIMITIVES


def small_cloud() -> cu.Cloud:
    return cu.Cloud(np.array([[0.0, 0.0, 0.0], [1.5, 0.0, 0.0]]), np.array([1.0, 1.2]))


def _npz_member(zf: zipfile.ZipFile, name: str, array: np.ndarray) -> None:
    buf = io.BytesIO()
    np.save(buf, array)
    zf.writestr(name + ".npy", buf.getvalue())


def _meta(cloud: cu.Cloud) -> np.ndarray:
    return np.frombuffer(json.dumps(cloud._meta()).encode(), np.uint8)


# --- L-system: max_length is capped before the core reserves memory -------------------------
def test_lsystem_max_length_is_capped_before_allocating() -> None:
    # 2**45 symbols: without the cap the core would reserve ~32 TB (MemoryError or the OOM killer).
    with pytest.raises(ValueError, match="max_length"):
        cu.lsystem_expand("X", {"X": "XX"}, 45, max_length=2**62)
    with pytest.raises(ValueError, match="max_length"):
        cu.lsystem_cloud(iterations=3, max_length=2**40)
    with pytest.raises(ValueError, match="max_length"):
        _core.lsystem_expand("X", {"X": "XX"}, 45, 2**64 - 1)
    # The cap itself is fine and below it everything works as before.
    cap = int(_core.LSYSTEM_MAX_LENGTH)
    assert cu.lsystem_expand("X", {"X": "XX"}, 3, max_length=cap) == "X" * 8

