"""The floor plan: kartci's packages import one way. Measured from the code's own imports by
tools/layers.py (an import inside a function counts: it is a dependency all the same)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from layers import cycles, edges


def test_no_cycle() -> None:
    """No two packages import each other, directly or around a loop (issue 25 untied the last)."""
    assert cycles(edges()) == []


def test_the_metric_engine_imports_no_robot_kind() -> None:
    """A kind's metrics live with the kind (`kartci.robots.<kind>.metrics`) and import the
    engine; the engine learns a robot's outline from its registered kind, never from its code."""
    assert [e.where for e in edges() if (e.source, e.target) == ("kartci.metrics",
                                                                 "kartci.robots")] == []
