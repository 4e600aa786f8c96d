"""Run every ``benchmarks/bench_*.py`` in turn (``--quick`` and ``--out`` are passed through).

Each script runs in a subprocess with a time limit (``--timeout``), so the whole run is bounded.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small sizes and few repeats")
    parser.add_argument("--out", type=Path, default=None, help="output folder for all scripts")
    parser.add_argument(
        "--timeout", type=float, default=3600.0, help="seconds allowed per script (default 3600)"
    )
    parser.add_argument("only", nargs="*", help="run only these bench_*.py names (e.g. noise)")
    args = parser.parse_args(argv)
    scripts = sorted(HERE.glob("bench_*.py"))
    if args.only:
        wanted = {n.removeprefix("bench_").removesuffix(".py") for n in args.only}
        scripts = [s for s in scripts if s.stem.removeprefix("bench_") in wanted]
        if not scripts:
            print(f"run_all: no benchmark matches {args.only}", file=sys.stderr)
            return 2
    failed = []
    for script in scripts:
        cmd = [sys.executable, str(script)]
        if args.quick:
            cmd.append("--quick")
        if args.out is not None:
            cmd += ["--out", str(args.out)]
        print(f"== {script.name}", flush=True)
        start = time.perf_counter()
        try:
            code = subprocess.call(cmd, timeout=args.timeout)
        except subprocess.TimeoutExpired:
            print(f"== {script.name}: killed after {args.timeout:.0f} s", flush=True)
            code = -1
        print(f"== {script.name}: exit {code} in {time.perf_counter() - start:.1f} s", flush=True)
        if code != 0:
            failed.append(script.name)
    if failed:
        print(f"run_all: failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
