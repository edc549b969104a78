"""Deprecated: import from `kartci.core` (`Direction`, `Metric`, `MetricDef`).

Kept so that plugins written against `kartci.metrics.base` keep working; nothing in kartci
imports it."""

from kartci.core.metric import Direction, Metric, MetricDef
from kartci.metrics.defs import DEFS

__all__ = ["DEFS", "Direction", "Metric", "MetricDef"]
