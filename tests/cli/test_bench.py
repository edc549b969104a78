"""Benchmark result files: written by the benchmarks/ scripts, compared by `kartci bench`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import kartci

from kartci.bench import Better, Change, Record, compare, load
from kartci.errors import KartciError


def _record(path: Path, solve_ms: list[float], rtf: list[float], extra: bool = False) -> None:
    rec = Record("bench_test")
    rec.add("solve", "ms", solve_ms)
    rec.add("lap RTF", "x", rtf, Better.HIGHER)
    if extra:
        rec.add("new figure", "s", [1.0])
    rec.save(path)


def test_record_round_trip_and_statistics(tmp_path: Path) -> None:
    _record(tmp_path / "a.json", [3.0, 1.0, 2.0, 100.0], [4.0])
    data = json.loads((tmp_path / "a.json").read_text())
    assert data["machine"]["cores"] >= 1 and "numpy" in data["machine"]["versions"]
    figs = load(tmp_path / "a.json")
    assert figs["solve"].median == 2.5
    assert figs["solve"].p95 == 100.0
    assert figs["lap RTF"].better is Better.HIGHER


def test_compare_reads_direction_and_noise(tmp_path: Path) -> None:
    _record(tmp_path / "old.json", [10.0], [2.0])
    _record(tmp_path / "new.json", [5.0], [2.1], extra=True)
    rows = {r.name: r for r in compare(load(tmp_path / "old.json"), load(tmp_path / "new.json"))}
    assert rows["solve"].ratio == 0.5 and rows["solve"].change is Change.BETTER
    assert rows["lap RTF"].change is Change.SAME  # +5 %: within 10 % noise
    assert rows["new figure"].change is Change.NEW
    back = {r.name: r for r in compare(load(tmp_path / "new.json"), load(tmp_path / "old.json"))}
    assert back["solve"].change is Change.WORSE and back["new figure"].change is Change.GONE


def test_cli_compare_exit_codes(tmp_path: Path) -> None:
    _record(tmp_path / "old.json", [10.0], [2.0])
    _record(tmp_path / "new.json", [20.0], [2.0])
    ok = kartci("bench", "compare", tmp_path / "old.json", tmp_path / "new.json")
    assert ok.returncode == 0 and "2.00x" in ok.stdout and "worse" in ok.stdout
    gated = kartci("bench", "compare", tmp_path / "old.json", tmp_path / "new.json",
                   "--fail-worse")
    assert gated.returncode == 1
    (tmp_path / "bad.json").write_text("{}")
    bad = kartci("bench", "compare", tmp_path / "bad.json", tmp_path / "new.json")
    assert bad.returncode == 2 and "not a kartci benchmark file" in bad.stderr
    assert "Traceback" not in bad.stderr


def test_empty_figure_is_refused() -> None:
    with pytest.raises(KartciError, match="no samples"):
        Record("x").add("empty", "ms", [])
