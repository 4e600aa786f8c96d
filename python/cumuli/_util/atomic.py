"""Atomic file writes shared by every saver (DESIGN §3: a failed write leaves no partial file).

The file is written to a temporary beside the destination and renamed over it once complete:

- the temporary is named ``.<name>.tmp-XXXXXXXX``: hidden, and ending in random characters, so
  no glob of the real extension (``*.exr``) finds it; the name is shortened where needed to stay
  within the folder's ``NAME_MAX`` (a legal 255-byte destination name still works);
- before the rename the data is flushed to the disk (``fsync``): a full disk or an I/O error
  raises ``OSError`` and the old file stays; savers that can check what was written (images are
  read back) do so first;
- the destination keeps its permission bits (and, for root, its owner); a symlink is written
  through (its target is replaced, the link stays);
- on ``SIGTERM`` or ``SIGHUP`` during a write in the main thread the temporary is removed and the
  signal then does what it did before (a Python handler runs; the default still kills the
  process with that signal); ``KeyboardInterrupt`` and exceptions remove it too.
"""

from __future__ import annotations

import os
import signal
import stat
import tempfile
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

#: NAME_MAX where the folder does not say (Linux, macOS, Windows all use 255).
DEFAULT_NAME_MAX = 255
#: Random characters ``tempfile.mkstemp`` appends to the prefix.
_RANDOM = 8
#: Signals that end a process by default and that a user sends to stop one.
_SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n))

_live: set[Path] = set()
_lock = threading.Lock()
_saved: dict[int, Any] = {}


def _temp_prefix(name: str, name_max: int) -> str:
    """``.<name>.tmp-``, ``name`` cut (on a character boundary) so that the prefix plus the
    random part fits in ``name_max`` bytes."""
    room = name_max - _RANDOM - len(b"..tmp-")
    encoded = name.encode("utf-8", "surrogateescape")
    if len(encoded) > room:
        name = encoded[:room].decode("utf-8", "ignore")
    return f".{name}.tmp-"


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return DEFAULT_NAME_MAX


def _on_signal(signum: int, frame: Any) -> None:
    """Let the signal do what it did before, removing the live temporaries first where that
    kills the process (a Python handler that raises unwinds through the writer, which removes
    its temporary itself)."""
    previous = _saved.get(signum, signal.SIG_DFL)
    if callable(previous):
        previous(signum, frame)
        return
    if previous == signal.SIG_IGN:
        return
    with _lock:
        for tmp in list(_live):
            try:
                os.unlink(tmp)
            except OSError:
                pass
        _live.clear()
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)


def _guard() -> bool:
    """Install the signal handlers (main thread only; nested writes share them)."""
    if threading.current_thread() is not threading.main_thread():
        return False
    with _lock:
        if not _saved:
            for sig in _SIGNALS:
                try:
                    if signal.getsignal(sig) is None:  # a handler set from C: left alone
                        continue
                    _saved[sig] = signal.signal(sig, _on_signal)
                except (ValueError, OSError):  # not the main interpreter, or not settable
                    pass
    return True


def _unguard() -> None:
    with _lock:
        if _live:
            return
        for sig, previous in _saved.items():
            try:
                signal.signal(sig, previous)
            except (ValueError, OSError):
                pass
        _saved.clear()


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _commit(tmp: Path, target: Path, verify: Callable[[Path], None] | None) -> None:
    """Check and flush ``tmp``, give it the destination's mode, rename it over ``target``."""
    if verify is not None:
        verify(tmp)
    _fsync(tmp)  # a full disk or an I/O error surfaces here, before the old file is replaced
    try:
        old = target.stat()
    except FileNotFoundError:
        old = None
    if old is not None:
        os.chmod(tmp, stat.S_IMODE(old.st_mode))
        if hasattr(os, "chown") and os.geteuid() == 0:
            try:
                os.chown(tmp, old.st_uid, old.st_gid)
            except OSError:
                pass
    else:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
    os.replace(tmp, target)
    try:  # the rename itself reaches the disk with the folder
        fd = os.open(target.parent, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def resolve_target(path: Path) -> Path:
    """The file a write to ``path`` replaces: a symlink's final target, else ``path``."""
    if path.is_symlink():
        return Path(os.path.realpath(path))
    return path


@contextmanager
def atomic_target(path: Path, verify: Callable[[Path], None] | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path`` (see the module
    docstring). The caller writes the whole file to the yielded path; ``verify(tmp)`` may check
    it (raising ``OSError``) before the rename. When the ``with`` body, the check or the rename
    fails, the temporary is removed and ``path`` is left as it was.
    """
    target = resolve_target(Path(path))
    folder = target.parent
    fd, name = tempfile.mkstemp(prefix=_temp_prefix(target.name, _name_max(folder)), dir=folder)
    os.close(fd)
    tmp = Path(name)
    guarded = _guard()
    with _lock:
        _live.add(tmp)
    try:
        yield tmp
        _commit(tmp, target, verify)
    except BaseException:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass
        raise
    finally:
        with _lock:
            _live.discard(tmp)
        if guarded:
            _unguard()
