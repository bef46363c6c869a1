"""Small pieces for writing the benchmark report: sections, tables, targets."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any


@dataclass
class Target:
    name: str
    met: bool | None          # None: not measured in this run
    measured: str             # the measured ratio or figure, in words
    why: str = ""


@dataclass
class Section:
    title: str
    lines: list = field(default_factory=list)
    targets: list = field(default_factory=list)
    series: dict = field(default_factory=dict)   # for the scaling plot
    data: dict = field(default_factory=dict)     # raw numbers

    def full_run_only(self, name: str, why: str) -> None:
        """A target of the full sizes, listed (not measured) by --quick."""
        self.targets.append(Target(name, None, "full run only", why))

    def add(self, *text: str) -> None:
        self.lines.extend(text)

    def table(self, header: list, rows: list) -> None:
        self.lines.append("| " + " | ".join(header) + " |")
        self.lines.append("|" + "|".join("---" for _ in header) + "|")
        for r in rows:
            self.lines.append("| " + " | ".join(str(c) for c in r) + " |")
        self.lines.append("")

    def markdown(self) -> str:
        return "\n".join([f"## {self.title}", ""] + self.lines) + "\n"


def fmt_t(seconds: Any) -> str:
    """A duration with three significant digits (or a dash)."""
    if seconds is None or (isinstance(seconds, float) and math.isnan(seconds)):
        return "–"
    s = float(seconds)
    if s >= 100:
        return f"{s:.0f} s"
    if s >= 1:
        return f"{s:.3g} s"
    if s >= 1e-3:
        return f"{s * 1e3:.3g} ms"
    return f"{s * 1e6:.3g} µs"


def fmt_x(ratio: Any) -> str:
    if ratio is None or (isinstance(ratio, float) and not math.isfinite(ratio)):
        return "–"
    return f"{ratio:.3g}×"


def fmt_mb(mb: Any) -> str:
    if mb is None:
        return "–"
    return f"{mb / 1024:.2f} GB" if mb >= 1024 else f"{mb:.0f} MB"


def pct(part: float, total: float) -> str:
    return f"{100 * part / total:.0f} %" if total > 0 else "–"
