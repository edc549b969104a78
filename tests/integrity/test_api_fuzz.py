"""Issue 40, done-when: the Python API's entry points (`run`, `compare`, `accept_baselines`,
`load_scenario`, `Session`) under generated input raise nothing but KartciError subclasses,
print no traceback, and write nothing outside the folders they were given.

Each example calls one entry point with arguments drawn from near-misses of valid ones
(scenario names and paths, `--set` overrides with real keys and odd values, run folders,
replica counts, agent objects that are not agents) and from arbitrary text. What an entry point
may write (`out`, `baselines`, a Session's log) is always inside GIVEN; the project folder
around it must be unchanged afterwards. The default run tries a few derandomized examples in
a few seconds; the long one many more:

    KARTCI_LONG=1 pytest -m long tests/integrity/test_api_fuzz.py
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import kartci
from kartci import project
from kartci.errors import KartciError

QUICK = ["duration_s=0.05", "criteria={}", "metrics.line_tracking.transient_s=0.01"]
KEYS = ["duration_s", "seed", "criteria", "metrics", "world", "agents.lt0.controller.kp",
        "agents.lt0.controller.type", "agents.lt0.model", "agents.lt0.start.lateral_m",
        "agents.lt1.model", "sweep", "metrics.line_tracking.transient_s", "name", ""]
VALUES = ["0", "-1", "1e308", "nan", ".inf", "[]", "{}", "null", "'x'", "line_pid",
          "[1, 2]", "{a: 1}", "!!python/object:os.system x", "&a [*a]", "0.02", "true"]
NAMES = ["line_straight", "line_circle", "no_such", "../line_straight", "/etc/passwd",
         "/dev/zero", "line_straight.yaml", "", ".", "LINE_STRAIGHT", "a" * 300, "x\0y"]


def _override() -> st.SearchStrategy[str]:
    short = st.text(max_size=12)
    return st.one_of(st.builds(lambda k, v: f"{k}={v}", st.sampled_from(KEYS),
                               st.one_of(st.sampled_from(VALUES), short)), short)


OVERRIDES = st.lists(_override(), max_size=3)
SCENARIO = st.one_of(st.sampled_from(NAMES), st.text(max_size=20))


class NotAnAgent:
    """Something a user might pass as an agent by mistake."""

    period_s = -1.0


AGENTS: st.SearchStrategy[dict[str, object] | None] = st.one_of(
    st.none(), st.just({}), st.just({"lt0": NotAnAgent()}), st.just({"nobody": NotAnAgent()}),
    st.just({"lt0": 3}))


@pytest.fixture(scope="module")
def sandbox() -> Iterator[Path]:
    """A project of its own (no scenarios of its own; the built-in ones by name), made the
    current one while the module runs, and a valid run in it for `compare`."""
    root = Path(tempfile.mkdtemp(prefix="kartci-api-fuzz-"))
    (root / "proj").mkdir()
    (root / "proj" / "kartci.toml").write_text('scenarios = ["scenarios"]\n')
    old = Path.cwd()
    os.chdir(root / "proj")
    project.activate(None)
    try:
        yield root / "proj"
    finally:
        os.chdir(old)
        project.activate(None)
        shutil.rmtree(root, ignore_errors=True)


@pytest.fixture(scope="module")
def valid_run(sandbox: Path) -> kartci.RunResult:
    return kartci.run("line_straight", overrides=QUICK, out=sandbox / "given" / "base",
                      baselines=sandbox / "given" / "baselines")


def _snapshot(folder: Path) -> dict[str, tuple[int, int]]:
    """Every path under `folder` but GIVEN, with its size and mtime."""
    out = {}
    for where, dirs, files in os.walk(folder):
        dirs[:] = [d for d in dirs if not (where == str(folder) and d == "given")]
        for name in (*dirs, *files):
            st_ = Path(where, name).lstat()
            out[str(Path(where, name).relative_to(folder))] = (st_.st_size, st_.st_mtime_ns)
    return out


def _call(sandbox: Path, capsys: pytest.CaptureFixture[str], call: Callable[[], Any]) -> str:
    """`call` raises nothing but a KartciError, prints no traceback, writes only in GIVEN;
    returns the outcome (`ok`, or the KartciError subclass's name)."""
    before = _snapshot(sandbox)
    outcome = "ok"
    try:
        call()
    except KartciError as err:
        assert "Traceback" not in str(err)
        outcome = type(err).__name__
    finally:
        printed = capsys.readouterr()
    assert "Traceback" not in printed.out + printed.err
    assert _snapshot(sandbox) == before
    return outcome


def _given(sandbox: Path, sub: str) -> Path:
    return sandbox / "given" / sub


FEW = settings(max_examples=6, deadline=None, derandomize=True, database=None,
               suppress_health_check=[HealthCheck.function_scoped_fixture,
                                      HealthCheck.too_slow])
MANY = settings(max_examples=150, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])


