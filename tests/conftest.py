"""Shared fixtures: paths to the real recorded logs (skipped when ../shared is absent), a
project copy with its own baselines folder, so tests never touch the committed baselines, and
kartci as a user installs it: its wheel (once per session) in a fresh venv."""

from __future__ import annotations

import fcntl
import os
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from helpers import KartLap, kartci

from kartci import portable
from kartci.core import RunFolder
from kartci.report import write_all
from kartci.runner.run import evaluate
from kartci.scenario import load_scenario
from kartci.sim import simulate

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT.parent / "shared" / "fixtures" / "bags"


def pytest_configure(config: pytest.Config) -> None:
    """The tests simulate in this process and compare with baselines bit for bit: a pytest
    started without kartci's pinned environment (kartci.portable) restarts itself with it."""
    if portable.state() is portable.Pin.UNPINNED and not os.environ.get("PYTEST_XDIST_WORKER"):
        capture = config.pluginmanager.getplugin("capturemanager")
        if capture is not None:
            capture.stop_global_capturing()  # the restarted pytest writes to the terminal
        portable.reexec(["-P", "-m", "pytest", *sys.argv[1:]])


LONG = os.environ.get("KARTCI_LONG") == "1"


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Two tiers: the default one a developer runs while working (`pytest -q -n 2`), and the
    full one, tests marked `long` (fuzzing, full-length scenario runs, fresh venvs, every SIMD
    level), which `KARTCI_LONG=1 pytest -m long` adds and `.ci/run` always runs."""
    if LONG:
        return
    for item in items:
        if (mark := item.get_closest_marker("long")) is not None:
            why = mark.kwargs.get("reason", "a slow run")
            item.add_marker(pytest.mark.skip(
                reason=f"full tier ({why}): KARTCI_LONG=1 pytest -m long runs it, as .ci/run does"))


@pytest.fixture(scope="session", autouse=True)
def _outside_ci() -> Iterator[None]:
    """Every test runs as outside CI: with `CI` set, kartci is strict and fails scenarios that
    have no baseline, which most tests run on purpose. Tests of strict mode set `CI` (or pass
    --strict) themselves. Session-scoped, so module-scoped fixtures that run kartci see it too."""
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv("CI", raising=False)
        mp.delenv("GITHUB_ACTIONS", raising=False)
        yield


@pytest.fixture
def bags() -> Path:
    if not FIXTURES.is_dir():
        pytest.skip(f"real recorded logs not found at {FIXTURES} (only CI and developer "
                    "checkouts have ../shared/fixtures)")
    return FIXTURES


@pytest.fixture
def baselines(tmp_path: Path) -> Path:
    path = tmp_path / "baselines"
    path.mkdir()
    return path


@pytest.fixture(scope="session")
def kartci_wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """kartci's wheel, built once per session from this checkout, offline (see venvs.py)."""
    from venvs import build_wheel

    return build_wheel(tmp_path_factory.mktemp("wheel"))


@pytest.fixture
def fresh_venv(tmp_path: Path, kartci_wheel: Path) -> Path:
    """A new venv with kartci installed from its wheel, as a user installs it; its bin folder.
    Run commands in it with `venvs.offline_env(fresh_venv)`."""
    from venvs import make_venv

    return make_venv(tmp_path / "venv", kartci_wheel)


# --- synthetic "real" kart logs with known truth (tests/realdata), made once per session ---
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
    from kartci.realdata.synthetic import synthetic_log

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
    result = evaluate(RunFolder(root / "out" / "kart_manual"), root / "baselines")
    write_all([result], root / "out")
    return KartLap(root / "out", root / "baselines", update, result)



@pytest.fixture(scope="session")
def shipped_run(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], Path]:
    """The log of a shipped scenario run at full length with its committed settings, simulated
    once per test run and shared by every test and every xdist worker that asks for it: the
    first one simulates while the others wait on the scenario's lock, then all read one log."""
    base = tmp_path_factory.getbasetemp()
    folder = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "shipped-runs"
    folder.mkdir(exist_ok=True)

    def get(name: str) -> Path:
        log, done = folder / f"{name}.mcap", folder / f"{name}.done"
        with (folder / f"{name}.lock").open("w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not done.exists():
                simulate(load_scenario(name), log)
                done.touch()
        return log

    return get


@pytest.fixture
def dds_alone(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """One DDS test at a time on this machine, across xdist workers and test runs: the tests
    that check a run leaves no Fast DDS shared memory compare /dev/shm before and after, which
    another worker's or another run's DDS processes would fill meanwhile (each run has its own
    domain, but /dev/shm is the machine's; two checkouts tested at once on one host failed so)."""
    with (Path(tempfile.gettempdir()) / "kartci-dds-tests.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield
