"""The report tests' fixture: one kart lap, run and accepted once per session."""

from __future__ import annotations

import pytest
from helpers import KartLap, kartci

from kartci.core import RunFolder
from kartci.project import current as active_project
from kartci.report import write_all
from kartci.runner.run import evaluate

LAP = ["kart_manual", "--set", "duration_s=17", "--set", "criteria={}", "--no-strict"]


@pytest.fixture(scope="session")
def kart_lap(tmp_path_factory: pytest.TempPathFactory) -> KartLap:
    """One kart lap shared by the report tests (kart_manual's first lap ends at ~15.8 s)."""
    root = tmp_path_factory.mktemp("lap")
    (root / "baselines").mkdir()
    run = kartci("run", *LAP, "--out", root / "out", "--baselines", root / "baselines")
    assert run.returncode == 0, run.stderr
    update = kartci("baseline", "update", root / "out", "--baselines", root / "baselines")
    assert update.returncode == 0, update.stderr
    result = evaluate(RunFolder(root / "out" / "kart_manual"), root / "baselines", active_project())
    write_all([result], root / "out")
    return KartLap(root / "out", root / "baselines", update, result)
