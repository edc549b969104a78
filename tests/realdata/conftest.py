"""The realdata tests' fixtures: synthetic "real" kart logs with a known truth (`helpers.TRUTH`)
and their import profile, made once per session."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import DURATION_S, changed

from kartci.project import current as active_project


@pytest.fixture(scope="session")
def kart_logs(tmp_path_factory: pytest.TempPathFactory) -> dict[float, Path]:
    """Logs of the kart with 0, half and all of the TRUTH change."""
    from kartci.realdata.synthetic import synthetic_log

    folder = tmp_path_factory.mktemp("synthetic")
    return {f: synthetic_log("kart_simreal", changed(f), DURATION_S, folder / f"kart_{f}.mcap",
                             active_project())
            for f in (0.0, 0.5, 1.0)}


@pytest.fixture(scope="session")
def kart_profile(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The profile of the synthetic kart logs."""
    path = tmp_path_factory.mktemp("profile") / "synth_kart.yaml"
    path.write_text("name: synth_kart\npose: {topic: /kart0/odom}\n"
                    "commands: {topic: /kart0/ackermann_cmd}\nrobot: {kind: gokart}\n",
                    encoding="utf-8")
    return path
