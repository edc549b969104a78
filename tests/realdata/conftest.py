"""Synthetic "real" logs with known truth, made once per session (a few seconds of sim each):
the simulated kart with nominal and with changed parameters, odometry noised."""

from __future__ import annotations

from pathlib import Path

import pytest

from kartci.realdata.synthetic import synthetic_log

KART = "agents.kart0.model"
# the truth of the perturbed log, relative to the nominal model: gain +20 %, steering rate
# -15 %, speed scale (the motor controller's wheel radius) +4.7 %
TRUTH = {"speed_gain_per_s": 2.4, "steering_rate_radps": 3.4, "rear_wheel_radius_m": 0.133}
NOMINAL = {"speed_gain_per_s": 2.0, "steering_rate_radps": 4.0, "rear_wheel_radius_m": 0.127}
DURATION_S = 5.0


def changed(fraction: float) -> list[str]:
    """Overrides that move every TRUTH parameter `fraction` of the way from nominal."""
    return [f"{KART}.{k}={NOMINAL[k] + fraction * (TRUTH[k] - NOMINAL[k])}" for k in TRUTH]


@pytest.fixture(scope="session")
def kart_logs(tmp_path_factory: pytest.TempPathFactory) -> dict[float, Path]:
    """Logs of the kart with 0, half and all of the TRUTH change."""
    folder = tmp_path_factory.mktemp("synthetic")
    return {f: synthetic_log("kart_simreal", changed(f), DURATION_S, folder / f"kart_{f}.mcap")
            for f in (0.0, 0.5, 1.0)}


@pytest.fixture(scope="session")
def kart_profile(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The profile of the synthetic kart logs."""
    path = tmp_path_factory.mktemp("profile") / "synth_kart.yaml"
    path.write_text("name: synth_kart\npose: {topic: /kart0/odom}\n"
                    "commands: {topic: /kart0/ackermann_cmd}\nrobot: {kind: gokart}\n",
                    encoding="utf-8")
    return path
