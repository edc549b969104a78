"""The built-in metrics' definitions (unit, better direction, default tolerance, meaning),
shared by the built-in metric sets that compute them."""

from __future__ import annotations

from kartci.core.metric import Direction, MetricDef

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
                                 "smallest gap between the robot's outline (from its "
                                 "description) and an obstacle or another robot's outline"),
    "overtakes": MetricDef("count", Direction.HIGHER, 0.0, 0.0,
                           "net passes of other karts (passes minus times passed; lapping a "
                           "kart is a pass)"),
    "solver_failures": MetricDef("count", Direction.LOWER, 0.0, 0.0,
                                 "MPCC solves that failed or hit the iteration cap (the kart "
                                 "braked)"),
    "solve_ms_median": MetricDef("ms", Direction.LOWER, 5.0, 1.0, "median MPCC solve time",
                                 timing=True),
    "solve_ms_p95": MetricDef("ms", Direction.LOWER, 5.0, 1.0, "95th percentile solve time",
                              timing=True),
    "solve_ms_max": MetricDef("ms", Direction.LOWER, 20.0, 2.0, "slowest solve", timing=True),
}


def defs_of(*names: str) -> dict[str, MetricDef]:
    """The definitions of these metrics, for a metric set that computes them."""
    return {n: DEFS[n] for n in names}
