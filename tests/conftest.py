"""Fixtures shared by several test folders: paths to the real recorded logs (skipped when
../shared is absent), a baselines folder of its own, so tests never touch the committed
baselines, kartci as a user installs it (its wheel, once per session, in a fresh venv), and
shipped scenarios' full-length logs. A fixture one folder uses lives in that folder's
conftest.py; such a folder (and every folder between it and tests/) is a package, with an
`__init__.py`, so that mypy names its conftest `report.conftest` as pytest imports it (tests/
itself is no package: pytest's `prepend` import mode puts it on sys.path, where `helpers` is)."""

from __future__ import annotations

import fcntl
import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from kartci import portable
from kartci.project import current as active_project
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
                simulate(load_scenario(name, project=active_project()), log)
                done.touch()
        return log

    return get
