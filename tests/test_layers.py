"""The floor plan: kartci's packages import one way. Measured from the code's own imports by
tools/layers.py (an import inside a function counts: it is a dependency all the same)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from layers import cycles, edges

# The knot the restructuring (issue 25) unties, package by package. It may only shrink: a package
# that joins it, or a new cycle elsewhere, fails here. Remove names as they leave it.
KNOWN_KNOT = {"kartci.metrics", "kartci.robots"}


def test_no_cycle_outside_the_known_knot() -> None:
    found = cycles(edges())
    assert [c for c in found if not set(c) <= KNOWN_KNOT] == []


def test_the_knot_holds_no_package_it_has_lost() -> None:
    """When a package leaves the knot, KNOWN_KNOT must say so (so it cannot come back)."""
    knotted = {p for c in cycles(edges()) for p in c}
    assert knotted == KNOWN_KNOT
