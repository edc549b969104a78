"""The joystick's pedal clip (joy._unit) gives np.clip's bits, signed zero and NaN included."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from kartci.robots.gokart.joy import _unit


@pytest.mark.parametrize("x", [-0.0, 0.0, -1.0, 2.0, 0.5, 1.0, math.nan, math.inf, -math.inf,
                               1e-300, -1e-300, 0.9999999999999999, 1.0000000000000002])
def test_unit_is_np_clip_to_the_bit(x: float) -> None:
    want = float(np.clip(x, 0.0, 1.0))
    assert struct.pack("<d", _unit(x)) == struct.pack("<d", want)
