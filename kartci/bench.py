"""Benchmark results as files: each `benchmarks/` script records its figures with the machine
and the versions that made them, and `kartci bench compare OLD NEW` reads two such files.

Wall-clock figures from shared 2-core machines are noisy, so a comparison reports ratios of
medians (new / old), and figures that are themselves ratios of two things measured in the same
run (`-j 2` over `-j 1`) are the ones to trust most.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from importlib import metadata
from pathlib import Path
from typing import Any

from kartci.atomic import write_text_atomic
from kartci.boundedio import JSON_MAX_BYTES, read_bytes
from kartci.errors import KartciError

__all__ = ["Better", "Change", "Comparison", "Figure", "Record", "compare", "load"]

FORMAT = "kartci-bench/1"
_PACKAGES = ("kartci", "numpy", "scipy", "pybullet", "casadi", "mcap", "rosbags")


class Better(StrEnum):
    """Which way a figure is better."""

    LOWER = "lower"  # times, sizes
    HIGHER = "higher"  # real-time factors, speed-ups, throughput


class Change(StrEnum):
    """A figure's verdict in a comparison, beyond the noise threshold."""

    BETTER = "better"
    WORSE = "worse"
    SAME = "same"
    NEW = "new"  # only in the new file
    GONE = "gone"  # only in the old file


@dataclass(frozen=True)
class Figure:
    """One measured quantity: its samples (repeats) in `unit`, and which way is better."""

    name: str
    unit: str
    samples: tuple[float, ...]
    better: Better = Better.LOWER
    note: str = ""

    @property
    def median(self) -> float:
        """The median of the samples: what the tables quote."""
        return statistics.median(self.samples)

    @property
    def p95(self) -> float:
        """95th percentile (nearest rank) of the samples."""
        ordered = sorted(self.samples)
        return ordered[min(len(ordered) - 1, max(0, round(0.95 * len(ordered) + 0.5) - 1))]


def _git_commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, timeout=5, cwd=Path(__file__).parent)
    except (OSError, subprocess.TimeoutExpired):
        return ""
    return out.stdout.strip() if out.returncode == 0 else ""


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def machine() -> dict[str, Any]:
    """What made the figures: CPU, cores, OS, Python, package versions, commit."""
    versions = {}
    for pkg in _PACKAGES:
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            continue
    return {"cpu": _cpu_model(), "cores": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version(), "versions": versions, "commit": _git_commit()}


@dataclass
class Record:
    """The figures of one benchmark script's run; `save` writes them as JSON."""

    script: str
    figures: list[Figure] = field(default_factory=list)

    def add(self, name: str, unit: str, samples: Sequence[float], better: Better = Better.LOWER,
            note: str = "") -> Figure:
        """Record a figure (at least one sample) and return it."""
        if not samples:
            raise KartciError(f"benchmark figure {name!r} has no samples")
        fig = Figure(name, unit, tuple(float(s) for s in samples), better, note)
        self.figures.append(fig)
        return fig

    def save(self, path: Path) -> None:
        """Write the figures, with the machine that made them, as JSON."""
        data = {"format": FORMAT, "script": self.script, "machine": machine(),
                "figures": {f.name: {**asdict(f), "median": f.median, "p95": f.p95}
                            for f in self.figures}}
        write_text_atomic(Path(path), json.dumps(data, indent=2) + "\n")


def load(path: Path) -> dict[str, Figure]:
    """The figures of one or more benchmark JSON files (a later file's figure wins)."""
    try:
        data = json.loads(read_bytes(Path(path), JSON_MAX_BYTES))
        if data.get("format") != FORMAT:
            raise KartciError(f"{path}: not a kartci benchmark file (format "
                              f"{data.get('format')!r}, expected {FORMAT!r})")
        return {name: Figure(name, f["unit"], tuple(f["samples"]), Better(f["better"]),
                             f.get("note", ""))
                for name, f in data["figures"].items()}
    except OSError as err:
        raise KartciError(f"{path}: cannot read ({err.strerror or err})") from err
    except (ValueError, KeyError, TypeError, AttributeError) as err:
        raise KartciError(f"{path}: malformed benchmark file ({err})") from err


@dataclass(frozen=True)
class Comparison:
    """One figure in two files: new median over old, and the verdict."""

    name: str
    unit: str
    old: float | None
    new: float | None
    ratio: float | None  # new / old
    change: Change


def _verdict(old: Figure, new: Figure, noise: float) -> Comparison:
    ratio = new.median / old.median if old.median else float("inf")
    gain = ratio if new.better is Better.HIGHER else (1 / ratio if ratio else float("inf"))
    change = (Change.SAME if abs(gain - 1) <= noise else
              Change.BETTER if gain > 1 else Change.WORSE)
    return Comparison(new.name, new.unit, old.median, new.median, ratio, change)


def compare(old: dict[str, Figure], new: dict[str, Figure],
            noise: float = 0.10) -> list[Comparison]:
    """Every figure of either file, by name: ratio of medians and whether it got better or
    worse by more than `noise` (a fraction: 0.10 is 10 %)."""
    rows = []
    for name in sorted(old.keys() | new.keys()):
        o, n = old.get(name), new.get(name)
        if o is not None and n is not None:
            rows.append(_verdict(o, n, noise))
        elif n is not None:
            rows.append(Comparison(name, n.unit, None, n.median, None, Change.NEW))
        elif o is not None:
            rows.append(Comparison(name, o.unit, o.median, None, None, Change.GONE))
    return rows
