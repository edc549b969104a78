"""The suite workflow (`kartci.app.suite`) is one function for the CLI, the Python API and the
pytest plugin: `kartci.run_suite(shard=...)` and `kartci.merge` give what `kartci run --shard`
and `kartci merge` give, and an unsharded run's results."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import kartci

import kartci as api
from kartci import SpecError
from kartci.app.suite import shard_of
from kartci.runner.jobs import shard_labels

PAIR = ["line_circle", "line_straight"]
QUICK = ("duration_s=2", "metrics.line_tracking.transient_s=0.5", "criteria={}")


def _metrics(out: Path) -> dict[str, bytes]:
    return {p.parent.name: p.read_bytes() for p in sorted(out.glob("*/metrics.json"))}


def test_api_shards_merge_into_what_the_cli_and_an_unsharded_run_give(tmp_path: Path) -> None:
    base = tmp_path / "baselines"
    base.mkdir()
    parts = [api.run_suite(PAIR, overrides=QUICK, out=tmp_path / f"s{i}", baselines=base,
                           shard=(i, 2)) for i in (1, 2)]
    assert [[r.name for r in p.results] for p in parts] == [["line_circle"], ["line_straight"]]
    assert [p.shard for p in parts] == [(1, 2), (2, 2)] and all(p.passed for p in parts)
    assert json.loads((tmp_path / "s1" / "shard.json").read_text()) == {
        "index": 1, "total": 2, "scenarios": ["line_circle"]}
    merged = api.merge([tmp_path / "s1", tmp_path / "s2"], out=tmp_path / "merged",
                       baselines=base)
    whole = api.run_suite(PAIR, overrides=QUICK, out=tmp_path / "whole", baselines=base)
    assert merged.exit_code == whole.exit_code == 0 and merged.shard is None
    assert _metrics(tmp_path / "merged") == _metrics(tmp_path / "whole")
    assert merged.reports["json"].read_bytes() == whole.reports["json"].read_bytes()
    assert sorted(merged.reports) == ["html", "json", "junit", "markdown", "static"]
    # the CLI shares the function: its shard writes the same partial result
    p = kartci("run", *PAIR, *(x for q in QUICK for x in ("--set", q)), "--out",
               tmp_path / "cli1", "--baselines", base, "--shard", "1/2")
    assert p.returncode == 0, p.stderr
    assert _metrics(tmp_path / "cli1") == _metrics(tmp_path / "s1")
    assert (tmp_path / "cli1" / "shard.json").read_bytes() == (
        tmp_path / "s1" / "shard.json").read_bytes()


def test_merge_through_the_api_refuses_a_missing_share(tmp_path: Path) -> None:
    base = tmp_path / "baselines"
    base.mkdir()
    api.run_suite(["line_straight"], overrides=QUICK, out=tmp_path / "s1", baselines=base,
                  shard=(1, 2))
    with pytest.raises(SpecError, match="shard 2 of 2 missing"):
        api.merge([tmp_path / "s1"], out=tmp_path / "merged", baselines=base)


@pytest.mark.parametrize("shard", [(0, 2), (3, 2), (1, 0)])
def test_a_bad_shard_is_refused_before_anything_runs(tmp_path: Path,
                                                     shard: tuple[int, int]) -> None:
    with pytest.raises(SpecError, match=r"expected I/N with 1 <= I <= N"):
        api.run_suite(["line_straight"], out=tmp_path / "out", shard=shard)
    assert not (tmp_path / "out").exists()


def test_shares_deal_labels_as_the_runner_does_and_cover_them_once() -> None:
    labels = [f"s{k}" for k in range(7)]
    shares = [shard_of(labels, (i, 3)) for i in (1, 2, 3)]
    assert shares == [shard_labels(set(labels), i, 3) for i in (1, 2, 3)]
    assert sorted(x for share in shares for x in share) == sorted(labels)
    assert sorted(len(s) for s in shares) == [2, 2, 3]
    assert shard_of(labels, None) == set(labels)
