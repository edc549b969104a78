"""Metric values and their definitions (unit, which direction is better, default tolerance)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any


class Direction(StrEnum):
    LOWER = "lower"  # lower is better
    HIGHER = "higher"  # higher is better
    EQUAL = "equal"  # must equal the baseline (within tolerance)


@dataclass(frozen=True)
class MetricDef:
    unit: str
    direction: Direction
    abs_tol: float  # default tolerance in the metric's unit...
    rel_tol: float  # ...or this fraction of the baseline value, whichever is larger
    description: str

    def default_tolerance(self, value: float) -> float:
        return max(self.abs_tol, self.rel_tol * abs(value)) if math.isfinite(value) else 0.0


@dataclass(frozen=True)
class Metric:
    name: str
    value: float
    unit: str
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        value: float | None = self.value if math.isfinite(self.value) else None
        return {"value": value, "unit": self.unit, **self.extra}


DEFS: dict[str, MetricDef] = {
    "cross_track_rms_m": MetricDef("m", Direction.LOWER, 0.0002, 0.10,
                                   "RMS distance of the line-sensor point from the line axis "
                                   "after the start-up transient"),
    "cross_track_max_m": MetricDef("m", Direction.LOWER, 0.0005, 0.10,
                                   "largest such distance after the transient"),
    "line_lost": MetricDef("bool", Direction.EQUAL, 0.0, 0.0,
                           "1 if the sensor point ever left the sensor's range of the line"),
    "completion": MetricDef("fraction", Direction.HIGHER, 0.01, 0.0,
                            "fraction of the course covered while on the line"),
    "mean_speed_mps": MetricDef("m/s", Direction.HIGHER, 0.002, 0.02,
                                "mean forward speed of base_link"),
    "settle_time_s": MetricDef("s", Direction.LOWER, 0.5, 0.10,
                               "time after which the cross-track error stays in the settle band"),
}
