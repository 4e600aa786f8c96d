"""The budget: how much memory and work one input may make cumuli spend, checked before it does.

Every entry point — a call, a scene file, a weather file, the command line — estimates the
memory (bytes) and the work (samples: points at which a density, an fBm or a light is
evaluated) that an input implies *before* allocating or computing, and refuses an input over the
budget with a ``ValueError`` that names the input, its estimated cost, the budget and the setting
that raises it. Loading a scene file costs at most ``scene_expansion`` times its size in bytes,
or ``scene_allowance`` if that is larger, and never more than ``memory``.

The budget is process-wide: `set_limits` changes it, `get_limits` reads it, `limits` changes it
for a ``with`` block. The environment variables ``CUMULI_MEMORY_BUDGET``, ``CUMULI_WORK_BUDGET``
and ``CUMULI_SCENE_ALLOWANCE`` set the starting values (``"8G"``, ``"512M"`` or a plain number
of bytes or samples), so that the command line and worker processes can be given more.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import os
import re
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

#: Default memory budget of one input, in bytes (4 GiB).
DEFAULT_MEMORY = 1 << 32
#: Default work budget of one input, in samples (2²⁸: about a minute of light or density
#: evaluation on two cores).
DEFAULT_WORK = 1 << 28
#: Default multiple of a scene file's size that loading it may cost in memory.
DEFAULT_SCENE_EXPANSION = 64
#: Default memory a scene file may cost whatever its size (256 MiB), within `memory`.
DEFAULT_SCENE_ALLOWANCE = 1 << 28

#: The environment variables that set the starting budget.
ENV_MEMORY = "CUMULI_MEMORY_BUDGET"
ENV_WORK = "CUMULI_WORK_BUDGET"
ENV_SCENE_ALLOWANCE = "CUMULI_SCENE_ALLOWANCE"

_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
#: Largest value any limit may be set to (2⁶²: beyond any machine, and still an int64).
MAX_LIMIT = 1 << 62


class BudgetError(ValueError):
    """An input refused because its estimated memory or work is over the budget (a ValueError:
    the message names the input, its cost, the budget and the setting that raises it)."""


@dataclass(frozen=True)
class Limits:
    """The budget. ``memory``: bytes one input may allocate; ``work``: samples one input may
    evaluate; ``scene_expansion`` and ``scene_allowance``: a scene file may cost
    ``max(scene_expansion × its bytes, scene_allowance)`` bytes, at most ``memory``."""

    memory: int = DEFAULT_MEMORY
    work: int = DEFAULT_WORK
    scene_expansion: int = DEFAULT_SCENE_EXPANSION
    scene_allowance: int = DEFAULT_SCENE_ALLOWANCE

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int):
                raise TypeError(f"limits.{f.name} must be an int, got {type(value).__name__}")
            if not 1 <= value <= MAX_LIMIT:
                raise ValueError(f"limits.{f.name} must be in [1, 2**62], got {value}")

    def scene_bytes(self, file_bytes: int) -> int:
        """The memory loading a scene file of ``file_bytes`` bytes may cost."""
        return min(self.memory, max(self.scene_expansion * file_bytes, self.scene_allowance))


def parse_amount(text: str, name: str) -> int:
    """``"8G"``, ``"512M"``, ``"64K"``, ``"1T"`` (powers of 1024) or a plain integer."""
    match = re.fullmatch(r"\s*([0-9]{1,19})\s*([KMGT]?)i?B?\s*", str(text), re.I)
    if match is None:
        raise ValueError(f"{name} must be a number with an optional K/M/G/T suffix, got {text!r}")
    value = int(match.group(1)) * _UNITS[match.group(2).upper()]
    if not 1 <= value <= MAX_LIMIT:
        raise ValueError(f"{name} must be between 1 and 2**62, got {text!r}")
    return value


def _from_environment() -> Limits:
    kw: dict[str, int] = {}
    for env, key in (
        (ENV_MEMORY, "memory"), (ENV_WORK, "work"), (ENV_SCENE_ALLOWANCE, "scene_allowance"),
    ):  # fmt: skip
        text = os.environ.get(env)
        if text:
            kw[key] = parse_amount(text, env)
    return Limits(**kw)


_lock = threading.Lock()
_current: Limits | None = None
#: A budget in force for the current thread or task only (`within`), over the process's.
_local: contextvars.ContextVar[Limits | None] = contextvars.ContextVar(
    "cumuli_limits", default=None
)


def get_limits() -> Limits:
    """The budget in force (the environment's on first use, else the defaults)."""
    global _current
    local = _local.get()
    if local is not None:
        return local
    with _lock:
        if _current is None:
            _current = _from_environment()
        return _current


def set_limits(
    limits: Limits | None = None,
    *,
    memory: int | str | None = None,
    work: int | str | None = None,
    scene_expansion: int | None = None,
    scene_allowance: int | str | None = None,
) -> Limits:
    """Change the budget (the fields given; ``limits`` replaces it whole) and return the previous
    one. Amounts may be strings such as ``"8G"``. ``set_limits(Limits())`` restores the
    defaults."""
    global _current
    previous = get_limits()
    if limits is not None and not isinstance(limits, Limits):
        raise TypeError(f"limits must be a cumuli.Limits, got {type(limits).__name__}")
    base = previous if limits is None else limits
    changes: dict[str, Any] = {}
    for key, value in (
        ("memory", memory), ("work", work), ("scene_expansion", scene_expansion),
        ("scene_allowance", scene_allowance),
    ):  # fmt: skip
        if value is not None:
            changes[key] = parse_amount(value, key) if isinstance(value, str) else value
    new = dataclasses.replace(base, **changes)
    with _lock:
        _current = new
    return previous


@contextlib.contextmanager
def limits(**changes: Any) -> Iterator[Limits]:
    """``with cu.limits(memory="16G"): ...`` — the budget changed for the block only."""
    previous = set_limits(**changes)
    try:
        yield get_limits()
    finally:
        set_limits(previous)


@contextlib.contextmanager
def within(limits: Limits) -> Iterator[Limits]:
    """``limits`` for the current thread (or asyncio task) only, the process's untouched: a
    cluster worker runs each task under the budget of the process that submitted it."""
    if not isinstance(limits, Limits):
        raise TypeError(f"limits must be a cumuli.Limits, got {type(limits).__name__}")
    token = _local.set(limits)
    try:
        yield limits
    finally:
        _local.reset(token)


def amount(n: float) -> str:
    """``n`` bytes as a short text (``"1.0 GiB"``)."""
    for unit, size in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size:
            return f"{n / size:.1f} {unit}"
    return f"{int(n)} B"


def check_memory(what: str, cost: float, budget: int | None = None, setting: str = "") -> None:
    """Refuse ``what`` when its estimated ``cost`` in bytes is over ``budget`` (default: the
    memory budget)."""
    limit = get_limits().memory if budget is None else budget
    if cost > limit:
        how = setting or f"cumuli.set_limits(memory=...) or the {ENV_MEMORY} environment variable"
        raise BudgetError(
            f"{what} would need about {amount(cost)} of memory, more than the budget of "
            f"{amount(limit)}; raise it with {how}"
        )


def check_work(what: str, samples: float) -> None:
    """Refuse ``what`` when its estimated work in samples is over the work budget."""
    limit = get_limits().work
    if samples > limit:
        raise BudgetError(
            f"{what} would evaluate about {samples:.3g} samples, more than the budget of "
            f"{limit:.3g}; raise it with cumuli.set_limits(work=...) or the {ENV_WORK} "
            "environment variable"
        )
