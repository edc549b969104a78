"""Parallel, sharded and merged runs give what one serial run gives, metric for metric."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import PAIR, QUICK, kartci
from junitparser import JUnitXml

from kartci.errors import SpecError
from kartci.project import current as active_project
from kartci.runner import expand, parse_shard, shard
from kartci.runner.merge import merge


def _metrics(out: Path) -> dict[str, bytes]:
    return {p.parent.name: p.read_bytes() for p in sorted(out.glob("*/metrics.json"))}


def _run(out: Path, baselines: Path, *extra: str | Path) -> None:
    p = kartci("run", *PAIR, *QUICK, "--out", out, "--baselines", baselines, *extra)
    assert p.returncode == 0, p.stderr


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One plain serial run of the pair: what every other executor must reproduce."""
    root = tmp_path_factory.mktemp("serial")
    (root / "baselines").mkdir()
    _run(root / "out", root / "baselines")
    assert sorted(_metrics(root / "out")) == sorted(PAIR)
    return root


@pytest.mark.long(reason="several kartci runs end to end")
def test_j2_and_two_merged_shards_equal_one_serial_run(serial: Path, tmp_path: Path) -> None:
    baselines = serial / "baselines"
    _run(tmp_path / "pool", baselines, "-j", "2")
    _run(tmp_path / "s1", baselines, "--shard", "1/2")
    _run(tmp_path / "s2", baselines, "--shard", "2/2")
    expected = _metrics(serial / "out")
    assert _metrics(tmp_path / "pool") == expected  # byte-identical in other processes
    assert len(_metrics(tmp_path / "s1")) == len(_metrics(tmp_path / "s2")) == 1
    m = kartci("merge", tmp_path / "s1", tmp_path / "s2", "--out", tmp_path / "merged",
               "--baselines", baselines)
    assert m.returncode == 0, m.stderr
    assert _metrics(tmp_path / "merged") == expected
    merged = json.loads((tmp_path / "merged" / "summary.json").read_text())
    assert merged == json.loads((serial / "out" / "summary.json").read_text())
    for name in ("report.html", "summary.md"):
        assert (tmp_path / "merged" / name).exists()
    xml = JUnitXml.fromfile(str(tmp_path / "merged" / "junit.xml"))
    assert sorted(case.name for suite in xml for case in suite) == sorted(PAIR)
    log = json.loads((tmp_path / "merged" / "line_circle" / "run.json").read_text())["log"]
    assert Path(log).parent == tmp_path / "merged" / "line_circle"


@pytest.mark.long(reason="starts Ray")
def test_a_sweep_on_local_ray_gives_the_same_metrics(serial: Path, tmp_path: Path) -> None:
    """Each sweep point a Ray task; the points equal to the scenarios' own gains reproduce the
    serial run byte for byte, and sweep points are judged as NEW (no baseline of their own)."""
    pytest.importorskip("ray", reason='Ray is not installed (pip install "kartci[ray]")')
    _run(tmp_path, serial / "baselines", "--executor", "ray", "-j", "2",
         "--sweep", "agents.lt0.controller.kp=50,100")
    got = _metrics(tmp_path)
    assert sorted(got) == [f"{n}@agents.lt0.controller.kp={k}" for n in sorted(PAIR)
                           for k in (100, 50)]
    expected = _metrics(serial / "out")
    assert got["line_straight@agents.lt0.controller.kp=100"] == expected["line_straight"]
    assert got["line_circle@agents.lt0.controller.kp=50"] == expected["line_circle"]
    assert got["line_circle@agents.lt0.controller.kp=100"] != expected["line_circle"]
    summary = json.loads((tmp_path / "summary.json").read_text())["scenarios"]
    assert {s["status"] for s in summary.values()} == {"new"}


def test_ray_missing_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "ray.py").write_text("raise ImportError('not here')\n")
    p = kartci("run", "line_straight", "--executor", "ray", "--out", tmp_path / "o",
               env={"PYTHONPATH": str(tmp_path)})
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.strip() == 'kartci: error: --executor ray needs Ray: pip install "kartci[ray]"'


def test_shards_are_disjoint_deterministic_and_cover_everything() -> None:
    jobs = expand(PAIR, [], active_project(), ["seed=1,2,3"], repeat=2)
    assert len(jobs) == 12  # 2 scenarios x 3 sweep points x 2 repeats
    parts = [shard(jobs, i, 4) for i in range(1, 5)]
    labels = [{j.label for j in p} for p in parts]
    assert sorted(x for s in labels for x in s) == sorted({j.label for j in jobs})
    assert [len(s) for s in labels] == [2, 2, 1, 1]
    assert all(sum(j.label == lab for j in p) == 2 for p in parts for lab in {j.label for j in p})
    assert [j.folder for j in shard(jobs, 2, 4)] == [j.folder for j in shard(jobs, 2, 4)]


@pytest.mark.parametrize("text", ["0/2", "3/2", "1", "a/b", "1/0"])
def test_bad_shard_is_bad_input(text: str) -> None:
    with pytest.raises(SpecError, match="--shard"):
        parse_shard(text)


def test_merge_refuses_a_missing_or_repeated_shard(tmp_path: Path, baselines: Path) -> None:
    for i in (1, 2):
        (tmp_path / f"s{i}").mkdir()
        (tmp_path / f"s{i}" / "shard.json").write_text(json.dumps(
            {"index": 1 if i == 1 else 3, "total": 3, "scenarios": []}))
    with pytest.raises(SpecError, match="shard 2 of 3 missing"):
        merge([tmp_path / "s1", tmp_path / "s2"], tmp_path / "out", baselines, active_project())
    with pytest.raises(SpecError, match="given twice"):
        merge([tmp_path / "s1", tmp_path / "s1"], tmp_path / "out", baselines, active_project())


@pytest.mark.long(reason="four short runs in worker processes")
def test_warm_workers_serve_a_second_batch_with_the_same_processes_and_bits(
        tmp_path: Path) -> None:
    from kartci.runner.executors import Warm
    from kartci.runner.suite import run_jobs

    quick = ["duration_s=1", "criteria={}", "metrics.line_tracking.transient_s=0.5"]
    jobs = expand(PAIR, quick, active_project())
    (tmp_path / "b").mkdir()
    warm = Warm()
    try:
        first = run_jobs(jobs, tmp_path / "one", tmp_path / "b",
                         active_project(), workers=2, warm=warm)
        kept = warm.workers
        assert kept is not None
        pids = {p.pid for p in kept.ex._processes.values()}
        second = run_jobs(jobs, tmp_path / "two", tmp_path / "b",
                          active_project(), workers=2, warm=warm)
        assert warm.workers is kept and {p.pid for p in kept.ex._processes.values()} == pids
    finally:
        warm.close()
    assert [r.error for r in first + second] == [None] * 4
    assert _metrics(tmp_path / "one") == _metrics(tmp_path / "two")
