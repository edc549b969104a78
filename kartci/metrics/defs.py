"""The definitions (unit, better direction, default tolerance, meaning) of the metrics that
more than one metric set computes, whatever the robot: speeds, distance from a course, laps on
a track, collisions, clearance. A metric only one kind computes is defined next to the code that
computes it, in the kind's own package."""

from __future__ import annotations

from kartci.core.metric import Direction, MetricDef

DEFS: dict[str, MetricDef] = {
    "cross_track_rms_m": MetricDef("m", Direction.LOWER, 0.0002, 0.10,
                                   "RMS distance from the course's axis (a line or a "
                                   "centreline), after the transient where a set has one"),
    "mean_speed_mps": MetricDef("m/s", Direction.HIGHER, 0.002, 0.02,
                                "mean forward speed of base_link"),
    "laps_completed": MetricDef("laps", Direction.HIGHER, 0.0, 0.0, "full laps from the start"),
    "lap_times_s": MetricDef("s", Direction.LOWER, 0.2, 0.03,
                             "mean lap time; every lap's time under `laps`"),
    "best_lap_s": MetricDef("s", Direction.LOWER, 0.2, 0.03, "fastest full lap"),
    "collisions": MetricDef("count", Direction.LOWER, 0.0, 0.0,
                            "contacts with anything but the floor; each under `events`"),
    "max_speed_mps": MetricDef("m/s", Direction.EQUAL, 0.2, 0.03, "top speed of base_link"),
    "progress_m": MetricDef("m", Direction.HIGHER, 0.5, 0.01, "arc length driven along the track"),
    "min_clearance_m": MetricDef("m", Direction.HIGHER, 0.05, 0.2,
                                 "smallest gap between the robot's outline (from its "
                                 "description) and an obstacle or another robot's outline"),
}


def defs_of(*names: str) -> dict[str, MetricDef]:
    """The definitions of these metrics, for a metric set that computes them."""
    return {n: DEFS[n] for n in names}
