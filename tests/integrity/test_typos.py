"""Issue 40, item 7: silent typos. An allow-list entry naming no metric or no scenario, or with
an empty reason, and a KARTCI_SIMD value that is neither `native` nor `pinned`, are errors
with the nearest valid name; none quietly means something else."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from helpers import ROOT

from kartci import project
from kartci.errors import SpecError
from kartci.project import current as active_project
from kartci.runner.run import check_criteria_names


@pytest.fixture
def in_project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """An empty project in tmp_path (kartci's built-in scenarios reachable by name)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("KARTCI_ROOT", raising=False)
    project.activate(None)
    yield tmp_path
    project.activate(None)


def _allow(folder: Path, *entries: str) -> None:
    (folder / "kartci.toml").write_text("[allow_loose_tolerances]\n" + "".join(
        f"{e}\n" for e in entries))
    project.activate(None)


@pytest.mark.parametrize(("entry", "message"), [
    ('"line_straight:cross_track_rms_mm" = "wide on purpose"',
     '"line_straight:cross_track_rms_mm": no metric named "cross_track_rms_mm" (did you mean '
     "'cross_track_rms_m'?)"),
    ('"line_straigth:cross_track_rms_m" = "wide on purpose"',
     '"line_straigth:cross_track_rms_m": no scenario or baseline named "line_straigth" (did '
     "you mean 'line_straight'?)"),
])
def test_an_allowed_loose_tolerance_must_name_a_scenario_and_a_metric(
        in_project: Path, entry: str, message: str) -> None:
    _allow(in_project, entry)
    with pytest.raises(SpecError) as err:
        check_criteria_names([],
                             active_project())  # what every judging command checks before it runs
    assert str(err.value) == (f"{in_project / 'kartci.toml'}: "
                              f"[tool.kartci.allow_loose_tolerances] {message}")


@pytest.mark.parametrize(("entry", "why"), [
    ('":cross_track_rms_m" = "wide"', "':cross_track_rms_m' names no scenario"),
    ('"line_straight:" = "wide"', "'line_straight:' names no metric"),
    ('"line_straight:cross_track_rms_m" = "  "',
     "'line_straight:cross_track_rms_m': an empty reason; say why its tolerance may stay loose"),
])
def test_an_allow_list_entry_without_a_part_is_refused_when_the_project_loads(
        in_project: Path, entry: str, why: str) -> None:
    _allow(in_project, entry)
    with pytest.raises(SpecError, match="allow_loose_tolerances: Value error, ") as err:
        project.current()
    assert why in str(err.value)


def test_a_sweep_point_and_an_agent_metric_are_valid_entries(in_project: Path) -> None:
    _allow(in_project, '"line_circle_edge_fast@seed=2:cross_track_rms_m" = "a point"',
           '"kart_wall:kart0.cross_track_rms_m" = "an agent\'s metric"')
    check_criteria_names([], active_project())


def test_the_shipped_allow_list_is_valid(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)
    monkeypatch.delenv("KARTCI_ROOT", raising=False)
    project.activate(None)
    try:
        assert project.current().allow_loose_tolerances
        check_criteria_names([], active_project())
    finally:
        project.activate(None)


@pytest.mark.parametrize(("value", "hint"), [("garbage", "unset means pinned"),
                                             ("Native", "did you mean 'native'?")])
def test_a_bad_kartci_simd_is_one_line_and_exit_2(value: str, hint: str) -> None:
    """It used to mean the pinned default, silently: `Native` asked for the CPU's kernels."""
    p = subprocess.run([sys.executable, "-m", "kartci", "plugins"], capture_output=True,
                       text=True, timeout=120, env={**os.environ, "KARTCI_SIMD": value})
    assert p.returncode == 2
    assert p.stderr == f"kartci: error: KARTCI_SIMD={value!r}: not native or pinned ({hint})\n"


def test_a_bad_kartci_simd_is_a_spec_error_in_python(monkeypatch: pytest.MonkeyPatch) -> None:
    from kartci import portable

    monkeypatch.setenv("KARTCI_SIMD", "AVX2")
    with pytest.raises(SpecError, match="KARTCI_SIMD='AVX2': not native or pinned"):
        portable.state()
    for ok in ("native", "pinned", ""):
        monkeypatch.setenv("KARTCI_SIMD", ok)
        portable.state()