def _entry_points(sandbox: Path, valid: kartci.RunResult) -> dict[str, st.SearchStrategy[Any]]:
    """One strategy per entry point, each drawing a ready-to-make call."""
    out_dir = st.sampled_from(["o1", "o2", "o 3"]).map(lambda s: _given(sandbox, s))
    base_dir = st.sampled_from(["baselines", "b2"]).map(lambda s: _given(sandbox, s))
    return {
        "load_scenario": st.builds(
            lambda s, o, a: lambda: kartci.load_scenario(s, o, allow_outside_paths=a),
            SCENARIO, OVERRIDES, st.booleans()),
        "run": st.builds(
            lambda s, o, agents, out, b: lambda: kartci.run(
                s, overrides=[*QUICK, *o], agents=agents, out=out, baselines=b),
            st.sampled_from(NAMES[:3]), OVERRIDES, AGENTS, out_dir, base_dir),
        "compare": st.builds(
            lambda b, head: lambda: kartci.compare(valid, head, baselines=b),
            st.one_of(base_dir, st.text(max_size=10).map(lambda t: _given(sandbox, t))),
            st.sampled_from([valid])),
        "accept_baselines": st.builds(
            lambda r, names, b, k, j: lambda: kartci.accept_baselines(
                r, names, baselines=b, replicas=k, jobs=j),
            st.one_of(st.just(valid), st.just(_given(sandbox, "base")),
                      st.text(max_size=10).map(lambda t: _given(sandbox, t)), st.just("/")),
            st.lists(st.sampled_from(["line_straight", "../x", "", "no_such"]), max_size=2),
            base_dir, st.sampled_from([0, 1, 2, -3, 10**9]), st.sampled_from([1, 0, -1])),
        "Session": st.builds(
            lambda s, o, agents, log: lambda: _session(s, o, agents, log),
            st.sampled_from(NAMES[:3]), OVERRIDES, AGENTS,
            st.sampled_from(["s.mcap", "deep/s.mcap"]).map(lambda s: _given(sandbox, s))),
    }


def _session(name: str, overrides: list[str], agents: Any, log: Path) -> None:
    spec = kartci.load_scenario(name, [*QUICK, *overrides])
    session = kartci.Session(spec, log, agents)
    session.reset()
    for _ in range(3):
        session.step()
    session.close()


@pytest.mark.parametrize("entry", ["load_scenario", "run", "compare", "accept_baselines",
                                   "Session"])
def test_every_api_entry_point_fails_only_with_kartci_errors(
        sandbox: Path, valid_run: kartci.RunResult, capsys: pytest.CaptureFixture[str],
        entry: str) -> None:
    @FEW
    @given(call=_entry_points(sandbox, valid_run)[entry])
    def check(call: Callable[[], Any]) -> None:
        _call(sandbox, capsys, call)

    check()


@pytest.mark.long(reason="many generated calls of the Python API, each possibly a short run")
@pytest.mark.parametrize("entry", ["load_scenario", "run", "compare", "accept_baselines",
                                   "Session"])
def test_every_api_entry_point_fails_only_with_kartci_errors_long(
        sandbox: Path, valid_run: kartci.RunResult, capsys: pytest.CaptureFixture[str],
        entry: str) -> None:
    outcomes: Counter[str] = Counter()

    @MANY
    @given(call=_entry_points(sandbox, valid_run)[entry])
    def check(call: Callable[[], Any]) -> None:
        outcomes[_call(sandbox, capsys, call)] += 1

    check()
    with capsys.disabled():
        print(f"\n{entry}: {dict(outcomes)}")
    assert outcomes["ok"] > 0, outcomes  # valid calls were made too, not only refusals
