"""The recorded fields measured on the wall clock, as the robot kinds that record them declare
them (`RobotKind.wall_clock`).

Everything else in a run log follows from the scenario and its seed; these fields differ between
two runs of one scenario on one machine, so `kartci diff` leaves them out unless asked
(`--wall-clock`). They are declared by message type, so they are found on every topic of that
type, in every agent's namespace. A field written from `time.perf_counter()` (or any clock but
sim time) belongs in its kind's declaration; tests/logs/test_diff.py checks that two runs then
compare identical.

Not listed: the bridge's `bridge/late_commands` (a lockstep tick answered too late). It is
wall-clock dependent too, but a late tick changes the commands applied, so it is the cause of a
divergence rather than noise beside one.
"""

from __future__ import annotations

from kartci.core.registry import ROBOTS


def wall_clock() -> dict[str, tuple[str, ...]]:
    """Every registered kind's wall-clock fields by message type."""
    out: dict[str, tuple[str, ...]] = {}
    for kind in ROBOTS.all():
        for msgtype, fields in kind.wall_clock.items():
            out[msgtype] = tuple(dict.fromkeys((*out.get(msgtype, ()), *fields)))
    return out


def wall_clock_fields(msgtype: str) -> tuple[str, ...]:
    """The dotted fields of `msgtype` measured on the wall clock (none for most types)."""
    return wall_clock().get(msgtype, ())


__all__ = ["wall_clock", "wall_clock_fields"]
