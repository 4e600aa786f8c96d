"""`make system` installs what a bare Debian needs for `make test` (run against fake dpkg/apt)."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="needs make")

#: What a bare Debian bookworm lacks for `make test`: venv/ensurepip, Python.h for the extension,
#: a compiler, GLM, and the EGL/libGL/Mesa libraries that glcontext dlopens.
NEEDED = {
    "g++",
    "make",
    "python3",
    "python3-venv",
    "python3-dev",
    "libglm-dev",
    "libegl1",
    "libegl-mesa0",
    "libgl1",
    "libgl1-mesa-dri",
}


def _fake_tools(bin_dir: Path, installed: set[str], log: Path) -> None:
    """dpkg-query answering from ``installed``; apt-get and sudo that only record their calls."""
    bin_dir.mkdir()
    known = " ".join(sorted(installed))
    scripts = {
        # `dpkg-query -W -f=FMT NAME`: the status of NAME, or an error for an unknown package.
        "dpkg-query": f"""#!/bin/sh
for name in "$@"; do :; done
for p in {known}; do
  if [ "$p" = "$name" ]; then printf 'install ok installed'; exit 0; fi
done
echo "dpkg-query: no packages found matching $name" >&2
exit 1
""",
        "apt-get": f"""#!/bin/sh
echo "DEBIAN_FRONTEND=${{DEBIAN_FRONTEND:-unset}} apt-get $*" >> {log}
""",
        # Like the real one, it starts the command with a reset environment.
        "sudo": f"""#!/bin/sh
echo "sudo $*" >> {log}
exec env -i PATH="$PATH" "$@"
""",
        # Not root, so the Makefile goes through sudo.
        "id": """#!/bin/sh
echo 1000
""",
    }
    for name, text in scripts.items():
        path = bin_dir / name
        path.write_text(text)
        path.chmod(0o755)


def _system_packages() -> set[str]:
    """The Makefile's SYSTEM_PACKAGES, as make expands it."""
    res = subprocess.run(
        ["make", "-s", "-C", str(ROOT), "--no-print-directory",
         "--eval=print-packages: ; @echo $(SYSTEM_PACKAGES)", "print-packages"],
        capture_output=True, text=True, timeout=60, check=True,
    )  # fmt: skip
    return set(res.stdout.split())


def test_system_packages_cover_a_bare_debian() -> None:
    assert NEEDED <= _system_packages()


def _make_system(tmp_path: Path, installed: set[str]) -> tuple[subprocess.CompletedProcess, str]:
    log = tmp_path / "calls.log"
    log.touch()
    _fake_tools(tmp_path / "bin", installed, log)
    env = dict(os.environ)
    env["PATH"] = f"{tmp_path / 'bin'}{os.pathsep}{env['PATH']}"
    env.pop("DEBIAN_FRONTEND", None)
    res = subprocess.run(
        ["make", "-s", "-C", str(ROOT), "system"],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    return res, log.read_text()


def _apt_installs(calls: str) -> list[str]:
    """The `apt-get install` calls the fake apt-get recorded (with the environment it saw)."""
    return [c for c in calls.splitlines() if c.startswith("DEBIAN_FRONTEND=") and " install " in c]


def test_make_system_installs_every_missing_package_non_interactively(tmp_path: Path) -> None:
    res, calls = _make_system(tmp_path, installed=set())
    assert res.returncode == 0, res.stderr + res.stdout
    install = _apt_installs(calls)
    assert len(install) == 1, calls
    # The front-end setting reaches apt-get even through sudo (which resets the environment).
    assert install[0].startswith("DEBIAN_FRONTEND=noninteractive "), install[0]
    assert "sudo env DEBIAN_FRONTEND=noninteractive apt-get install" in calls
    assert NEEDED <= set(install[0].split()), install[0]
    assert "apt-get update" in calls


def test_make_system_installs_only_what_is_missing(tmp_path: Path) -> None:
    res, calls = _make_system(tmp_path, installed=NEEDED - {"python3-venv", "python3-dev"})
    assert res.returncode == 0, res.stderr + res.stdout
    install = _apt_installs(calls)
    assert len(install) == 1, calls
    names = set(install[0].split()) & NEEDED
    assert names == {"python3-venv", "python3-dev"}


def test_make_system_does_nothing_when_everything_is_installed(tmp_path: Path) -> None:
    res, calls = _make_system(tmp_path, installed=_system_packages())
    assert res.returncode == 0, res.stderr + res.stdout
    assert "apt-get" not in calls
