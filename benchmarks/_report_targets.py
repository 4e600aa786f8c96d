"""RESULTS.md: the issue targets of every archived benchmark that has no section of its own.

Each benchmark states its targets as ``{limit, comparison, reached, met}`` somewhere in its JSON
(at the top, or per case); this walks the file and lists every such entry under its path, so a
new benchmark's targets show up in the report as soon as its JSON is archived.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any


def find_targets(node: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[str, dict[str, Any]]]:
    """``(dotted path, target)`` for every dict holding ``limit``, ``reached`` and ``met``."""
    if isinstance(node, dict):
        if {"limit", "reached", "met"} <= node.keys():
            yield ".".join(p for p in path if p != "targets"), node
            return
        for key, value in node.items():
            if key != "machine":
                yield from find_targets(value, (*path, str(key)))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from find_targets(value, (*path, str(i)))


def _number(value: Any) -> str:
    numeric = isinstance(value, (int, float)) and not isinstance(value, bool)
    return f"{value:.3g}" if numeric else "—"


def targets_lines(folder: Path, handled: tuple[str, ...]) -> list[str]:
    """A table per archived JSON of ``folder`` not in ``handled``, if it states any target."""
    lines: list[str] = []
    for path in sorted(folder.glob("*.json")):
        if path.stem in handled:
            continue
        data = json.loads(path.read_text())
        found = list(find_targets(data))
        if not found:
            continue
        machine = data.get("machine", {})
        date, cpu = machine.get("date", "?"), machine.get("cpu_model")
        on = f", {cpu}, {machine.get('cores')} cores" if cpu else ""
        lines += [f"### Targets of bench_{path.stem} (run {date}{on})", "",
                  "| target | limit | reached | met |", "|---|---|---|---|"]  # fmt: skip
        for name, t in found:
            met = {True: "yes", False: "**no**"}.get(t.get("met"), "n/a")
            limit = f"{t.get('comparison', '')} {_number(t.get('limit'))}".strip()
            lines.append(f"| {name} | {limit} | {_number(t.get('reached'))} | {met} |")
        lines.append("")
    return lines
