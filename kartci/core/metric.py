"""Metric values and their definitions (unit, which direction is better, default tolerance):
what every metric set returns and declares, so scoring, judging and plugins share one type."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

RESOLUTION = 0.1  # the narrowest meaningful tolerance, as a fraction of the default one


class Direction(StrEnum):
    """Which way a metric is better, for judging it against its baseline."""

    LOWER = "lower"  # lower is better
    HIGHER = "higher"  # higher is better
    EQUAL = "equal"  # must equal the baseline (within tolerance)


@dataclass(frozen=True)
class MetricDef:
    """A metric's definition: unit, better direction, default tolerance, meaning."""

    unit: str
    direction: Direction
    abs_tol: float  # default tolerance in the metric's unit...
    rel_tol: float  # ...or this fraction of the baseline value, whichever is larger
    description: str
    timing: bool = False  # wall-clock: machine-dependent, kept out of the deterministic metrics

    def default_tolerance(self, value: float) -> float:
        """The tolerance a new baseline entry gets for this value."""
        return max(self.abs_tol, self.rel_tol * abs(value)) if math.isfinite(value) else (
            self.abs_tol)

    def resolution(self, value: float) -> float:
        """The narrowest tolerance worth gating on, in the metric's unit: RESOLUTION of its
        default tolerance. A move below it is float digits, not behaviour, and a gate tighter
        than it fails every harmless change, so that teams learn to re-accept blindly."""
        return RESOLUTION * self.default_tolerance(value)


@dataclass(frozen=True)
class Metric:
    """One named number of a run, with its unit (`extra`: details such as every lap's time)."""

    name: str
    value: float
    unit: str
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """10 significant digits: identical across CPUs whose last float bits differ."""
        value: float | None = float(f"{self.value:.10g}") if math.isfinite(self.value) else None
        return {"value": value, "unit": self.unit, **self.extra}
