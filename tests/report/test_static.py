"""The static report's figures (SVG, no script)."""

from __future__ import annotations

import re

import numpy as np

from kartci.plotting import Axis, Figure, Series
from kartci.report.static import figure_svg


def test_a_log_axis_is_labelled_with_plain_numbers_not_raw_mathtext() -> None:
    """Mathtext is off for user text, so the log axis's default labels came out as the literal
    `$\\mathdefault{10^{1}}$`; they must read as numbers."""
    t = np.linspace(0.0, 10.0, 50)
    fig = Figure("solve", "MPCC solve time", "sim time [s]", "solve time [ms]", Axis.TIME,
                 [Series("kart0", t, 5.0 + 20.0 * np.exp(-t))], log_y=True)
    svg = figure_svg(fig)
    assert "mathdefault" not in svg and "$" not in svg
    labels = set(re.findall(r">\s*([0-9.]+)\s*</text>", svg))
    assert {"10", "20"} <= labels, labels
