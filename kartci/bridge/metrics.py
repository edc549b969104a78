"""The `bridge` metric set: how often an external stack answered a lockstep tick too late.
Wall-clock dependent, so it is a timing figure (reported, kept out of the deterministic
metrics); any late tick also means the run may not repeat byte for byte."""

from __future__ import annotations

from kartci.bridge.agent import LATE_TOPIC
from kartci.core import Direction, Metric, MetricDef, MetricSet
from kartci.metrics import ScoreContext


def _late(ctx: ScoreContext, params: object) -> list[Metric]:
    table = ctx.table(LATE_TOPIC)
    return [Metric("late_commands", float(0 if table is None else len(table)), "count")]


BRIDGE = MetricSet(
    "bridge",
    {"late_commands": MetricDef("count", Direction.LOWER, 0.0, 0.0, "control ticks the "
                                "external stack answered after tick_timeout_s (lockstep)",
                                timing=True)},
    _late, None, (), "an external stack's late answers (timing: wall-clock dependent)")
