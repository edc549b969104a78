"""The recorded fields measured on the wall clock, the one place they are declared.

Everything else in a run log follows from the scenario and its seed; these fields differ between
two runs of one scenario on one machine, so `kartci diff` leaves them out unless asked
(`--wall-clock`). They are declared by message type, so they are found on every topic of that
type, in every agent's namespace. A field written from `time.perf_counter()` (or any clock but
sim time) belongs here; tests/logs/test_diff.py checks that two runs then compare identical.

Not listed: the bridge's `bridge/late_commands` (a lockstep tick answered too late). It is
wall-clock dependent too, but a late tick changes the commands applied, so it is the cause of a
divergence rather than noise beside one.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Final

WALL_CLOCK: Final[Mapping[str, tuple[str, ...]]] = MappingProxyType({
    # the kart's MPCC (its mpcc.controller): time.perf_counter() around the solve, ms
    "kartci_msgs/msg/SolverStats": ("solve_ms",),
})


def wall_clock_fields(msgtype: str) -> tuple[str, ...]:
    """The dotted fields of `msgtype` measured on the wall clock (none for most types)."""
    return WALL_CLOCK.get(msgtype, ())


__all__ = ["WALL_CLOCK", "wall_clock_fields"]
