"""Fitting the MPCC's own prediction model: exact recovery on data the model made, and a
better yaw-rate prediction than the hand-tuned defaults on the simulated kart's log."""

from __future__ import annotations

from pathlib import Path

import pytest

from kartci.errors import SpecError
from kartci.mpcc.params import MpccVehicle
from kartci.realdata.mpcc_fit import Lateral, fit_mpcc, lateral_data, predict

NAMES = ("steer_gain", "mass_per_yaw_inertia_per_m2")


def test_recovers_the_parameters_of_data_the_model_made(kart_logs: dict[float, Path]) -> None:
    vehicle = MpccVehicle()
    data = lateral_data(kart_logs[0.0], "kart0", vehicle)
    made = predict(data, vehicle, NAMES, [0.7, 3.2], window_s=100.0)  # one long run
    fit = fit_mpcc(Lateral(data.t, data.vx, made[:, 0], made[:, 1], data.delta), vehicle, NAMES)
    assert fit.values == pytest.approx((0.7, 3.2), rel=1e-3)
    assert fit.rms_after[1] < 1e-6 < fit.rms_before[1]


def test_fitted_to_the_simulated_kart_it_predicts_yaw_rate_better(
        kart_logs: dict[float, Path]) -> None:
    vehicle = MpccVehicle()
    fit = fit_mpcc(lateral_data(kart_logs[0.0], "kart0", vehicle), vehicle, NAMES)
    assert fit.rms_after[1] < 0.8 * fit.rms_before[1]
    with pytest.raises(SpecError, match="not a field"):
        fit_mpcc(lateral_data(kart_logs[0.0], "kart0", vehicle), vehicle, ["nope"])
