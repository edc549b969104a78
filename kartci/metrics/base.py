"""Metric values and their definitions (unit, which direction is better, default tolerance)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any


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


DEFS: dict[str, MetricDef] = {
    "cross_track_rms_m": MetricDef("m", Direction.LOWER, 0.0002, 0.10,
                                   "RMS distance from the line axis (line tracker: of the "
                                   "sensor point, after the transient) or from the centreline"),
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
    "laps_completed": MetricDef("laps", Direction.HIGHER, 0.0, 0.0, "full laps from the start"),
    "lap_times_s": MetricDef("s", Direction.LOWER, 0.2, 0.03,
                             "mean lap time; every lap's time under `laps`"),
    "best_lap_s": MetricDef("s", Direction.LOWER, 0.2, 0.03, "fastest full lap"),
    "collisions": MetricDef("count", Direction.LOWER, 0.0, 0.0,
                            "contacts with anything but the floor; each under `events`"),
    "off_track_s": MetricDef("s", Direction.LOWER, 0.1, 0.10,
                             "time with any wheel outside the track bounds"),
    "max_speed_mps": MetricDef("m/s", Direction.EQUAL, 0.2, 0.03, "top speed of base_link"),
    "progress_m": MetricDef("m", Direction.HIGHER, 0.5, 0.01, "arc length driven along the track"),
    "min_clearance_m": MetricDef("m", Direction.HIGHER, 0.05, 0.2,
                                 "smallest gap between the kart's footprint and an obstacle or "
                                 "another kart"),
    "overtakes": MetricDef("count", Direction.HIGHER, 0.0, 0.0,
                           "net passes of other karts (passes minus times passed)"),
    "solver_failures": MetricDef("count", Direction.LOWER, 0.0, 0.0,
                                 "MPCC solves that failed or hit the iteration cap (the kart "
                                 "braked)"),
    "solve_ms_median": MetricDef("ms", Direction.LOWER, 5.0, 1.0, "median MPCC solve time",
                                 timing=True),
    "solve_ms_p95": MetricDef("ms", Direction.LOWER, 5.0, 1.0, "95th percentile solve time",
                              timing=True),
    "solve_ms_max": MetricDef("ms", Direction.LOWER, 20.0, 2.0, "slowest solve", timing=True),
}
