"""What an installed wheel must do, run by test_wheel.py in a fresh virtual environment and by
cibuildwheel's test-command: the README's quick start, then ``cumuli demo``, in an empty folder
away from the source tree.

usage: python wheel_smoke.py README.md
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
from pathlib import Path


def quick_start(readme: Path) -> str:
    """The first ```python block of the README's "Quick start" section."""
    section = readme.read_text(encoding="utf-8").split("## Quick start", 1)[1]
    match = re.search(r"^```python\n(.*?)^```$", section, re.M | re.S)
    if match is None:
        raise SystemExit(f"no quick start in {readme}")
    return match.group(1)


def main(readme: Path) -> None:
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        (work / "quick_start.py").write_text(quick_start(readme), encoding="utf-8")
        subprocess.run([sys.executable, "quick_start.py"], cwd=work, check=True)
        if not (work / "cumulus.png").is_file():
            raise SystemExit("the quick start wrote no cumulus.png")
        subprocess.run(["cumuli", "demo", "--size", "64x48", "--quiet"], cwd=work, check=True)
        if not (work / "out.png").is_file() or not (work / "out.exr").is_file():
            raise SystemExit("cumuli demo wrote no out.png / out.exr")
    import cumuli

    print(
        f"cumuli {cumuli.__version__} from {Path(cumuli.__file__).parent}: quick start and demo ok"
    )


if __name__ == "__main__":
    main(Path(sys.argv[1]))
